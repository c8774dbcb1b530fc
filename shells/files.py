"""The project's file formats (a shared leaf: no ``shells`` import but its errors).

JSON lines, the files runs append to as they compute (branch files, phase-diagram points,
post-buckling runs): one record per line. ``append_record`` writes a whole line with one
write(2) on an O_APPEND descriptor, under an exclusive ``flock`` (several processes append to
one file), and fsyncs it, so a crash leaves whole lines only. A write cut short anyway (a full
disk, a power loss) leaves a torn last line: an unterminated tail, which ``read_records`` skips
and the next ``append_record`` (or ``drop_torn_tail``) truncates before writing, so a new
record never continues a torn one. A terminated line that is not a JSON object is corruption,
not a torn write: ``read_records`` refuses the file (``InputError``: the CLI's one-line error,
exit 2) instead of using it. A file may start with a header record ``{"header": {...}}``
(``read_with_header``); ``write_header`` replaces a file by a new one holding only the header.

``write_atomic`` replaces any file by new text atomically (temporary file, fsync, then rename);
``read_number_rows`` reads the plain-text tables a user gives (a meridian, a curvature field);
``json_default`` serialises numpy scalars and arrays. ``hold_output_folder`` gives a run its
output folder to itself: a second run into a folder in use is refused (``InputError``), not
interleaved with the first.
"""

from __future__ import annotations

import fcntl
import json
import logging
import os
import re
import socket
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from shells.errors import InputError, on_rank_zero

__all__ = ["RUN_FILE", "append_record", "drop_torn_tail", "hold_output_folder", "json_default",
           "read_number_rows", "read_records", "read_with_header", "write_atomic", "write_header"]

log = logging.getLogger("shells")


def json_default(o: Any) -> Any:
    """``json.dumps``' ``default``: numpy scalars and arrays as Python numbers and lists.

    Args:
        o: the object ``json`` cannot serialise itself.

    Returns:
        Its Python equivalent.

    Raises:
        TypeError: for anything else.
    """
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
    """Truncate a torn (unterminated) last line of a file.

    Args:
        path: the file (nothing happens if it does not exist).

    Returns:
        The number of bytes dropped.
    """
    if not Path(path).exists():
        return 0
    fd = os.open(path, os.O_RDWR)
    try:
        _lock(fd)
        return _drop_tail(fd, path)
    finally:
        os.close(fd)


def append_record(path: str | os.PathLike, rec: dict[str, Any]) -> None:
    """Append one record as one line: one write(2) on an O_APPEND descriptor, flushed to disk.

    Under an exclusive lock, a torn last line left by a crash is truncated first.

    Args:
        path: the JSON-lines file.
        rec: the record (numpy values allowed, ``json_default``).
    """
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
    """The records of a JSON-lines file.

    Blank lines and a torn last line (unterminated: a write cut short, or one still being
    written by another process) are skipped.

    Args:
        path: the file.

    Returns:
        The records in order; none if the file does not exist.

    Raises:
        InputError: if a terminated line is not a JSON object (a corrupt file).
    """
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


#: the sidecar of a run folder's JSON-lines file: {"file": its name, "header": its header}
RUN_FILE = "run.json"


def read_with_header(path: str | os.PathLike) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """Read a JSON-lines file and its header: the folder's ``run.json`` where it names the
    file (``write_header(..., sidecar=True)``), else a record {"header": ...} in the file.

    Args:
        path: the file.

    Returns:
        (the header, or {} if there is none; the other records).

    Raises:
        InputError: as ``read_records``.
    """
    header: dict[str, Any] = {}
    side = Path(path).parent / RUN_FILE
    if side.exists():
        try:
            run = json.loads(side.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            run = None
        if isinstance(run, dict) and run.get("file") == Path(path).name:
            header = run.get("header") or {}
    recs = []
    for rec in read_records(path):
        if "header" in rec:
            header = rec["header"]
        else:
            recs.append(rec)
    return header, recs


def write_header(path: str | os.PathLike, header: dict[str, Any],
                 records: Sequence[dict[str, Any]] = (), *, sidecar: bool = False) -> None:
    """Replace a file, atomically, by its header and then ``records``.

    Args:
        path: the JSON-lines file.
        header: the header: the file's first record {"header": header}, or with ``sidecar``
            the folder's ``run.json``, so that the file holds records of one kind only (one
            table: ``pandas.read_json(path, lines=True)``).
        records: a resumed run's kept records.
        sidecar: write the header to ``run.json``. The file is replaced first: a kill between
            the two writes leaves the kept records under the old header, which a rerun of
            another configuration refuses and one of the same configuration reads as its own.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    head = [] if sidecar else [{"header": header}]
    write_atomic(path, "".join(json.dumps(r, default=json_default) + "\n"
                               for r in [*head, *records]))
    if sidecar:
        write_atomic(path.parent / RUN_FILE, json.dumps(
            {"file": path.name, "header": header}, indent=1, default=json_default))


def write_atomic(path: str | os.PathLike, text: str) -> None:
    """Replace a file by one holding ``text``, atomically.

    A temporary file in the same folder, flushed to disk, is renamed over it: a kill leaves the
    old file or the new one.

    Args:
        path: the file.
        text: its new contents.
    """
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(tmp, "w") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def read_number_rows(path: str | os.PathLike, what: str, rows: str,
                     columns: Sequence[Sequence[str]] = ()) -> tuple[tuple[float, ...], ...]:
    """The rows of numbers of a text table, as people and spreadsheets write them.

    Values are separated by spaces, tabs, commas or semicolons; blank lines and lines
    starting with # are skipped. A first row that holds no number is a header: its names
    (case, quotes and a unit in brackets, ``r (mm)``, ignored) pick the columns, in the order
    of the first set of ``columns`` they all name (``("r", "z")``: a header ``z,r`` reads
    its columns swapped); other columns are dropped.

    Args:
        path: the file.
        what: what the file is, for messages (e.g. "the meridian file").
        rows: what a row should hold, for messages (e.g. "'r z'").
        columns: the column sets a header may name, e.g. ``(("theta", "f"), ("x", "y", "z",
            "f"))``; empty: a header row is skipped and the columns taken as they stand.

    Returns:
        The rows, as tuples of floats.

    Raises:
        InputError: if the file cannot be read, its header names none of ``columns``, or it
            holds anything but numbers.
    """
    try:
        with open(path, encoding="utf-8-sig") as fh:
            text = [ln.strip() for ln in fh if ln.strip() and not ln.lstrip().startswith("#")]
        # a comma, semicolon or tab separates the values where the file uses one (then a
        # header's names may hold spaces: "r (mm)"), else spaces do
        sep = r"\s*[,;\t]\s*" if text and re.search(r"[,;\t]", text[0]) else r"\s+"
        lines = [re.split(sep, ln) for ln in text]
    except (OSError, UnicodeError) as e:
        raise InputError(f"cannot read {what} {str(path)!r}: "
                         f"{getattr(e, 'strerror', None) or e}") from None
    order = None
    if lines and not any(_is_number(v) for v in lines[0]):
        names = [re.sub(r"\s*[\[(].*$", "", v.strip("\"'")).strip().lower() for v in lines[0]]
        lines = lines[1:]
        for cols in columns:
            if all(c in names for c in cols):
                order = [names.index(c) for c in cols]
                break
        if columns and order is None:
            raise InputError(f"{what} {str(path)!r} has the header {', '.join(names)}"
                             f" but needs the columns {' or '.join(' '.join(c) for c in columns)}")
    try:
        table = [tuple(float(v) for v in ln) for ln in lines]
    except ValueError:
        raise InputError(f"{what} {str(path)!r} holds something other than numbers (rows "
                         f"{rows})") from None
    if order is not None:
        try:
            table = [tuple(row[i] for i in order) for row in table]
        except IndexError:
            raise InputError(f"{what} {str(path)!r}: a row is shorter than its header") from None
    return tuple(table)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


#: the lock file of a run's output folder, there while the run holds the folder
RUN_LOCK = ".shells-run.lock"


def _take_folder(folder: Path, label: str) -> tuple[int | None, list[Path]]:
    """Lock ``folder/RUN_LOCK`` exclusively without waiting, making the folder if missing.

    Returns:
        (the descriptor holding the lock, or None where the file system has no locks; the
        folders made for it, innermost first).

    Raises:
        InputError: another run holds the folder, or it cannot be written.
    """
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
    """Hold a run's output folder for the ``with`` block: one run at a time writes into it.

    Rank 0 of ``comm`` takes an exclusive ``flock`` on ``folder/RUN_LOCK`` (made with the
    folder if missing) without waiting and tells the others the outcome. The lock file is
    removed at the end, and so are the folders made for it if the run left them empty; the
    lock goes with the process however it ends. Where the file system has no locks the run
    goes on unlocked. Collective on ``comm``.

    Args:
        folder: the output folder.
        comm: the run's communicator.
        label: the folder's option, named in the error (e.g. "-o").

    Raises:
        InputError: on every rank, if another run holds the folder (naming its process and
            host: the CLI's one line, exit 2) or it cannot be written.
    """
    folder = Path(folder)
    taken = on_rank_zero(comm, lambda: _take_folder(folder, label),
                         f"cannot hold the output folder {str(folder)!r}")
    fd, made = taken if taken is not None else (None, [])
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
