"""Kill and resume: the commands killed at random moments, rerun to the end, results compared.

``shells branch``, ``shells critical`` (both models) and ``shells phase-diagram`` killed with
SIGKILL at random moments, on 1 and 2 ranks, then rerun to the end; the final results must
equal an uninterrupted run's and no point computed before a kill may be lost.

    scripts/in-env python3 benchmarks/reliability.py [--trials 3] [--kills 2] [--seed 16]
        [--ranks 1 2] [--cases ...] [-o benchmarks/results/reliability.json]

Run it serially (not under mpirun): it starts every run itself, as ``python3 -m shells ...`` or
``mpirun -n 2 python3 -m shells ...`` in a new session, and a kill is SIGKILL to the whole
process group (mpirun and its ranks at once: a node lost, a job killed by the scheduler). Kill
moments are uniform in (0.1, 0.95) of the uninterrupted run's wall time, from a seeded RNG
(reproducible but for the machine's speed). A trial kills the same output folder ``--kills``
times in a row, then lets the rerun finish; one trial per case and rank count also tears the
last line of the points file (half a record, no newline) before the final rerun.

Checks per trial: the final run exits 0; its records equal the uninterrupted run's (the same
count, every number to 1e-10 relative, timings excluded; on 2 ranks the few numbers that
parallel MUMPS does not reproduce bit for bit even between uninterrupted runs to
``PARALLEL_RTOL``); every record on disk after each kill is in the final file with the same
numbers (none lost); the torn line is gone. ``branch`` and ``critical-surface`` (surface
model: ``shells critical``'s points, critical points and ``critical.json``) and
``phase-diagram`` resume (checkpoint / points file); ``branch --model axisym`` and
``critical`` (the 1D model) have no checkpoint and compute the whole run again (seconds).

Also counted: SIGINT and SIGTERM (one line on stderr, exit 130 / 143, then resumed to identical
results; on 2 ranks sent to the ranks, as a batch scheduler does), one exception on one rank of
two (``inject_rank_failure``: all ranks end within seconds, the message printed once), and the
surface model's critical points of a cap and of the sphere on 1 and on 2 ranks (located kappa
to 1e-8, ``rank_identity``).

Writes ``benchmarks/results/reliability.json`` and prints a table. ``tests/test_reliability.py``
runs single trials of these (``run``, ``records``, ``compare``, ``CASES``).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import random
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
RTOL = 1e-10
#: a run that takes longer is a hang (the runs take seconds)
TIMEOUT = 150.0
#: fields that are timings or bookkeeping, not results (``locator_accuracy`` is a copy of
#: ``accuracy``, compared there under the scale of all the run's accuracies)
SKIP = {"wall_time", "rank", "signature", "locator_accuracy"}

#: Open MPI variables of the environment (scripts/in-env) that a nested mpirun may inherit; every
#: other OMPI_/PMIX_/PRTE_ variable belongs to a running job (ours, under mpirun) and would
#: make the child join it
_KEEP_MPI = {"OMPI_ALLOW_RUN_AS_ROOT", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "OMPI_MCA_btl",
             "OMPI_MCA_btl_vader_single_copy_mechanism", "OMPI_MCA_rmaps_base_oversubscribe",
             "OMPI_MCA_btl_base_warn_component_unused"}


def clean_env(**extra: str) -> dict[str, str]:
    """The environment for a child run: no variable of a running MPI job."""
    env = {k: v for k, v in os.environ.items()
           if k in _KEEP_MPI or not k.startswith(("OMPI_", "PMIX_", "PRTE_"))}
    env.update(extra)
    return env


#: fields that runs on several ranks do not reproduce bit for bit, with the relative tolerance
#: they are compared to there (leaf names, or the ends of their paths). Parallel MUMPS
#: schedules its work dynamically, so the order of its floating-point operations, and the
#: round-off of every solve, changes from run to run; most numbers still agree to 1e-11, but
#: the round-off of these is amplified: dκ/ds (the tangent, a solve with the stiff
#: Kirchhoff-Love penalty's Jacobian; it tends to 0 at a fold) and, at a located critical
#: point, its eigenvalue nearest 0 (SLEPc, converged to its tolerance), the mode's orbit and
#: Rayleigh quotient, and the location's accuracy estimate (a bracket's width). Measured on the
#: ``critical-surface`` case, three uninterrupted 2-rank runs against a fourth: dκ/ds 2.2e-10
#: (of its largest value), eigenvalue 1.2e-7, accuracy 2.1e-7, orbit 1.4e-8, the quotient
#: 2.3e-10, the located κ 1.7e-12 (compared to ``RTOL``); the campaign's 4 resumed 2-rank runs
#: (benchmarks/results/reliability.json): 6.0e-10, 3.4e-8, 6.3e-8, 9.4e-8, 1.6e-10, and every
#: other number 5.8e-12. On one rank every run is the same to the last bit. A bifurcation's
#: accuracy also holds a measured round-off (``shells.algorithms.locate.EIGEN_ROUNDOFF``: the
#: change of its eigenvalue when the point is solved again at κ (1 ± 1e-10)), itself a difference of
#: round-offs:
#: compared as an order of magnitude there (0.9: within a factor 10). The fold's mode is
#: axisymmetric (m = 0, named by the state tangent): its m² quotient is the leakage into
#: m ≥ 1, 2.1e-4, a ratio of small numbers whose round-off is 1.7e-13 absolute, 8e-10 of it
#: (two resumed 2-rank runs against the uninterrupted one).
PARALLEL_RTOL: dict[str, float] = {"dkappa_ds": 1e-8, "eigenvalue": 1e-5, "accuracy": 0.9,
                                   "mode_rayleigh.orbit": 1e-5, "mode_rayleigh.x": 1e-8,
                                   "mode_rayleigh.m2": 1e-8}


@dataclass
class Case:
    """One command: its arguments (``-o`` is added), the files of its records, whether it
    resumes, and the fields compared with ``PARALLEL_RTOL`` on several ranks (``parallel``)."""

    name: str
    argv: list[str]
    files: list[str]
    resumes: bool
    parallel: bool = False

    def field_rtol(self, ranks: int) -> dict[str, float] | None:
        """The per-field tolerances of ``compare`` for a run on ``ranks`` ranks."""
        return PARALLEL_RTOL if self.parallel and ranks > 1 else None


CASES: dict[str, Case] = {c.name: c for c in [
    # surface model, pseudo-arclength: 5196 DOFs, about 18 points in a few seconds
    Case("branch", ["branch", "--shape", "sphere", "--h-over-r", "0.05", "--kappa-h-max", "1",
                    "--size", "0.3", "--degree", "2", "--ds", "0.5", "--ds-max", "2"],
         ["branch.jsonl"], True),
    # 1D model through the snap-through of a 30 degree cap (two folds)
    Case("branch-axisym", ["branch", "--model", "axisym", "--shape", "cap", "--theta-deg", "30",
                           "--h-over-r", "0.04", "--kappa-r-max", "3"], ["branch.jsonl"], False),
    Case("critical", ["critical", "--model", "axisym", "--shape", "cap", "--theta-deg", "30",
                      "--h-over-r", "0.04"], ["critical.json"], False),
    # surface model: a coarse 30 degree cap (3078 DOFs) to its fold, 10 points in about 2 s;
    # its points and critical points as computed, the result at the end
    Case("critical-surface", ["critical", "--shape", "cap", "--theta-deg", "30", "--h-over-r",
                              "0.04", "--size", "0.4", "--layer-elements", "2", "--degree",
                              "2"], ["branch.jsonl", "critical.json"], True, parallel=True),
    Case("phase-diagram", ["phase-diagram", "--h-over-r", "0.04", "--thetabar-range", "1.5",
                           "3.5", "--points", "2", "--refine", "1", "--m-max", "4",
                           "--no-figure"], ["points.jsonl"], True),
]}


@dataclass
class Run:
    rc: int | None
    seconds: float
    stderr: str
    signalled: str | None = None


def command(argv: list[str], ranks: int) -> list[str]:
    cmd = [sys.executable, "-m", "shells", *argv]
    return cmd if ranks == 1 else ["mpirun", "-n", str(ranks), *cmd]


def _session_alive(sid: int) -> list[int]:
    """Processes of session ``sid`` still running (an orphaned rank would be one)."""
    out = []
    for p in Path("/proc").iterdir():
        if not p.name.isdigit():
            continue
        try:
            stat = (p / "stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2:].split()
        if fields[0] != "Z" and int(fields[3]) == sid:
            out.append(int(p.name))
    return out


def _finish(p: subprocess.Popen, timeout: float) -> tuple[str, bool, list[int]]:
    """Wait for a job started in a new session: (stderr, hung, processes left). A hung job is
    killed whole, its ranks too (Open MPI puts each in its own process group, out of reach of
    a kill of mpirun's), as are processes left after it ended."""
    try:
        _, err = p.communicate(timeout=timeout)
        hung = False
    except subprocess.TimeoutExpired:
        hung = True
        _kill(_session_alive(p.pid))
        _, err = p.communicate()
    left = _session_alive(p.pid)
    _kill(left)
    return err, hung, left


def _kill(pids: list[int]) -> None:
    for q in pids:
        try:
            os.kill(q, signal.SIGKILL)
        except ProcessLookupError:
            pass


def run(argv: list[str], out: Path, ranks: int = 1, *, after: float | None = None,
        sig: int = signal.SIGKILL, wait_for: Callable[[], bool] | None = None,
        timeout: float | None = None,
        env: dict[str, str] | None = None) -> Run:
    """``shells ARGV -o OUT`` on ``ranks`` ranks; with ``after``, signal ``sig`` at that many
    seconds (counted from the moment ``wait_for()`` is true, if given): SIGKILL to every process
    of the run (mpirun and its ranks: Open MPI puts each rank in its own process group), and
    SIGINT/SIGTERM to the ranks, as a batch scheduler does (to mpirun, they make it end the
    ranks itself, silently: exit 1, the files whole)."""
    t0 = time.perf_counter()
    p = subprocess.Popen(command([*argv, "-o", str(out)], ranks), cwd=REPO,
                         env=env or clean_env(), stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE, text=True, start_new_session=True)
    signalled = None
    try:
        if after is not None:
            t_ref = time.perf_counter()
            if wait_for is not None:
                while not wait_for() and p.poll() is None:
                    time.sleep(0.02)
                t_ref = time.perf_counter()
            while p.poll() is None and time.perf_counter() - t_ref < after:
                time.sleep(0.01)
            if p.poll() is None:
                signalled = signal.Signals(sig).name
                pids = [p.pid] if ranks == 1 else _session_alive(p.pid)
                if sig != signal.SIGKILL and ranks > 1:
                    pids = [q for q in pids if q != p.pid]
                for q in pids:
                    try:
                        os.kill(q, sig)
                    except ProcessLookupError:
                        pass
        _, err = p.communicate(timeout=timeout or TIMEOUT)
    except subprocess.TimeoutExpired:
        for q in _session_alive(p.pid):
            os.kill(q, signal.SIGKILL)
        _, err = p.communicate()
        return Run(None, time.perf_counter() - t0, err + "\n[timeout]", signalled)
    # a killed job leaves no process behind (no orphaned rank still writing the files)
    t_end = time.perf_counter() + 10
    while _session_alive(p.pid) and time.perf_counter() < t_end:
        time.sleep(0.05)
    left = _session_alive(p.pid)
    if left:
        for pid in left:
            os.kill(pid, signal.SIGKILL)
        err += f"\n[orphaned processes {left}]"
    if signalled is not None and ranks > 1:
        _remove_session_dirs(p.pid)
    return Run(p.returncode, time.perf_counter() - t0, err, signalled)


def _remove_session_dirs(pid: int) -> None:
    """The session folder of an mpirun that a signal ended (``prterun.<host>.<pid>.<n>`` in
    the temporary folder): left behind, it makes a later mpirun that gets the same process id
    fail to start ("PMIX_ERR_EXISTS ... prte_session_dir failed", seen on a machine with 113
    such folders from earlier campaigns)."""
    import shutil
    import tempfile

    for d in Path(tempfile.gettempdir()).glob(f"prterun.*.{pid}.*"):
        shutil.rmtree(d, ignore_errors=True)


def records(out: Path, case: Case) -> list[dict[str, Any]]:
    """The results on disk: the records of the case's files (a torn last line skipped)."""
    from shells.files import read_records

    recs: list[dict[str, Any]] = []
    for name in case.files:
        f = out / name
        if not f.exists():
            continue
        if f.suffix == ".json":
            try:
                recs.append(json.loads(f.read_text()))
            except json.JSONDecodeError:
                recs.append({"unreadable": name})
        else:
            recs.extend(r for r in read_records(f) if "header" not in r)
    return recs


def record_key(rec: dict[str, Any]) -> str:
    if "critical_point" in rec and "number" in rec:
        return f"critical point {rec['number']}"
    if "index" in rec:
        return f"point {rec['index']}"
    if "thetabar" in rec:
        return f"{rec['h_over_R']:g}/{rec['thetabar']:.9g}/{rec['direction']}/{rec.get('tag')}"
    return "result"


def _leaves(x: Any, path: str = "") -> dict[str, Any]:
    if isinstance(x, dict):
        out: dict[str, Any] = {}
        for k, v in x.items():
            if k not in SKIP:
                out.update(_leaves(v, f"{path}.{k}"))
        return out
    if isinstance(x, list):
        out = {}
        for i, v in enumerate(x):
            out.update(_leaves(v, f"{path}[{i}]"))
        return out
    return {path: x}


def compare(ref: list[dict[str, Any]], got: list[dict[str, Any]], rtol: float = RTOL,
            subset: bool = False, field_rtol: dict[str, float] | None = None
            ) -> tuple[list[str], float]:
    """Differences between two record lists (matched by index / task; ``subset``: every record
    of ``got`` must be in ``ref``, not the reverse) and the largest relative difference of the
    fields compared to ``rtol``. A value of κ (a field named kappa...) is compared relative to
    itself; any other number relative to the largest magnitude of that field over ``ref`` (a
    branch's energies and displacements pass through 0 at κ = 0). ``field_rtol``: fields
    (leaf names or the ends of their paths) compared to their own tolerance instead
    (``PARALLEL_RTOL``)."""
    field_rtol = field_rtol or {}

    def tolerance(f: str) -> float | None:
        return next((t for k, t in field_rtol.items() if f.endswith("." + k)), None)

    a = {record_key(r): _leaves(r) for r in ref}
    b = {record_key(r): _leaves(r) for r in got}
    scale: dict[str, float] = {}
    for leaves in a.values():
        for f, u in leaves.items():
            if isinstance(u, (int, float)) and not isinstance(u, bool) and math.isfinite(u):
                scale[f] = max(scale.get(f, 0.0), abs(u))
    diffs: list[str] = []
    worst = 0.0
    if len(b) != len(got) or len(a) != len(ref):
        diffs.append("a record appears twice")
    missing = set(b) - set(a) if subset else set(a) ^ set(b)
    diffs += [f"{k}: only in one of them" for k in sorted(missing)]
    for k in sorted(set(a) & set(b)):
        if set(a[k]) != set(b[k]):
            diffs.append(f"{k}: fields {sorted(set(a[k]) ^ set(b[k]))}")
            continue
        for f, u in a[k].items():
            v = b[k][f]
            if isinstance(u, (int, float)) and isinstance(v, (int, float)) \
                    and not isinstance(u, bool):
                if u == v or (math.isnan(u) and math.isnan(v)):
                    continue
                own = f.rsplit(".", 1)[-1].startswith("kappa")
                rel = abs(u - v) / max(abs(u), abs(v), 0.0 if own else scale.get(f, 0.0))
                tol = tolerance(f)
                if tol is None:
                    worst = max(worst, rel)
                if rel > (rtol if tol is None else tol):
                    diffs.append(f"{k}{f}: {u!r} != {v!r} (rel {rel:.1e})")
            elif u != v:
                diffs.append(f"{k}{f}: {u!r} != {v!r}")
    return diffs, worst


def tear(out: Path, case: Case) -> bool:
    """Append half of the last record (of a made-up one if there is none), without its
    newline: a write cut short."""
    f = out / case.files[0]
    if f.suffix != ".jsonl":
        return False
    f.parent.mkdir(parents=True, exist_ok=True)
    lines = f.read_text().splitlines() if f.exists() else []
    last = lines[-1] if lines else '{"index": 0, "kappa_R": 0.0, "torn": true}'
    with open(f, "a") as fh:
        fh.write(last[: len(last) // 2])
    return True


@dataclass
class Trial:
    case: str
    ranks: int
    kill_at: list[float] = field(default_factory=list)
    killed: int = 0
    on_disk_after_kills: list[int] = field(default_factory=list)
    torn: bool = False
    final_rc: int | None = None
    worst_rel: float = 0.0
    problems: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.problems


def trial(case: Case, ranks: int, out: Path, ref: list[dict[str, Any]], t_ref: float,
          rng: random.Random, kills: int, torn: bool = False) -> Trial:
    """Kill ``kills`` runs in a row in ``out`` at random moments, then finish; check."""
    t = Trial(case.name, ranks)
    seen: dict[str, dict[str, Any]] = {}  # every record on disk after a kill, by point / task
    for _ in range(kills):
        at = rng.uniform(0.1, 0.95) * t_ref
        t.kill_at.append(round(at, 3))
        r = run(case.argv, out, ranks, after=at)
        if r.rc is None or "orphaned" in r.stderr:
            t.problems.append(f"killed run: {r.stderr.strip()[-300:]}")
        if r.signalled:
            t.killed += 1
        now = records(out, case)
        t.on_disk_after_kills.append(len(now))
        seen.update((record_key(r), r) for r in now if "unreadable" not in r)
    if torn:
        t.torn = tear(out, case)
    final = run(case.argv, out, ranks)
    t.final_rc = final.rc
    if final.rc != 0:
        t.problems.append(f"final run exit {final.rc}: {final.stderr.strip()[-300:]}")
        return t
    got = records(out, case)
    diffs, t.worst_rel = compare(ref, got, field_rtol=case.field_rtol(ranks))
    t.problems += diffs[:5]
    # no computed point lost: every record seen after a kill is in the final results
    if case.resumes:
        lost, _ = compare(got, list(seen.values()), subset=True,
                          field_rtol=case.field_rtol(ranks))
        t.problems += [f"lost: {d}" for d in lost[:5]]
    if t.torn and (out / case.files[0]).read_bytes()[-1:] != b"\n":
        t.problems.append("the torn line is still there")
    return t


def interrupt(case: Case, ranks: int, out: Path, ref: list[dict[str, Any]], sig: int,
              after: float) -> dict[str, Any]:
    """SIGINT or SIGTERM ``after`` seconds past the first record; one line, 130 / 143, and the
    rerun gives the uninterrupted results."""
    first = out / case.files[0]
    r = run(case.argv, out, ranks, after=after, sig=sig,
            wait_for=first.exists if first.suffix == ".jsonl" else None)
    lines = [ln for ln in r.stderr.splitlines() if ln.startswith("shells:")]
    want = 130 if sig == signal.SIGINT else 143
    problems = []
    if r.signalled is None:
        problems.append("ended before the signal")
    else:
        if r.rc != want:
            problems.append(f"exit {r.rc}, not {want}")
        if len(lines) != 1 or "interrupted" not in lines[0] or "Traceback" in r.stderr:
            problems.append(f"stderr: {r.stderr.strip()[-300:]}")
    on_disk = records(out, case)
    final = run(case.argv, out, ranks)
    tols = case.field_rtol(ranks)
    diffs, worst = (compare(ref, records(out, case), field_rtol=tols) if final.rc == 0
                    else ([f"rc {final.rc}"], 0))
    lost, _ = compare(records(out, case), on_disk, subset=True, field_rtol=tols)
    return {"case": case.name, "ranks": ranks, "signal": signal.Signals(sig).name,
            "exit": r.rc, "message": lines[-1] if lines else None, "worst_rel": worst,
            "problems": problems + diffs[:5] + [f"lost: {d}" for d in lost[:5]]}


#: the surface model's critical points on 1 and 2 ranks (a partitioned mesh, parallel MUMPS):
#: the located kappa must agree to 1e-8
IDENTITY: dict[str, list[str]] = {
    "cap": ["critical", "--shape", "cap", "--theta-deg", "30", "--h-over-r", "0.04", "--size",
            "0.3", "--degree", "2"],
    "sphere": ["critical", "--shape", "sphere", "--h-over-r", "0.05", "--size", "0.4",
               "--first-only"],
}


def rank_identity(name: str, work: Path, rtol: float = 1e-8) -> dict[str, Any]:
    """``shells critical`` (surface model) on 1 and on 2 ranks: the critical points' kind,
    mode and located kappa R (to ``rtol``)."""
    runs = {}
    for ranks in (1, 2):
        out = work / f"identity-{name}-{ranks}"
        r = run(IDENTITY[name], out, ranks)
        if r.rc != 0:
            return {"case": name, "problems": [f"{ranks} rank(s): exit {r.rc}: "
                                               f"{r.stderr.strip()[-300:]}"]}
        res = json.loads((out / "critical.json").read_text())
        runs[ranks] = ([(c["kind"], c["mode_m"], c["mode_n"], c["kappa_R"])
                        for c in res["critical_points"]], round(r.seconds, 1))
    (a, ta), (b, tb) = runs[1], runs[2]
    rels = [abs(x[3] - y[3]) / abs(x[3]) for x, y in zip(a, b, strict=False)]
    problems = []
    if [x[:3] for x in a] != [y[:3] for y in b]:
        problems.append(f"kinds/modes differ: {a} != {b}")
    if any(r > rtol for r in rels):
        problems.append(f"kappa R differs: {a} != {b}")
    return {"case": name, "critical_points": [list(x) for x in a],
            "kappa_R_2_ranks": [y[3] for y in b], "worst_rel": max(rels, default=0.0),
            "seconds": {"1": ta, "2": tb}, "problems": problems}


#: a driver that raises on one rank only, inside a collective run: the CLI's failure path
RANK_FAILURE = """
import os, sys
from mpi4py import MPI
from shells.analyses import branch
from shells.cli import main

real = branch.run_axisym

def failing(*args, **kwargs):
    if MPI.COMM_WORLD.rank == int(os.environ["FAIL_RANK"]):
        raise RuntimeError("injected failure on one rank")
    MPI.COMM_WORLD.barrier()  # the healthy ranks wait for the failed one, as in a collective
    return real(*args, **kwargs)

branch.run_axisym = failing
sys.exit(main(sys.argv[1:]))
"""


#: a phase diagram whose every task falls to rank 0: the other rank finds each claimed
#: (a rerun with fewer tasks left than ranks; the claims race made it occasional)
RANK_IDLE = """
import os, sys
from mpi4py import MPI
from shells.cli import main

real_open = os.open

def claim(path, *args, **kwargs):
    if ".claims" in str(path) and MPI.COMM_WORLD.rank != 0:
        raise FileExistsError(path)
    return real_open(path, *args, **kwargs)

os.open = claim
sys.exit(main(sys.argv[1:]))
"""


def _run_script(out: Path, name: str, text: str, case: str, ranks: int, timeout: float,
                **env: str) -> tuple[subprocess.Popen, str, bool, list[int], float]:
    """``text`` written to ``out/name`` and run on ``ranks`` ranks with the arguments of
    ``CASES[case]`` (output ``out/run``), in a new session: (process, stderr, hung, processes
    left, seconds)."""
    script = out / name
    out.mkdir(parents=True, exist_ok=True)
    script.write_text(text)
    argv = [*CASES[case].argv, "-o", str(out / "run")]
    cmd = ["mpirun", "-n", str(ranks), sys.executable, str(script), *argv]
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, cwd=REPO, env=clean_env(**env), stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE, text=True, start_new_session=True)
    err, hung, left = _finish(p, timeout)
    return p, err, hung, left, round(time.perf_counter() - t0, 2)


def idle_rank(out: Path, ranks: int = 2, timeout: float = 60.0) -> dict[str, Any]:
    """``shells phase-diagram`` with every task on rank 0 and none on the others: all ranks
    must end (it hung at exit: SLEPc initialised on rank 0 only, ``phase_diagram.jobs``)."""
    from shells.files import read_records

    p, err, hung, left, seconds = _run_script(out, "idle_rank.py", RANK_IDLE, "phase-diagram",
                                              ranks, timeout)
    pts = out / "run" / "points.jsonl"
    recs = read_records(pts) if pts.exists() else []
    return {"ranks": ranks, "exit": p.returncode, "hung": hung, "seconds": seconds,
            "points": len(recs), "ranks_that_computed": sorted({r.get("rank") for r in recs}),
            "traceback": "Traceback" in err, "left": left}


def inject_rank_failure(out: Path, fail_rank: int = 1, ranks: int = 2,
                        timeout: float = 60.0) -> dict[str, Any]:
    """An exception on rank ``fail_rank`` only: every rank ends within seconds, exit 1, the
    message once on stderr."""
    p, err, hung, left, seconds = _run_script(out, "fail_one_rank.py", RANK_FAILURE,
                                              "branch-axisym", ranks, timeout,
                                              FAIL_RANK=str(fail_rank))
    msgs = [ln for ln in err.splitlines() if "injected failure" in ln]
    return {"ranks": ranks, "fail_rank": fail_rank, "exit": p.returncode, "hung": hung,
            "seconds": seconds, "messages": len(msgs),
            "message": msgs[0] if msgs else None, "traceback": "Traceback" in err,
            "left": left}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=3, help="trials per case and rank count")
    ap.add_argument("--kills", type=int, default=2, help="SIGKILLs in a row per trial")
    ap.add_argument("--seed", type=int, default=16)
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    ap.add_argument("--identity", nargs="*", default=list(IDENTITY), choices=list(IDENTITY),
                    help="surface critical points compared on 1 and 2 ranks")
    ap.add_argument("--work", default="scratch/reliability", help="scratch folder")
    ap.add_argument("-o", default="benchmarks/results/reliability.json")
    a = ap.parse_args()
    if "OMPI_COMM_WORLD_RANK" in os.environ:
        sys.exit("run this serially: it starts its own mpirun")
    rng = random.Random(a.seed)
    work = (REPO / a.work).resolve()
    subprocess.run(["rm", "-rf", str(work)], check=True)
    work.mkdir(parents=True)
    rows, trials, interrupts = [], [], []
    t_all = time.perf_counter()
    for name in a.cases:
        case = CASES[name]
        for ranks in a.ranks:
            ref_dir = work / f"{name}-{ranks}-ref"
            r = run(case.argv, ref_dir, ranks)
            if r.rc != 0:
                sys.exit(f"{name} on {ranks} rank(s): reference run failed: {r.stderr}")
            ref = records(ref_dir, case)
            ts = [trial(case, ranks, work / f"{name}-{ranks}-{i}", ref, r.seconds, rng,
                        a.kills, torn=i == 0) for i in range(a.trials)]
            trials += ts
            sig = (signal.SIGTERM, signal.SIGINT)[(len(interrupts)) % 2]
            appends = (ref_dir / case.files[0]).suffix == ".jsonl"  # else: from the start
            it = interrupt(case, ranks, work / f"{name}-{ranks}-sig", ref, sig,
                           after=rng.uniform(*((0.05, 0.3) if appends else (0.4, 0.8)))
                           * r.seconds)
            interrupts.append(it)
            row = {"case": name, "ranks": ranks, "reference_s": round(r.seconds, 2),
                   "reference_records": len(ref), "trials": len(ts),
                   "kills": sum(t.killed for t in ts),
                   "kills_survived": sum(t.killed for t in ts if t.ok),
                   "torn_lines_dropped": sum(t.torn and t.ok for t in ts),
                   "worst_rel": max(t.worst_rel for t in ts),
                   "failed_trials": sum(not t.ok for t in ts),
                   "interrupt": f"{it['signal']} -> {it['exit']}"
                                + ("" if not it["problems"] else " FAILED")}
            rows.append(row)
            Path(a.o).write_text(json.dumps({"partial": True, "rows": rows,
                                             "trials": [t.__dict__ for t in trials],
                                             "interrupts": interrupts}, indent=1) + "\n")
            print(f"{name:>14} {ranks} rank(s): {row['kills_survived']}/{row['kills']} kills "
                  f"survived, worst rel {row['worst_rel']:.1e}, {row['interrupt']}", flush=True)
    faults = [inject_rank_failure(work / f"fault-{k}", fail_rank=k) for k in (1, 0)]
    identity = [rank_identity(n, work) for n in a.identity]
    result = {
        "seed": a.seed, "kills_per_trial": a.kills, "rtol": RTOL,
        "wall_time_s": round(time.perf_counter() - t_all, 1), "rows": rows,
        "totals": {"kills": sum(t.killed for t in trials),
                   "kills_survived_identical": sum(t.killed for t in trials if t.ok),
                   "trials": len(trials), "failed_trials": sum(not t.ok for t in trials),
                   "hung_runs": sum("[timeout]" in p for t in trials for p in t.problems),
                   "interrupts": len(interrupts),
                   "interrupts_clean": sum(not i["problems"] for i in interrupts),
                   "rank_faults": len(faults),
                   "rank_faults_clean": sum(f["exit"] == 1 and not f["hung"]
                                            and f["messages"] == 1 and not f["traceback"]
                                            and not f["left"] for f in faults),
                   "hangs": sum(f["hung"] for f in faults),
                   "identical_on_1_and_2_ranks": sum(not i["problems"] for i in identity),
                   "identity_cases": len(identity)},
        "trials": [t.__dict__ for t in trials], "interrupts": interrupts,
        "rank_faults": faults, "identity": identity,
    }
    Path(a.o).write_text(json.dumps(result, indent=1) + "\n")
    print()
    print(f"{'case':>14} {'ranks':>5} {'ref s':>6} {'records':>7} {'kills':>5} {'survived':>8} "
          f"{'torn':>4} {'worst rel':>9}  signal")
    for r in rows:
        print(f"{r['case']:>14} {r['ranks']:>5} {r['reference_s']:6.1f} "
              f"{r['reference_records']:>7} {r['kills']:>5} {r['kills_survived']:>8} "
              f"{r['torn_lines_dropped']:>4} {r['worst_rel']:9.1e}  {r['interrupt']}")
    for f in faults:
        print(f"exception on rank {f['fail_rank']} of {f['ranks']}: exit {f['exit']} in "
              f"{f['seconds']} s, message printed {f['messages']}x, hung {f['hung']}")
    for i in identity:
        print(f"critical points of the {i['case']} (surface) on 1 and 2 ranks: "
              f"{i.get('critical_points')}, worst rel {i.get('worst_rel', math.nan):.1e} "
              f"{'OK' if not i['problems'] else i['problems']}")
    tot = result["totals"]
    print(f"kills survived with identical results: {tot['kills_survived_identical']}/"
          f"{tot['kills']}; failed trials {tot['failed_trials']}; wrote {a.o}")
    return 0 if tot["failed_trials"] == 0 and tot["interrupts_clean"] == tot["interrupts"] \
        and tot["rank_faults_clean"] == tot["rank_faults"] \
        and tot["identical_on_1_and_2_ranks"] == tot["identity_cases"] else 1


if __name__ == "__main__":
    sys.exit(main())
