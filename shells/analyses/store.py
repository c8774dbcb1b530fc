"""Checkpoints and resume of the runs (analyses layer).

Checkpoints (a run's state at its last point, to resume from): ``save_checkpoint`` writes one
``.npz`` per MPI rank and then ``meta.json``, ``load_checkpoint`` reads them back (branch files'
``checkpoint/``, a post-buckling side's ``side_checkpoint/``). ``save_state_checkpoint`` and
``load_state_checkpoint`` do so for states of the surface model, each value with its node's
coordinates, so a checkpoint is read back on any partition of the same mesh (``shells branch``,
``shells critical``). ``resumable`` is a rerun's first step: the records of its file if they are
this run's (the same header), read on rank 0 and shared. The JSON-lines files themselves are
``shells.files``.
"""

from __future__ import annotations

import json
import logging
import os
import re
import zipfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from shells.errors import InputError
from shells.files import json_default, read_with_header

__all__ = ["CHECKPOINT_ERRORS", "load_checkpoint", "load_state_checkpoint", "read_meta",
           "resumable", "save_checkpoint", "save_state_checkpoint"]

log = logging.getLogger("shells")


def read_meta(path: str | os.PathLike, comm: Any) -> dict[str, Any] | None:
    """Read a checkpoint's ``meta.json`` on rank 0 and broadcast it.

    ``meta.json`` is written last, so its presence marks a complete checkpoint.

    Args:
        path: the ``meta.json`` file.
        comm: the communicator.

    Returns:
        The dict, or None (on every rank) if it is missing or not JSON.
    """
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
    """Write the checkpoint of point ``index`` in folder ``d`` (collective on ``comm``).

    This rank's arrays (and the index) go to ``state-RANK-of-SIZE.INDEX.npz`` (a temporary
    file renamed into place); rank 0 then writes ``meta.json``, the last file of a complete
    checkpoint, and only then are the earlier points' state files removed: a kill at any
    moment leaves a complete checkpoint, this point's or the previous one's.

    Args:
        d: the checkpoint's folder (created if needed).
        comm: the communicator.
        index: the point's index.
        arrays: this rank's arrays.
        meta: entries added to ``meta.json`` beside {"ranks": SIZE, "index": INDEX}.
    """
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
    """Read the checkpoint ``save_checkpoint`` wrote in ``d`` (collective).

    Args:
        d: the checkpoint's folder.
        comm: the communicator.
        every_rank: read every rank's file (a checkpoint read on any partition, which matches
            its values by what they hold); False: this rank's only (a checkpoint of this rank
            count only).
        check: asked of each file's dict of arrays; False rejects the checkpoint.

    Returns:
        (its meta, its state files, each read whole into a dict of arrays); None on every
        rank when it is missing or incomplete, a file cannot be read, holds another point,
        or fails ``check``.
    """
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
    """``save_checkpoint`` of point ``index`` for the surface model, readable on any partition.

    Each state is stored with the coordinates of its owned DOF nodes (``x``), so
    ``load_state_checkpoint`` can read it back on any partition of the same mesh (another rank
    count, or another partition of the same rank count). Collective.

    Args:
        d: the checkpoint's folder.
        model: the surface model.
        index: the point's index.
        states: {name: this rank's owned values, or the whole local array (its owned part is
            taken)}.
        scalars: stored beside the states.
        meta: entries of ``meta.json``.
    """
    x, bs = _owned_nodes(model)
    n = x.shape[0] * bs
    arrays: dict[str, Any] = {"x": x}
    for name, v in states.items():
        arrays[name] = np.asarray(v)[:n].reshape(-1, bs)
    arrays.update(scalars or {})
    save_checkpoint(d, model.shell.comm, index, arrays, meta)


def load_state_checkpoint(d: Path, model: Any, names: Sequence[str]
                          ) -> tuple[dict[str, Any], dict[str, np.ndarray], dict[str, Any]] | None:
    """Read the checkpoint ``save_state_checkpoint`` wrote in ``d`` onto this rank's partition.

    Nodes are matched by their coordinates. Collective.

    Args:
        d: the checkpoint's folder.
        model: the surface model, on the checkpoint's mesh.
        names: the states that must be there.

    Returns:
        (its meta, {name: this rank's owned values} for each of its states, the first file's
        other arrays: the scalars); None on every rank when it is missing, incomplete,
        unreadable, lacks one of ``names`` or is of another mesh.
    """
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
    """What a rerun finds in its JSON-lines file: its records, if they are this run's.

    Rank 0 reads the file and tells the others.

    Args:
        path: the run's file.
        header: this run's header.
        comm: the communicator.
        resume: False: ("--restart", []) without reading the file.
        ignore: header keys not compared.

    Returns:
        (None, its records) when the file is this run's (its header equals ``header``,
        ``ignore``'s keys aside) and holds records, else (why not, []).

    Raises:
        InputError: on every rank, if the file has a corrupt line.
    """
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
