"""Running the phase diagram's tasks (driver layer): dynamic claims over MPI ranks, the resumable
points file (``shells.analyses.store``), the θ̄_s bisection, then fits and figure
(``run``)."""

from __future__ import annotations

import json
import logging
import os
import time
import uuid
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from shells.errors import InputError
from shells.files import append_record, drop_torn_tail, json_default, read_records, write_atomic
from shells.theory import PAPER

__all__ = ["RunStats", "run"]

from shells.analyses.phase_diagram.config import PhaseDiagramConfig, Task, tasks_of
from shells.analyses.phase_diagram.figure import make_figure
from shells.analyses.phase_diagram.fits import fit_all, merge_points
from shells.analyses.phase_diagram.tracing import compute_task

log = logging.getLogger("shells")


# ------------------------------------------------------------------------------------------------
# the points file, claims and the parallel driver
# ------------------------------------------------------------------------------------------------
def _record_key(rec: dict[str, Any], signature: str) -> str:
    return Task(rec["h_over_R"], rec["thetabar"], rec["direction"]).key(signature)


@dataclass
class RunStats:
    """What a run did (summed over ranks by ``run``)."""

    computed: int = 0
    skipped_done: int = 0
    wall_time: float = 0.0
    per_rank: list[int] = field(default_factory=list)


def _run_tasks(tasks: list[Task], cfg: PhaseDiagramConfig, outdir: Path, comm: Any,
               limit: int | None, progress: Callable[[str], None]) -> int:
    """Compute the tasks not yet in the points file, claimed dynamically; returns how many this
    rank computed."""
    sig = cfg.signature()
    points = outdir / "points.jsonl"
    done: Any = None
    run_id = None
    if comm.rank == 0:
        try:
            drop_torn_tail(points)  # a write cut short: never continued by the next record
            done = {_record_key(r, sig) for r in read_records(points)
                    if r.get("status") == "ok" and r.get("signature", sig) == sig}
        except InputError as e:  # a corrupt file: refused on every rank, not used
            done = str(e)
        run_id = uuid.uuid4().hex[:12]
        if not isinstance(done, str):
            claims = outdir / ".claims" / run_id
            claims.mkdir(parents=True, exist_ok=True)
    done, run_id = comm.bcast((done, run_id), root=0)
    if isinstance(done, str):
        raise InputError(done)
    claims = outdir / ".claims" / run_id
    todo = [t for t in tasks if t.key(sig) not in done]
    mine = 0
    seen = base = len(read_records(points)) if comm.rank == 0 else 0
    total = len(todo) + len(done)
    for i, t in enumerate(todo):
        if limit is not None and mine >= limit:
            break
        try:
            fd = os.open(claims / f"{i:06d}", os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            continue
        os.close(fd)
        rec = compute_task(t, cfg)
        rec["signature"] = sig
        rec["rank"] = comm.rank
        append_record(points, rec)
        mine += 1
        if comm.rank == 0:  # progress: everything in the file so far (all ranks)
            recs = read_records(points)
            for k, r in enumerate(recs[seen:], start=seen + 1):
                progress(_progress_line(r, len(done) + k - base, total))
            seen = len(recs)
    comm.Barrier()
    if comm.rank == 0:
        recs = read_records(points)
        for k, r in enumerate(recs[seen:], start=seen + 1):
            progress(_progress_line(r, len(done) + k - base, total))
        for f in claims.iterdir():
            f.unlink()
        claims.rmdir()
    return mine


def _progress_line(r: dict[str, Any], k: int, n: int) -> str:
    f = r.get("first") or {}
    what = (f"{f.get('kind')} at kappa R = {f['kappa_R']:+.4f} (m = {f.get('mode_m')})"
            if f.get("kappa_R") is not None else r.get("error", f.get("kind", "?")))
    return (f"[{k}/{n}] h/R = {r['h_over_R']:g}, thetabar = {r['thetabar']:.3f}, "
            f"{r['direction']:>4}: {what}  (rank {r.get('rank')}, {r['wall_time']:.1f} s)")


def run(cfg: PhaseDiagramConfig, outdir: str | Path, comm: Any = None,
                      limit: int | None = None, figure: bool = True,
                      progress: Callable[[str], None] | None = None,
                      landings: list[dict[str, Any]] | None = None) -> dict[str, Any]:
    """Compute (or complete) a phase diagram in ``outdir``.

    Args:
        cfg: the diagram.
        outdir: the folder of ``points.jsonl``, ``phase_diagram.json`` and the figure; the
            tasks already in ``points.jsonl`` (same numerics) are not computed again.
        comm: the communicator whose ranks share the tasks (default ``MPI.COMM_WORLD``).
        limit: each rank computes at most this many new tasks in the grid phase (an
            interrupted run, for tests); the result then covers what exists.
        figure: also draw the figure.
        progress: called with one line per finished task (rank 0; default: the log).
        landings: where snapped caps landed (``read_landings``), shown in the figure and kept
            in the result (``landings``).

    Returns:
        The result, on every rank; ``result["stats"]`` says how many tasks this run computed
        (summed over ranks).
    """
    from mpi4py import MPI

    comm = comm or MPI.COMM_WORLD
    # PETSc's and SLEPc's initialisations (the first imports of dolfinx and slepc4py) and
    # finalisations are collective on MPI_COMM_WORLD: both are imported here by every rank,
    # not inside the first task a rank computes. Otherwise a rerun with fewer tasks left than
    # ranks hangs: in PetscInitialize (the rank with a task) against the barrier after the
    # tasks, and, with dolfinx imported here, at exit: SLEPc, initialised on the ranks that
    # computed a task only, is finalised there with an MPI_Comm_dup on COMM_WORLD that the
    # rank without a task never joins (it waits in MPI_Finalize); one EPS created on rank 0 of
    # two reproduces it.
    import dolfinx  # noqa: F401
    from slepc4py import SLEPc  # noqa: F401

    out = Path(outdir)
    if comm.rank == 0:
        out.mkdir(parents=True, exist_ok=True)
    comm.Barrier()
    say = progress or (lambda s: log.info(s))
    t0 = time.perf_counter()
    tasks, skipped = tasks_of(cfg)
    mine = _run_tasks(tasks, cfg, out, comm, limit, say if comm.rank == 0 else lambda s: None)
    # θ̄_s by bisection: one h/R per rank, sequential steps, each step a recorded task
    refined = 0
    if cfg.refine and limit is None:
        grid = [r for r in _current(out, cfg) if r.get("tag") == "grid"]
        brackets = comm.bcast(_snap_brackets(grid) if comm.rank == 0 else None, root=0)
        for j, (h, lo, hi) in enumerate(brackets):
            if j % comm.size != comm.rank:
                continue
            refined += _bisect_snap(h, lo, hi, cfg, out, comm.rank)
    comm.Barrier()
    computed = comm.allreduce(mine + refined, op=MPI.SUM)
    per_rank = comm.allgather(mine + refined)
    result = None
    if comm.rank == 0:
        recs = _current(out, cfg)
        points = merge_points(recs)
        fits = fit_all(points, cfg.nu)
        result = {"fits": fits["fits"], "fits_error": fits["fits_error"],
                  "fits_extra": fits["extra"], "points": points, "skipped": skipped,
                  "config": cfg.describe(), "points_file": str(out / "points.jsonl"),
                  "paper": {k: PAPER[k] for k in ("alpha", "beta", "b", "c", "thetabar_s",
                                                  "thetabar_c")},
                  "stats": asdict(RunStats(computed=computed, wall_time=time.perf_counter() - t0,
                                           per_rank=per_rank))}
        if landings:
            result["landings"] = landings
        if figure:
            result["figures"] = make_figure(result, out / "phase_diagram")
        write_atomic(out / "phase_diagram.json",
                     json.dumps(result, indent=1, default=json_default))
    return comm.bcast(result, root=0)


def _current(out: Path, cfg: PhaseDiagramConfig) -> list[dict[str, Any]]:
    """Records of this configuration (same numerics), last one per task."""
    sig = cfg.signature()
    hs = set(cfg.h_over_r)
    a, b = cfg.thetabar_range
    keep: dict[str, dict[str, Any]] = {}
    for r in read_records(out / "points.jsonl"):
        if r.get("signature") != sig or r.get("status") != "ok":
            continue
        if r["h_over_R"] not in hs or not (a - 1e-9 <= r["thetabar"] <= b + 1e-9):
            continue
        keep[_record_key(r, sig)] = r
    return list(keep.values())


def _snaps(rec: dict[str, Any]) -> bool:
    return rec.get("fold") is not None


def _snap_brackets(recs: list[dict[str, Any]]) -> list[tuple[float, float, float]]:
    """Per h/R: (h, θ̄ of the last no-snap point, θ̄ of the first snap point) if both exist."""
    out = []
    for h in sorted({r["h_over_R"] for r in recs}):
        ups = sorted((r for r in recs if r["h_over_R"] == h and r["direction"] == "up"),
                     key=lambda r: r["thetabar"])
        first = next((i for i, r in enumerate(ups) if _snaps(r)), None)
        if first is not None and first > 0:
            out.append((h, ups[first - 1]["thetabar"], ups[first]["thetabar"]))
    return out


def _bisect_snap(h: float, lo: float, hi: float, cfg: PhaseDiagramConfig, out: Path,
                 rank: int) -> int:
    sig = cfg.signature()
    done = {_record_key(r, sig): r for r in read_records(out / "points.jsonl")
            if r.get("signature") == sig and r.get("status") == "ok"}
    n = 0
    for _ in range(cfg.refine):
        mid = 0.5 * (lo + hi)
        t = Task(h, mid, "up", tag="refine")
        rec = done.get(t.key(sig))
        if rec is None:
            rec = compute_task(t, cfg)
            rec.update(signature=sig, rank=rank)
            append_record(out / "points.jsonl", rec)
            n += 1
        if rec.get("status") != "ok":
            break
        lo, hi = (lo, mid) if _snaps(rec) else (mid, hi)
    return n
