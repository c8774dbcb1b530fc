"""The JSON-lines files that runs append to as they compute (driver layer): branch files,
phase-diagram points, post-buckling runs.

One record per line. ``append_record`` writes a whole line with one write(2) on an O_APPEND
descriptor, under an exclusive ``flock`` (several processes append to one file), and fsyncs it,
so a crash leaves whole lines only. A write cut short anyway (a full disk, a power loss) leaves
a torn last line: an unterminated tail, which ``read_records`` skips and the next
``append_record`` (or ``drop_torn_tail``) truncates before writing, so a new record never
continues a torn one. A terminated line that is not a JSON object is corruption, not a torn
write: ``read_records`` refuses the file (``InputError``: the CLI's one-line error, exit 2)
instead of using it. A file may start with a header record ``{"header": {...}}``
(``read_with_header``); ``write_header`` replaces a file by a new one holding only the header,
and ``write_atomic`` any file by new text, atomically (temporary file, fsync, then rename).
``read_number_rows`` reads the plain-text tables a user gives (a meridian, a curvature field).
``hold_output_folder`` gives a run its output folder to itself: a second run into a folder in
use is refused (``InputError``), not interleaved with the first.

Checkpoints (a run's state at its last point, to resume from): ``save_checkpoint`` writes one
``.npz`` per MPI rank and then ``meta.json``, ``load_checkpoint`` reads them back (branch files'
``checkpoint/``, a post-buckling side's ``side_checkpoint/``). ``save_state_checkpoint`` and
``load_state_checkpoint`` do so for states of the surface model, each value with its node's
coordinates, so a checkpoint is read back on any partition of the same mesh (``shells branch``,
``shells critical``). ``resumable`` is a rerun's first step: the records of its file if they are
this run's (the same header), read on rank 0 and shared.
"""

from __future__ import annotations

import fcntl
import json
import logging
import os
import re
import socket
import zipfile
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from shells.errors import InputError

__all__ = ["CHECKPOINT_ERRORS", "append_record", "drop_torn_tail", "json_default",
           "load_checkpoint", "load_state_checkpoint", "read_meta", "read_number_rows",
           "read_records", "read_with_header", "resumable", "save_checkpoint",
           "save_state_checkpoint", "write_atomic", "write_header", "hold_output_folder"]

log = logging.getLogger("shells")


def json_default(o: Any) -> Any:
    """JSON for numpy scalars and arrays."""
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def _torn_tail(fd: int) -> tuple[int, int]:
    """(file size, offset just past its last newline) of an open file: equal unless the file
    ends in a torn (unterminated) line."""
    size = os.fstat(fd).st_size
    end = size
    while end > 0:
        start = max(0, end - 65536)
        chunk = os.pread(fd, end - start, start)
        k = chunk.rfind(b"\n")
        if k >= 0:
            return size, start + k + 1
        end = start
    return size, 0


def _drop_tail(fd: int, path: str | os.PathLike) -> int:
    size, keep = _torn_tail(fd)
    if keep < size:
        os.ftruncate(fd, keep)
        os.fsync(fd)
        log.warning("%s: dropped a torn last line (%d bytes, a write cut short)", path,
                    size - keep)
    return size - keep


def _lock(fd: int) -> bool:
    """An exclusive lock on the open file, where the file system has locks (Lustre mounted
    without ``flock`` refuses them: the appends are then whole lines all the same, and a torn
    tail is dropped only by ``drop_torn_tail``, at the start of a run)."""
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
    except OSError:
        return False
    return True


def drop_torn_tail(path: str | os.PathLike) -> int:
    """Truncate a torn (unterminated) last line of ``path``; returns the bytes dropped."""
    if not Path(path).exists():
        return 0
    fd = os.open(path, os.O_RDWR)
    try:
        _lock(fd)
        return _drop_tail(fd, path)
    finally:
        os.close(fd)


def append_record(path: str | os.PathLike, rec: dict[str, Any]) -> None:
    """One line, one write(2) on an O_APPEND descriptor, flushed to disk. Under an exclusive
    lock, a torn last line left by an earlier crash is truncated first."""
    line = (json.dumps(rec, default=json_default) + "\n").encode()
    fd = os.open(path, os.O_RDWR | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        if _lock(fd):  # else another process may be writing the tail just now
            _drop_tail(fd, path)
        os.write(fd, line)
        os.fsync(fd)
    finally:
        os.close(fd)  # releases the lock


def read_records(path: str | os.PathLike) -> list[dict[str, Any]]:
    """The records of a file (none if it does not exist). Blank lines and a torn last line
    (unterminated: a write cut short, or one still being written by another process) are
    skipped; a terminated line that is not a JSON object raises ``InputError``."""
    path = Path(path)
    if not path.exists():
        return []
    lines = path.read_bytes().split(b"\n")
    out = []
    for i, line in enumerate(lines[:-1], start=1):  # lines[-1]: the unterminated tail
        if not line.strip():
            continue
        try:
            rec = json.loads(line)
        except (json.JSONDecodeError, UnicodeDecodeError):
            rec = None
        if not isinstance(rec, dict):
            raise InputError(f"{path}: line {i} is not a record (the file is corrupt and "
                             "cannot be trusted): move it away, or rerun with another output "
                             "folder")
        out.append(rec)
    return out


def read_with_header(path: str | os.PathLike) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """(header, the other records) of a file whose records may include {"header": ...}."""
    header: dict[str, Any] = {}
    recs = []
    for rec in read_records(path):
        if "header" in rec:
            header = rec["header"]
        else:
            recs.append(rec)
    return header, recs


def write_header(path: str | os.PathLike, header: dict[str, Any],
                 records: Sequence[dict[str, Any]] = ()) -> None:
    """Replace ``path`` by a file holding the header record and then ``records`` (a run's kept
    records when it resumes), atomically."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, "".join(json.dumps(r, default=json_default) + "\n"
                               for r in [{"header": header}, *records]))


def write_atomic(path: str | os.PathLike, text: str) -> None:
    """Replace ``path`` by a file holding ``text``: a temporary file in the same folder, flushed
    to disk, then renamed over it (a kill leaves the old file or the new one)."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(tmp, "w") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def read_meta(path: str | os.PathLike, comm: Any) -> dict[str, Any] | None:
    """A checkpoint's ``meta.json`` (written last, so its presence marks a complete
    checkpoint), read on rank 0 and broadcast: the dict, or None if it is missing or not
    JSON."""
    meta = None
    path = Path(path)
    if comm.rank == 0 and path.exists():
        try:
            meta = json.loads(path.read_text())
        except (OSError, json.JSONDecodeError):
            meta = None
    return comm.bcast(meta, root=0)


#: what reading a checkpoint's files may raise when they are missing, truncated or corrupt
CHECKPOINT_ERRORS = (OSError, ValueError, KeyError, TypeError, EOFError, zipfile.BadZipFile)


def save_checkpoint(d: Path, comm: Any, index: int, arrays: dict[str, Any],
                    meta: dict[str, Any] | None = None) -> None:
    """The checkpoint of point ``index`` in folder ``d``: this rank's ``arrays`` (and the
    index) to ``state-RANK-of-SIZE.INDEX.npz`` (a temporary file renamed into place); rank 0
    then writes ``meta.json`` ({"ranks": SIZE, "index": INDEX} and ``meta``'s entries), the
    last file of a complete checkpoint, and only then are the earlier points' state files
    removed: a kill at any moment leaves a complete checkpoint, this point's or the previous
    one's. Collective on ``comm``."""
    if comm.rank == 0:
        d.mkdir(parents=True, exist_ok=True)
    comm.barrier()
    stem = f"state-{comm.rank}-of-{comm.size}"
    p = d / f"{stem}.{index}.npz"
    tmp = d / f"{stem}.{index}.tmp.npz"
    np.savez(tmp, **arrays, index=index)
    os.replace(tmp, p)
    comm.barrier()
    if comm.rank == 0:
        tmp_meta = d / "meta.json.tmp"
        tmp_meta.write_text(json.dumps({"ranks": comm.size, "index": index, **(meta or {})},
                                       default=json_default))
        os.replace(tmp_meta, d / "meta.json")
    comm.barrier()
    for old in d.glob(f"{stem}.*.npz"):  # this rank's earlier points
        if old != p:
            old.unlink(missing_ok=True)
    if comm.rank == 0:  # files of a run on another rank count, or of an older layout
        for old in d.glob("state-*.npz"):
            m = re.fullmatch(r"state-\d+-of-(\d+)\.\d+\.npz", old.name)
            if m is None or int(m.group(1)) != comm.size:
                old.unlink(missing_ok=True)


def load_checkpoint(d: Path, comm: Any, *, every_rank: bool,
                    check: Callable[[Any], bool] | None = None
                    ) -> tuple[dict[str, Any], list[Any]] | None:
    """The checkpoint ``save_checkpoint`` wrote in ``d``: (its meta, its state files, each read
    whole into a dict of arrays): every rank's (``every_rank``: a checkpoint read on any
    partition, which matches its values by what they hold) or this rank's only (a checkpoint of
    this rank count only). None on every rank when it is missing or incomplete, a file cannot
    be read, holds another point, or fails ``check`` (asked of each file)."""
    from mpi4py import MPI

    meta = read_meta(d / "meta.json", comm)
    if meta is None:
        return None
    ok = True
    try:
        if not (every_rank or meta["ranks"] == comm.size):
            raise ValueError("another rank count")
        ranks = range(meta["ranks"]) if every_rank else (comm.rank,)
        parts = []
        for r in ranks:
            with np.load(d / f"state-{r}-of-{meta['ranks']}.{meta['index']}.npz") as z:
                parts.append(dict(z))  # read whole here: a corrupt member fails here
        ok = all(int(q["index"]) == meta["index"] and (check is None or check(q))
                 for q in parts)
    except CHECKPOINT_ERRORS:
        ok = False
    if not comm.allreduce(ok, op=MPI.LAND):
        return None
    return meta, parts


def _owned_nodes(model: Any) -> tuple[np.ndarray, int]:
    """Coordinates of this rank's owned DOF nodes of the surface model and the block size
    (values per node)."""
    return model.owned_dof_coordinates(), model.W.dofmap.index_map_bs


def save_state_checkpoint(d: Path, model: Any, index: int, states: dict[str, np.ndarray],
                          scalars: dict[str, float] | None = None,
                          meta: dict[str, Any] | None = None) -> None:
    """``save_checkpoint`` of point ``index`` for the surface model ``model``: each of ``states``
    (this rank's owned values, or the whole local array: its owned part is taken) with the
    coordinates of its owned DOF nodes (``x``), so ``load_state_checkpoint`` can read it back on
    any partition of the same mesh (another rank count, or another partition of the same rank
    count); ``scalars`` are stored beside them, ``meta`` in ``meta.json``. Collective."""
    x, bs = _owned_nodes(model)
    n = x.shape[0] * bs
    arrays: dict[str, Any] = {"x": x}
    for name, v in states.items():
        arrays[name] = np.asarray(v)[:n].reshape(-1, bs)
    arrays.update(scalars or {})
    save_checkpoint(d, model.shell.comm, index, arrays, meta)


def load_state_checkpoint(d: Path, model: Any, names: Sequence[str]
                          ) -> tuple[dict[str, Any], dict[str, np.ndarray], dict[str, Any]] | None:
    """The checkpoint ``save_state_checkpoint`` wrote in ``d``, on this rank's partition of
    ``model``'s mesh: (its meta, {name: this rank's owned values} for each of its states, the
    first file's other arrays: the scalars). Nodes are matched by their coordinates; None on
    every rank when it is missing, incomplete, unreadable, lacks one of the states ``names``
    or is of another mesh. Collective."""
    from mpi4py import MPI
    from scipy.spatial import cKDTree

    comm = model.shell.comm
    x, bs = _owned_nodes(model)
    got = load_checkpoint(d, comm, every_rank=True,
                          check=lambda q: all(q[k].ndim == 2 and q[k].shape[1] == bs
                                              for k in names))
    if got is None:
        return None
    meta, parts = got
    xs = np.concatenate([q["x"] for q in parts])
    dist, idx = cKDTree(xs).query(x)
    scale = max(float(np.ptp(xs, axis=0).max()), 1e-300)
    ok = xs.shape[0] == comm.allreduce(x.shape[0]) and bool(np.all(dist <= 1e-9 * scale))
    if not comm.allreduce(ok, op=MPI.LAND):
        return None
    held = [k for k, v in parts[0].items() if k != "x" and v.ndim == 2 and v.shape[1] == bs
            and all(k in q for q in parts)]
    states = {k: np.concatenate([q[k] for q in parts])[idx].ravel() for k in held}
    rest = {k: v for k, v in parts[0].items() if k not in ("x", "index", *held)}
    return meta, states, rest


def resumable(path: Path, header: dict[str, Any], comm: Any, *, resume: bool = True,
              ignore: Sequence[str] = ("dofs",)) -> tuple[str | None, list[dict[str, Any]]]:
    """What a rerun finds in its file ``path``: (None, its records) when it is this run's (its
    header equals ``header``, ``ignore``'s keys aside) and holds records, else (why not, []).
    Rank 0 reads it and tells the others; a file with a corrupt line is an ``InputError`` on
    every rank. ``resume`` False: ("--restart", []) without reading it."""
    if not resume:
        return "--restart", []
    old: Any = None
    if comm.rank == 0 and Path(path).exists():
        try:
            old = read_with_header(path)
        except InputError as e:
            old = str(e)
    old = comm.bcast(old, root=0)
    if isinstance(old, str):
        raise InputError(f"{old} (or --restart)")
    if old is None:
        return "there is none", []
    old_header, recs = old
    mine = {k: v for k, v in header.items() if k not in ignore}
    theirs = {k: v for k, v in old_header.items() if k not in ignore}
    if json.loads(json.dumps(mine, default=json_default)) != theirs:  # as JSON reads it back
        return "its configuration differs from this run's", []
    if not recs:
        return "it has no points", []
    return None, recs


def read_number_rows(path: str | os.PathLike, what: str, rows: str
                     ) -> tuple[tuple[float, ...], ...]:
    """The rows of numbers of a text table (spaces or commas; blank lines and lines starting
    with # skipped); an ``InputError`` naming ``what`` (e.g. "the meridian file") and the
    expected ``rows`` (e.g. "'r z'") if it cannot be read or holds anything else."""
    try:
        with open(path, encoding="utf-8") as fh:
            lines = [ln.replace(",", " ").split() for ln in fh
                     if ln.strip() and not ln.lstrip().startswith("#")]
    except (OSError, UnicodeError) as e:
        raise InputError(f"cannot read {what} {str(path)!r}: "
                         f"{getattr(e, 'strerror', None) or e}") from None
    try:
        return tuple(tuple(float(v) for v in ln) for ln in lines)
    except ValueError:
        raise InputError(f"{what} {str(path)!r} holds something other than numbers (rows "
                         f"{rows})") from None


#: the lock file of a run's output folder, there while the run holds the folder
RUN_LOCK = ".shells-run.lock"


def _take_folder(folder: Path, label: str) -> tuple[int | None, list[Path]]:
    """(descriptor holding ``folder/RUN_LOCK`` locked, the folders made for it, innermost
    first); descriptor None where the file system has no locks. ``InputError`` if another run
    holds it."""
    while True:
        made, p = [], folder
        while not p.exists():
            made.append(p)
            p = p.parent
        try:
            folder.mkdir(parents=True, exist_ok=True)
            fd = os.open(folder / RUN_LOCK, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        except FileNotFoundError:  # the folder was removed meanwhile by a run that ended
            continue
        except OSError as e:
            raise InputError(f"{label} {str(folder)!r} cannot be written: "
                             f"{e.strerror or e}") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 200, 0).decode(errors="replace").strip()
            os.close(fd)
            holder = f" ({holder})" if holder else ""
            raise InputError(f"{label} {str(folder)!r} is the output folder of a run in progress"
                             f"{holder}: wait for it to end, or give another folder") from None
        except OSError:  # no locks here (Lustre mounted without flock): the run goes unlocked
            os.close(fd)
            return None, made
        try:
            st = os.stat(folder / RUN_LOCK)
            same = (st.st_dev, st.st_ino) == (os.fstat(fd).st_dev, os.fstat(fd).st_ino)
        except FileNotFoundError:
            same = False
        if same:
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"pid {os.getpid()} on {socket.gethostname()}\n".encode(), 0)
            return fd, made
        os.close(fd)  # unlinked by the run that held it as it ended: take the file there now


@contextmanager
def hold_output_folder(folder: str | os.PathLike, comm: Any, label: str = "-o") -> Iterator[None]:
    """The output folder ``folder`` held by this run for the ``with`` block: an exclusive
    ``flock`` on ``folder/RUN_LOCK`` (made with the folder if missing), taken without waiting by
    rank 0 of ``comm``, which tells the others the outcome. If another run holds it, every rank
    raises ``InputError`` naming that run (the CLI's one line, exit 2). The lock file is removed
    at the end, and so are the folders made for it if the run left them empty; the lock goes
    with the process however it ends. Where the file system has no locks the run goes on
    unlocked. Collective on ``comm``."""
    folder = Path(folder)
    fd, made, err = None, [], None
    if comm.rank == 0:
        try:
            fd, made = _take_folder(folder, label)
        except InputError as e:
            err = str(e)
        except Exception as e:  # never leave the other ranks waiting in the broadcast
            err = f"cannot hold the output folder {str(folder)!r}: {type(e).__name__}: {e}"
    if comm.size > 1:
        err = comm.bcast(err, root=0)
    if err:
        raise InputError(err)
    try:
        yield
    finally:
        if fd is not None:
            # unlinked while held: a run that opened it meanwhile finds another file at the
            # path (or none) once it has the lock, and takes that one
            try:
                os.unlink(folder / RUN_LOCK)
            except OSError:
                pass
            os.close(fd)
            for p in made:  # innermost first; a folder with anything in it stays
                try:
                    p.rmdir()
                except OSError:
                    break
