"""Reliability (issue 16): files that survive a crash, kill and resume, SIGINT/SIGTERM, injected
solver failures, an exception on one MPI rank.

* store: a torn last line is never continued by the next record and never used; a corrupt line
  refuses the file (one line, exit 2, on every rank);
* ``shells branch`` (surface model) interrupted by SIGINT, SIGTERM and SIGKILL at seeded random
  moments, with a torn line written before the last rerun, ends with the uninterrupted run's
  points (to 1e-10) and loses none written before a kill;
* ``shells critical`` (surface model) interrupted between a point's record and its checkpoint
  resumes after the checkpointed point and ends with the uninterrupted run's points, critical
  points and JSON; another configuration, ``--restart`` or an unreadable checkpoint start
  afresh; ``critical.follow`` resumed after any point of a run continues it to the last bit;
* Newton steps that diverge (a NaN residual) and factorisations that fail (a zero Jacobian),
  injected into the algebraic problems, cut the step and the run recovers the exact answers; a
  failed LDL^T and a SLEPc eigensolve that converges nothing stop with a clear message or fall
  back on the inertia; a continuation that gives up is an error that leaves a resumable branch;
* an exception on one rank of two ends both within seconds, the message printed once.

Subprocesses, and the CLI runs on this process alone, are started by rank 0 only (with the
environment of no MPI job), the others wait for its verdict, so every test is valid on any
number of ranks. The campaign (several kills of
every command, 1 and 2 ranks) is ``benchmarks/reliability.py``, whose helpers these tests use.
"""

from __future__ import annotations

import json
import math
import random
import signal
import sys
from pathlib import Path

# PETSc's initialisation (the first import of dolfinx) is collective: on every rank, here,
# before rank 0 works alone
import dolfinx  # noqa: F401
import pytest
from mpi4py import MPI

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
import reliability as rel  # noqa: E402

from shells.errors import InputError  # noqa: E402
from shells.files import append_record, read_records  # noqa: E402

#: natural steps of κR = 5 on a coarse P2 sphere: 5 points, about 0.2 s each
BRANCH = ["branch", "--shape", "sphere", "--h-over-r", "0.05", "--kappa-h-max", "1", "--size",
          "0.3", "--degree", "2", "--method", "natural", "--ds", "5", "--ds-max", "5"]


#: the world of ranks (``one_rank`` makes this process the CLI's whole world)
WORLD = MPI.COMM_WORLD


def _on_rank0(fn):
    """fn() on rank 0 (it may start processes or run the CLI on this process alone): its
    (ok, message), or its exception's message, on every rank. The others wait asleep, not in
    a collective that spins a core the processes started need."""
    import time

    c = WORLD
    res = (False, "not run")
    if c.rank == 0:
        try:
            res = fn()
        except Exception as e:  # noqa: BLE001 - reported on every rank
            res = (False, f"{type(e).__name__}: {e}")
    req = c.Ibarrier()
    while not req.Test():
        time.sleep(0.05)
    return c.bcast(res, root=0)


# ------------------------------------------------------------------------------------------
# the files
# ------------------------------------------------------------------------------------------
def test_a_torn_last_line_is_dropped_not_continued(tmp_path):
    f = tmp_path / "points.jsonl"
    append_record(f, {"a": 1})
    append_record(f, {"a": 2})
    with open(f, "a") as fh:
        fh.write('{"a": 3, "b"')  # a write cut short
    assert read_records(f) == [{"a": 1}, {"a": 2}]  # skipped, not used
    append_record(f, {"a": 4})  # not glued to the torn line
    assert f.read_text() == '{"a": 1}\n{"a": 2}\n{"a": 4}\n'
    with open(f, "a") as fh:
        fh.write("\0\0\0")  # a block of zeros from a lost write
    assert read_records(f) == [{"a": 1}, {"a": 2}, {"a": 4}]


@pytest.mark.parametrize("bad", ['{"a": 3, "b"', "[1, 2]", "\0\0\0", "\xff\xfe"])
def test_a_corrupt_line_refuses_the_file(tmp_path, bad):
    f = tmp_path / "points.jsonl"
    f.write_bytes(b'{"a": 1}\n' + bad.encode("latin-1") + b'\n{"a": 2}\n')
    with pytest.raises(InputError, match="line 2 is not a record"):
        read_records(f)


def test_cli_refuses_a_corrupt_points_file_on_every_rank(capsys, shared_tmp):
    """A resume that would use a points file it cannot trust: one line, exit 2, no work."""
    from shells.cli import main

    out = shared_tmp / "pd"
    if MPI.COMM_WORLD.rank == 0:
        out.mkdir()
        (out / "points.jsonl").write_text('{"h_over_R": 0.04}\nnot json\n')
    MPI.COMM_WORLD.barrier()
    rc = main(["phase-diagram", "--h-over-r", "0.04", "--thetabar-range", "1.5", "3.5",
               "--points", "2", "--no-figure", "-o", str(out)])
    assert rc == 2
    err = capsys.readouterr().err
    if MPI.COMM_WORLD.rank == 0:
        lines = [ln for ln in err.splitlines() if ln.strip()]
        assert len(lines) == 1 and "line 2 is not a record" in lines[0], err


# ------------------------------------------------------------------------------------------
# kill and resume, SIGINT and SIGTERM
# ------------------------------------------------------------------------------------------
def _branch_config():
    """``BRANCH``'s configuration, as ``shells branch`` builds it."""
    from shells.algorithms.settings import ContinuationSettings
    from shells.analyses.branch import BranchConfig
    from shells.geometry.shapes import Sphere

    return BranchConfig(shape=Sphere(1.0), h_over_r=0.05, nu=0.5, kappa_end=20.0, size=0.3,
                        degree=2, continuation=ContinuationSettings(method="natural", ds=5.0,
                                                                    ds_max=5.0))


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> list[dict] | None:
    """The uninterrupted branch, computed by rank 0 alone (None elsewhere): the same numbers
    as a 1-rank ``shells branch``, without one more process start."""
    from shells.analyses.branch import run_branch

    if WORLD.rank != 0:
        return None
    out = tmp_path_factory.mktemp("reference")
    list(run_branch(_branch_config(), out, comm=MPI.COMM_SELF))
    return rel.records(out, rel.CASES["branch"])


def _one_rank(monkeypatch) -> None:
    """This process alone is the CLI's whole world (in ``_on_rank0``: rank 0 runs it)."""
    monkeypatch.setattr(MPI, "COMM_WORLD", MPI.COMM_SELF)


def test_sigint_and_sigterm_inside_petsc_callbacks_are_interruptions(monkeypatch, tmp_path,
                                                                     capsys, reference):
    """Ctrl-C, then SIGTERM, land in Python code called by PETSc (the residual's assembly
    inside SNES), which turns the KeyboardInterrupt into a PETSc error: still the one line and
    exit 130 / 143 of an interruption (it was "shells: failed: Error: error code -1 ..." and
    exit 1), and the reruns resume to the uninterrupted run's points. The signal goes to the
    main thread (as a terminal's Ctrl-C reaches the process), and the handler in place when
    it is sent must be the interpreter's (the CLI's), not PETSc's: PETSc's own would end the
    MPI job (MPI_Abort 59, PETSC_ERR_SIG), which a 2-rank pass once did here."""
    ok, msg = _on_rank0(lambda: _interruptions(monkeypatch, tmp_path, capsys, reference))
    assert ok, msg


def _handler_library(sig: int) -> str:
    """The file of the native code that handles ``sig`` now ("" for SIG_DFL or SIG_IGN): the
    interpreter's where Python's ``signal.signal`` installed it, libpetsc's where PETSc's."""
    import ctypes

    class DlInfo(ctypes.Structure):
        _fields_ = [("fname", ctypes.c_char_p), ("fbase", ctypes.c_void_p),
                    ("sname", ctypes.c_char_p), ("saddr", ctypes.c_void_p)]

    libc = ctypes.CDLL(None)
    action = (ctypes.c_char * 256)()  # struct sigaction: the handler is its first member
    libc.sigaction(int(sig), None, action)
    handler = ctypes.c_void_p.from_buffer(action).value
    if handler in (None, 0, 1):
        return ""
    info = DlInfo()
    libc.dladdr(ctypes.c_void_p(handler), ctypes.byref(info))
    return (info.fname or b"?").decode()


def _interruptions(monkeypatch, tmp_path, capsys, reference) -> tuple[bool, str]:
    import threading

    from shells.algorithms import newton as solvers
    from shells.cli import main

    _one_rank(monkeypatch)
    real = solvers.NewtonSolver.assemble_residual
    out = tmp_path / "b"
    kept: list[dict] = []
    for sig in (signal.SIGINT, signal.SIGTERM):
        sent: list[int] = []
        owner: list[str] = []
        before = len(kept)

        def interrupted(self, b, sig=sig, sent=sent, owner=owner, before=before):
            # inside the first solve after this run's first new point
            if not sent and len(rel.records(out, rel.CASES["branch"])) > before:
                sent.append(sig)
                owner.append(_handler_library(sig))
                if "petsc" not in owner[0]:  # PETSc's handler would end the whole MPI job
                    signal.pthread_kill(threading.main_thread().ident, sig)
            real(self, b)

        monkeypatch.setattr(solvers.NewtonSolver, "assemble_residual", interrupted)
        status = main([*BRANCH, "-o", str(out)])
        assert sent and "petsc" not in owner[0], f"{sig.name} handled by {owner[0]}"
        assert status == 128 + sig
        lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("shells:")]
        assert lines == [f"shells: interrupted ({sig.name}); rerun the same command to resume"]
        now = rel.records(out, rel.CASES["branch"])
        assert now[:len(kept)] == kept and len(kept) < len(now) < len(reference)
        kept = now
    monkeypatch.setattr(solvers.NewtonSolver, "assemble_residual", real)
    assert main([*BRANCH, "-o", str(out)]) == 0
    got = rel.records(out, rel.CASES["branch"])
    diffs, _ = rel.compare(reference, got)
    assert not diffs, diffs[:3]
    assert got[:len(kept)] == kept  # from the file, not recomputed
    return True, ""


def test_a_signal_during_teardown_keeps_the_status_and_prints_nothing():
    """SIGINT (then SIGTERM) after ``main`` returned, from an atexit callback (where logging's
    shutdown also runs): the command's status and no KeyboardInterrupt fragments (the default
    handler, restored by ``main``, printed "Exception ignored in atexit callback ...
    KeyboardInterrupt"), however many arrive."""
    import subprocess

    def check():
        problems = []
        for sigs, want in (("SIGINT", 0), ("SIGTERM", 0), ("SIGINT, signal.SIGTERM", 0)):
            code = ("import atexit, os, signal, sys; sys.argv = ['shells']; atexit.register("
                    f"lambda: [os.kill(os.getpid(), s) for s in (signal.{sigs},)]); "
                    "from shells.cli import entry; entry()")
            r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                               env=rel.clean_env(), cwd=rel.REPO, timeout=60)
            if r.returncode != want or r.stderr.strip() or "usage: shells" not in r.stdout:
                problems.append(f"{sigs}: exit {r.returncode}, stderr {r.stderr[-300:]!r}")
        return not problems, "; ".join(problems)

    ok, msg = _on_rank0(check)
    assert ok, msg


def test_a_signal_during_an_import_acts_once_the_import_is_done(tmp_path):
    """SIGTERM while a module is being imported (its body sends it, then works 0.3 s): the
    interrupt waits until the import has finished, then ends the command as usual (one line,
    exit 143). Raised inside the import instead, it aborted the process with a native
    backtrace, or ended it by SIGINT, when the module was a C extension that calls back into
    Python while it initialises (dolfinx's nanobind module: 8 of 300 signals sent within 0.5 s
    of a 1D branch's first record, none of 150 since)."""
    import subprocess

    def check():
        mark = tmp_path / f"imported-{MPI.COMM_WORLD.rank}"
        (tmp_path / "slow_import_module.py").write_text(
            "import os, signal, time\n"
            "os.kill(os.getpid(), signal.SIGTERM)\n"
            "time.sleep(0.3)\n"
            f"open({str(mark)!r}, 'w').write('done')\n")
        code = (f"import sys, time; sys.path.insert(0, {str(tmp_path)!r})\n"
                "import shells.cli as cli, shells.cli.common as common\n"
                "def paths(args):\n"
                "    import slow_import_module\n"
                "    time.sleep(20)\n"
                "common.check_paths = paths\n"
                f"sys.exit(cli.main(['mesh', 'disk', '-o', {str(tmp_path / 'out')!r}]))\n")
        r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           env=rel.clean_env(), cwd=rel.REPO, timeout=60)
        lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
        problems = []
        if r.returncode != 143:
            problems.append(f"exit {r.returncode}")
        if lines != ["shells: interrupted (SIGTERM); rerun the same command to resume"]:
            problems.append(f"stderr {r.stderr[-400:]!r}")
        if not mark.exists():
            problems.append("the import was cut short")
        return not problems, "; ".join(problems)

    ok, msg = _on_rank0(check)
    assert ok, msg


def test_a_signal_right_after_the_start_is_one_line(tmp_path):
    """Ctrl-C 0.15 and 0.3 s after ``python3 -m shells critical ...`` starts, while it imports
    NumPy, SciPy and dolfinx: one line and exit 130. ``import shells`` took 0.36 s (the
    geometry's SciPy) before the command had any handler, and a Ctrl-C then ended in a
    KeyboardInterrupt traceback (exit by SIGINT); ``shells.cli`` now imports in ~15 ms and
    the heavy modules after its handlers are in place."""
    import subprocess
    import time

    def check():
        problems = []
        for t in (0.15, 0.3):
            p = subprocess.Popen([sys.executable, "-m", "shells", "critical", "--model",
                                  "axisym", "--shape", "cap", "--theta-deg", "30",
                                  "--h-over-r", "0.04", "-o", str(tmp_path / f"out{t}")],
                                 cwd=rel.REPO, env=rel.clean_env(), stdout=subprocess.DEVNULL,
                                 stderr=subprocess.PIPE, text=True)
            time.sleep(t)
            p.send_signal(signal.SIGINT)
            _, err = p.communicate(timeout=60)
            lines = [ln for ln in err.splitlines() if ln.strip()]
            if p.returncode != 130 or lines != [
                    "shells: interrupted (SIGINT); rerun the same command to resume"]:
                problems.append(f"{t} s: exit {p.returncode}, stderr {err[-300:]!r}")
        return not problems, "; ".join(problems)

    ok, msg = _on_rank0(check)
    assert ok, msg


def test_branch_killed_torn_and_resumed(shared_tmp, reference):
    """``shells branch`` (a process of its own) killed by SIGKILL at a random moment after its
    first point, a torn line, and the rerun: the uninterrupted run's points (1e-10), none
    lost."""
    rng = random.Random(16)
    case = rel.Case("branch", BRANCH, ["branch.jsonl"], True)

    def check():
        out = shared_tmp / "cut"
        bfile = out / "branch.jsonl"
        seen: dict[str, dict] = {}
        problems = []
        for sig in (signal.SIGKILL,):
            before = len(rel.records(out, case))
            r = rel.run(BRANCH, out, after=rng.uniform(0.0, 0.15), sig=sig,
                        wait_for=lambda b=before: len(rel.records(out, case)) > b)
            lines = [ln for ln in r.stderr.splitlines() if ln.startswith("shells:")]
            want = {signal.SIGTERM: 143, signal.SIGKILL: -9}[sig]
            if r.signalled is None or r.rc != want:
                problems.append(f"{sig.name}: exit {r.rc} (signalled: {r.signalled})")
            if sig == signal.SIGTERM and (len(lines) != 1 or "Traceback" in r.stderr
                                          or "interrupted (SIGTERM)" not in lines[0]):
                problems.append(f"{sig.name}: stderr {r.stderr[-400:]}")
            seen.update((rel.record_key(p), p) for p in rel.records(out, case))
        with open(bfile, "a") as f:
            f.write(bfile.read_text().splitlines()[-1][:40])  # a write cut short
        final = rel.run(BRANCH, out)
        if final.rc != 0:
            return False, f"final run: exit {final.rc}: {final.stderr[-400:]}"
        got = rel.records(out, case)
        diffs, worst = rel.compare(reference, got)
        lost, _ = rel.compare(got, list(seen.values()), subset=True)
        problems += diffs[:3] + [f"lost {d}" for d in lost[:3]]
        if not bfile.read_text().endswith("}\n"):
            problems.append("the torn line is still there")
        return not problems, f"{problems}; {len(seen)} points seen, worst rel {worst:.1e}"

    ok, msg = _on_rank0(check)
    assert ok, msg


# ------------------------------------------------------------------------------------------
# shells critical (surface model): resumed after an interruption
# ------------------------------------------------------------------------------------------
#: a coarse 30 degree cap (3078 DOFs) to its fold at kappa R = 1.3769: 10 points, about 2 s
CRITICAL = rel.CASES["critical-surface"]


def _shared_dir(tmp_path_factory, name: str) -> Path:
    """A fresh folder with the same path on every rank."""
    path = str(tmp_path_factory.mktemp(name)) if WORLD.rank == 0 else None
    return Path(WORLD.bcast(path, root=0))


@pytest.fixture(scope="module")
def critical_reference(tmp_path_factory) -> Path:
    """The uninterrupted ``shells critical`` run of ``CRITICAL`` (on every rank)."""
    from shells.cli import main

    out = _shared_dir(tmp_path_factory, "critical-ref")
    assert main([*CRITICAL.argv, "-o", str(out)]) == 0
    WORLD.barrier()  # rank 0 writes the files
    return out


def _follow_indices(monkeypatch) -> list[int]:
    """The indices of the points ``shells.algorithms.following.follow`` computes from now on."""
    import shells.algorithms.following
    import shells.algorithms.settings

    real = shells.algorithms.following.follow
    computed: list[int] = []

    def counting(*args, **kwargs):
        for p, res, found in real(*args, **kwargs):
            computed.append(p.index)
            yield p, res, found

    monkeypatch.setattr(shells.algorithms.following, "follow", counting)
    return computed


def _cli(capsys, argv: list[str]) -> tuple[int, str, str]:
    """``shells ARGV`` on every rank: (exit status, stdout, stderr); the output (rank 0's
    only: the CLI logs to stderr on rank 0) on every rank."""
    from shells.cli import main

    capsys.readouterr()
    rc = main(argv)
    cap = capsys.readouterr()
    WORLD.barrier()  # rank 0 writes the files
    out, err = WORLD.bcast((cap.out, cap.err), root=0)
    return rc, out, err


def _check_same(ref_dir: Path, out: Path) -> None:
    """The points, critical points (file and critical.json) of ``out`` are the reference's:
    every number to 1e-10 (on several ranks, the few that parallel MUMPS does not reproduce
    bit for bit to ``rel.PARALLEL_RTOL``), the located kappa to 1e-10 in any case."""
    ref, got = rel.records(ref_dir, CRITICAL), rel.records(out, CRITICAL)
    diffs, worst = rel.compare(ref, got, field_rtol=CRITICAL.field_rtol(WORLD.size))
    assert not diffs, diffs[:5]
    a = json.loads((ref_dir / "critical.json").read_text())
    b = json.loads((out / "critical.json").read_text())
    assert a.keys() == b.keys()
    assert [c["kind"] for c in b["critical_points"]] == [c["kind"] for c in a["critical_points"]]
    for ca, cb in zip(a["critical_points"], b["critical_points"], strict=True):
        assert cb["kappa_R"] == pytest.approx(ca["kappa_R"], rel=1e-10)
        assert (cb["mode_m"], cb["after_point"]) == (ca["mode_m"], ca["after_point"])
    if WORLD.size == 1:  # the same to the last bit
        assert rel.compare(ref, got, rtol=0.0)[0] == []


@pytest.mark.parametrize("at", ["early", "before the fold"])
def test_critical_interrupted_and_resumed(monkeypatch, capsys, tmp_path_factory,
                                          critical_reference, at):
    """``shells critical`` (surface model) interrupted (Ctrl-C) after the records of point
    k + 1 were written and before its checkpoint: the rerun keeps points 0..k as written,
    computes from point k + 1 on (early: k = 1; before the fold: the fold lies between points
    k and k + 1, its record written and dropped, and the first step after the resume must
    locate it again) and ends with the uninterrupted run's points, critical points and JSON
    (timings aside). A rerun of the finished run computes nothing (the critical point and its
    mode from the file and the checkpoint) and gives the same JSON."""
    import shells.analyses.store

    ref = rel.records(critical_reference, CRITICAL)
    fold = next(r["critical_point"] for r in ref if "critical_point" in r)
    k = 1 if at == "early" else fold["after_point"]  # the fold lies between k and k + 1
    out = _shared_dir(tmp_path_factory, "critical-cut")
    real = shells.analyses.store.save_state_checkpoint
    saves = [0]

    def interrupted(*args, **kwargs):
        saves[0] += 1
        if saves[0] == k + 2:  # the checkpoint of point k + 1, its record written
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(shells.analyses.store, "save_state_checkpoint", interrupted)
    rc, _, err = _cli(capsys, [*CRITICAL.argv, "-o", str(out)])
    assert rc == 130 and "interrupted (SIGINT); rerun the same command to resume" in err
    monkeypatch.setattr(shells.analyses.store, "save_state_checkpoint", real)
    cut = rel.records(out, CRITICAL)
    assert [r["index"] for r in cut if "index" in r] == list(range(k + 2))
    assert len(cut) == k + 2 + (at != "early")  # the fold's record, dropped on the resume

    computed = _follow_indices(monkeypatch)
    rc, printed, err = _cli(capsys, [*CRITICAL.argv, "-o", str(out), "--json"])
    assert rc == 0
    assert f"critical: resuming after point {k} at kappa R" in err
    points = [r for r in ref if "index" in r]
    assert computed == list(range(k + 1, len(points)))
    got = rel.records(out, CRITICAL)
    assert got[:k + 1] == cut[:k + 1]  # kept as written, not recomputed
    _check_same(critical_reference, out)
    # the CLI's JSON is critical.json
    printed = json.loads(printed.strip().splitlines()[-1])
    on_disk = json.loads((out / "critical.json").read_text())
    assert {k: v for k, v in printed.items() if k != "wall_time"} == \
        {k: v for k, v in on_disk.items() if k != "wall_time"}

    # the finished run again: nothing computed, the same result
    computed.clear()
    assert _cli(capsys, [*CRITICAL.argv, "-o", str(out)])[0] == 0
    assert computed == []
    _check_same(critical_reference, out)


def test_critical_starts_afresh_under_another_configuration(monkeypatch, capsys,
                                                            tmp_path_factory, critical_reference):
    """A rerun with another configuration (here a shorter kappa range in longer steps: no
    critical point, 4 points) does not resume, with one log line, and computes from point 0;
    so does ``--restart`` with the same configuration; a checkpoint that cannot be read (a
    state file cut short) likewise. A corrupt line in the file refuses the run before any
    work (one line, exit 2)."""
    import shutil

    out = _shared_dir(tmp_path_factory, "critical-other")
    if WORLD.rank == 0:
        shutil.copytree(critical_reference, out, dirs_exist_ok=True)
    WORLD.barrier()
    computed = _follow_indices(monkeypatch)
    short = [*CRITICAL.argv, "--kappa-r-max", "0.4", "--ds", "0.15", "--ds-max", "0.15", "-o",
             str(out)]
    rc, _, err = _cli(capsys, short)
    assert rc == 0
    assert "not resuming from the existing branch file (its configuration differs" in err
    assert computed[0] == 0 and len(computed) >= 2
    res = json.loads((out / "critical.json").read_text())
    assert res["kind"] == "none" and res["kappa_R_end"] == pytest.approx(0.4)
    assert [r["index"] for r in rel.records(out, CRITICAL) if "index" in r] == computed

    computed.clear()
    rc, _, err = _cli(capsys, [*short, "--restart"])
    assert rc == 0 and computed[0] == 0 and "resuming" not in err

    # a state file of the checkpoint cut short: not used
    if WORLD.rank == 0:
        with open(out / "branch.jsonl") as f:
            lines = f.read().splitlines()
        (out / "branch.jsonl").write_text("\n".join(lines[:-1]) + "\n")  # the last point
        for f in (out / "checkpoint").glob("state-*.npz"):
            f.write_bytes(f.read_bytes()[:100])
    WORLD.barrier()
    computed.clear()
    rc, _, err = _cli(capsys, short)
    assert rc == 0 and computed[0] == 0
    assert "its checkpoint is missing, incomplete, unreadable" in err

    # a corrupt line: refused before any work
    if WORLD.rank == 0:
        with open(out / "branch.jsonl", "a") as f:
            f.write("not json\n")
    WORLD.barrier()
    computed.clear()
    rc, _, err = _cli(capsys, short)
    assert rc == 2 and computed == []
    assert len(err.strip().splitlines()) == 1 and "is not a record" in err, err


# ------------------------------------------------------------------------------------------
# critical.follow resumed after any point
# ------------------------------------------------------------------------------------------
def test_follow_resumes_exactly_on_the_algebraic_pitchforks():
    """``follow(..., resume=r)`` from the ``FollowResume`` of any point of a run continues as
    the run did: the same points and the same critical points (the pitchforks at kappa = 1
    and 2, located to 1e-8), to the last bit, the first step after the resume searched for a
    change of the point's counts like any other."""
    from shells.algorithms.following import follow
    from shells.algorithms.settings import ContinuationSettings, CriticalSettings
    from shells.problem.algebraic import PitchforkProblem

    st = ContinuationSettings(ds=0.1, ds_max=0.2, ds_unit="kappa")
    crit = CriticalSettings(rel_tol=1e-8, stop_at_fold=False)
    tracked = []
    full = list(follow(PitchforkProblem(), st, 2.5, crit, track=tracked.append))
    found = [(i, c.kind, c.kappa) for i, (_, _, cps) in enumerate(full) for c in cps]
    assert [f[1] for f in found] == ["bifurcation", "bifurcation"]
    assert [f[2] for f in found] == pytest.approx([1.0, 2.0], rel=1e-8)
    assert len(tracked) == len(full) and tracked[-1].ended
    for k in range(len(full) - 1):
        rest = list(follow(PitchforkProblem(), st, 2.5, crit, resume=tracked[k]))
        assert [p.as_dict() | {"wall_time": 0} for p, _, _ in rest] == \
            [p.as_dict() | {"wall_time": 0} for p, _, _ in full[k + 1:]], k
        assert [[(c.kind, c.kappa, c.after_point) for c in cps] for _, _, cps in rest] == \
            [[(c.kind, c.kappa, c.after_point) for c in cps] for _, _, cps in full[k + 1:]], k
    assert list(follow(PitchforkProblem(), st, 2.5, crit, resume=tracked[-1])) == []


def test_follow_resumes_exactly_with_the_quadratic_predictor():
    """The quadratic predictor's first step after a resume starts from the point before the
    resumed one (``FollowResume.state_prev``, ``kappa_prev``, ``step``), as the run's did: on
    the fold x² + κ - 1 = 0, whose branch bends (the quadratic start is not the tangent
    predictor's), the resumed runs from every point take the run's points to the last bit,
    with its iterations, and locate its fold."""
    from shells.algorithms.following import follow
    from shells.algorithms.settings import ContinuationSettings, CriticalSettings
    from shells.problem.algebraic import FoldProblem

    st = ContinuationSettings(ds=0.05, ds_max=0.05, max_steps=40, predictor="quadratic")
    crit = CriticalSettings(rel_tol=1e-8, stop_at_fold=False)
    tracked = []
    full = list(follow(FoldProblem(), st, 3.0, crit, track=tracked.append))
    assert [c.kind for _, _, cps in full for c in cps] == ["fold"]
    for k in range(len(full) - 1):
        rest = list(follow(FoldProblem(), st, 3.0, crit, resume=tracked[k]))
        assert [p.as_dict() | {"wall_time": 0} for p, _, _ in rest] == \
            [p.as_dict() | {"wall_time": 0} for p, _, _ in full[k + 1:]], k
        assert [[(c.kind, c.kappa) for c in cps] for _, _, cps in rest] == \
            [[(c.kind, c.kappa) for c in cps] for _, _, cps in full[k + 1:]], k


# ------------------------------------------------------------------------------------------
# injected solver failures (the algebraic problems: exact answers, milliseconds, any rank)
# ------------------------------------------------------------------------------------------
STEPS = dict(ds=0.1, ds_max=0.2)


def _inject(monkeypatch, problem, method: str, calls: set[int], spoil) -> list[int]:
    """Spoil the output of ``problem.method`` on the given calls; returns the calls spoilt."""
    real = getattr(problem, method)
    n, hits = [0], []

    def spoilt(*args):
        n[0] += 1
        real(*args)
        if n[0] in calls:
            hits.append(n[0])
            spoil(args[-1])

    monkeypatch.setattr(problem, method, spoilt)
    return hits


def _nan(b) -> None:  # a diverged Newton step: the residual at the iterate is not finite
    b.set(math.nan)


def _zero(A) -> None:  # a failed factorisation: MUMPS cannot factor a zero matrix
    A.zeroEntries()
    A.assemble()


@pytest.mark.parametrize("method, spoil", [("assemble_residual", _nan),
                                           ("assemble_jacobian", _zero)],
                         ids=["diverged Newton", "failed factorisation"])
@pytest.mark.parametrize("calls", [{5}, {5, 6, 7}, {20, 21}], ids=str)
def test_failed_corrector_steps_are_cut_and_the_run_recovers(monkeypatch, method, spoil, calls):
    """The pseudo-arclength corrector fails at the injected calls (before the fold, or in the
    locator next to it): the step is halved, and every later point is on the exact branch and
    the fold located to 1e-8 (x² + κ - 1 = 0: at κ = 1)."""
    from shells.algorithms.following import follow
    from shells.algorithms.settings import ContinuationSettings, CriticalSettings
    from shells.problem.algebraic import FoldProblem

    P = FoldProblem()
    hits = _inject(monkeypatch, P, method, calls, spoil)
    run = list(follow(P, ContinuationSettings(**STEPS), 3.0, CriticalSettings(rel_tol=1e-8)))
    assert hits == sorted(calls)
    found = [c for _, _, cps in run for c in cps]
    assert [c.kind for c in found] == ["fold"]
    assert found[0].kappa == pytest.approx(1.0, rel=1e-8)
    for p, r, _ in run[:-1]:
        assert p.scalars["w0"] == pytest.approx(P.exact_x(p.kappa), abs=1e-10)
        assert r.negative_count == 0


@pytest.mark.parametrize("method, spoil", [("assemble_residual", _nan),
                                           ("assemble_jacobian", _zero)],
                         ids=["diverged Newton", "failed factorisation"])
@pytest.mark.parametrize("driver", ["arclength", "natural"])
def test_one_failure_anywhere_in_a_run_is_recovered(monkeypatch, method, spoil, driver):
    """One failure at each call of a run in turn, wherever it lands: the start, a Newton
    iterate, the corrector, the tangent at a converged point (which once went on with the
    failed factor and ended in a MUMPS error), the locator. Every arclength run ends with the
    fold at κ = 1 to 1e-8, every natural run on κ = 0.9, their points on the exact branch."""
    from shells.algorithms.continuation import continuation
    from shells.algorithms.following import follow
    from shells.algorithms.settings import ContinuationSettings, CriticalSettings
    from shells.problem.algebraic import FoldProblem

    def run(calls: set[int]) -> list[int]:
        P = FoldProblem()
        with monkeypatch.context() as mp:
            hits = _inject(mp, P, method, calls, spoil)
            if driver == "natural":
                pts = list(continuation(P, ContinuationSettings(method="natural", **STEPS),
                                        kappa_end=0.9))
                assert pts[-1].kappa == 0.9
                out = [(p, None, []) for p in pts]
            else:
                out = list(follow(P, ContinuationSettings(**STEPS), 3.0,
                                  CriticalSettings(rel_tol=1e-8)))
                found = [c for _, _, cps in out for c in cps]
                assert [c.kind for c in found] == ["fold"], calls
                assert found[0].kappa == pytest.approx(1.0, rel=1e-8), calls
                out = out[:-1]
        for p, r, _ in out:
            # (natural steps stop at a residual relative to the κ-load, as the test above)
            tol = 1e-8 if driver == "natural" else 1e-10
            assert p.scalars["w0"] == pytest.approx(P.exact_x(p.kappa), abs=tol), calls
            assert r is None or r.negative_count == 0
        return hits

    calls = [0]
    real = getattr(FoldProblem, method)

    def counting(self, *args):
        calls[0] += 1
        return real(self, *args)

    with monkeypatch.context() as mp:
        mp.setattr(FoldProblem, method, counting)
        run(set())
    assert calls[0] > 10
    for k in range(1, calls[0] + 1):
        assert run({k}) == [k]


@pytest.mark.parametrize("method, spoil", [("assemble_residual", _nan),
                                           ("assemble_jacobian", _zero)],
                         ids=["diverged Newton", "failed factorisation"])
def test_failed_natural_steps_are_cut_and_the_run_recovers(monkeypatch, method, spoil):
    """SNES (natural steps): the failed solves are retried with half the step; the factor of a
    failed factorisation is reset (else every later solve fails), the run lands on κ = 0.9."""
    from shells.algorithms.continuation import continuation
    from shells.algorithms.settings import ContinuationSettings
    from shells.problem.algebraic import FoldProblem

    P = FoldProblem()
    hits = _inject(monkeypatch, P, method, {3, 4}, spoil)
    pts = list(continuation(P, ContinuationSettings(method="natural", **STEPS), kappa_end=0.9))
    assert hits == [3, 4]
    assert pts[-1].kappa == 0.9
    for p in pts:
        assert p.scalars["w0"] == pytest.approx(P.exact_x(p.kappa), abs=1e-8)


def test_a_failed_inertia_factorisation_stops_with_a_message_and_the_next_one_works(
        monkeypatch):
    from shells.algorithms import stability
    from shells.algorithms.newton import reset_factor
    from shells.problem.algebraic import FoldProblem

    P = FoldProblem()
    stab = stability.Stability(P)
    real = stability.setup_factor
    calls = [0]

    def failing(ksp, A, options):
        calls[0] += 1
        ok = real(ksp, A, options)
        if calls[0] == 2:  # a failed factorisation, as setup_factor reports it
            reset_factor(ksp, A, options)
            return False
        return ok

    monkeypatch.setattr(stability, "setup_factor", failing)
    # test=False: the LDLᵀ itself (a definite block is otherwise decided by the banded
    # Cholesky test and never factored: the injected failure would not be reached)
    assert stab.inertia(test=False) == (0, 0, 3)
    with pytest.raises(RuntimeError, match="LDL\\^T factorisation failed"):
        stab.inertia(test=False)
    assert stab.inertia(test=False) == (0, 0, 3)
    assert calls[0] == 3
    stab.destroy()


@pytest.mark.parametrize("failures", [3, 10_000], ids=["3 eigensolves", "every eigensolve"])
def test_slepc_failures_fall_back_on_the_inertia(monkeypatch, caplog, failures):
    """Eigensolves that converge nothing: the locator bisects by inertia alone, to the same
    1e-8 (the pitchforks at κ = 1 and 2); when every one fails the modes are unnamed, with a
    warning."""
    import logging

    from slepc4py import SLEPc

    from shells.algorithms.following import follow
    from shells.algorithms.settings import ContinuationSettings, CriticalSettings
    from shells.problem.algebraic import PitchforkProblem

    n = [0]

    class NotConverged(SLEPc.EPS):
        """An eigensolver that ends without a converged pair (as after max_it iterations)."""

        def solve(self):
            n[0] += 1
            super().solve()

        def getConverged(self):
            return 0 if n[0] <= failures else super().getConverged()

        def getConvergedReason(self):
            return (SLEPc.EPS.ConvergedReason.DIVERGED_ITS if n[0] <= failures
                    else super().getConvergedReason())

    monkeypatch.setattr(SLEPc, "EPS", NotConverged)
    P = PitchforkProblem()
    with caplog.at_level(logging.WARNING, logger="shells"):
        run = list(follow(P, ContinuationSettings(**STEPS), 2.5,
                          CriticalSettings(rel_tol=1e-8, stop_at_fold=False)))
    found = [c for _, _, cps in run for c in cps]
    assert [c.kind for c in found] == ["bifurcation", "bifurcation"]
    assert [c.kappa for c in found] == pytest.approx([1.0, 2.0], rel=1e-8)
    assert n[0] > failures or failures > 100
    assert "SLEPc: 0 of the 4 eigenpairs nearest 0 converged" in caplog.text
    if failures < 100:
        assert [c.mode_m for c in found] == [1, 2]


def test_a_continuation_that_gives_up_is_an_error_and_leaves_a_resumable_branch(
        monkeypatch, tmp_path, reference):
    """Every Newton solve past κR = 10 fails (injected): the step is halved down to ds_min and
    the branch of ``shells branch`` stops with a message (the CLI's one line, exit 1) instead
    of a short branch. The rerun without the failure resumes after the last point and ends
    with the uninterrupted run's points."""
    ok, msg = _on_rank0(lambda: _gives_up(monkeypatch, tmp_path, reference))
    assert ok, msg


def _gives_up(monkeypatch, tmp_path, reference) -> tuple[bool, str]:
    from shells.algorithms import newton as solvers
    from shells.analyses import branch

    _one_rank(monkeypatch)
    real = solvers.NewtonSolver.solve

    def failing(self, atol=None):
        if self.problem.get_kappa() > 10.0 + 1e-9:
            return False, 0
        return real(self, atol)

    out = tmp_path / "gave-up"
    monkeypatch.setattr(solvers.NewtonSolver, "solve", failing)
    with pytest.raises(RuntimeError, match=r"stopped at kappa R = 10 before the end of the "
                       r"range, kappa R = 20: .* the same command resumes"):
        branch.run_surface(_branch_config(), out)
    monkeypatch.setattr(solvers.NewtonSolver, "solve", real)
    case = rel.Case("branch", BRANCH, ["branch.jsonl"], True)
    kept = rel.records(out, case)
    assert [p["kappa_R"] for p in kept] == pytest.approx([0, 5, 10], rel=1e-12)
    branch.run_surface(_branch_config(), out)
    got = rel.records(out, case)
    assert got[:len(kept)] == kept  # from the file, not recomputed
    diffs, _ = rel.compare(reference, got)
    assert not diffs, diffs[:3]
    return True, ""


# ------------------------------------------------------------------------------------------
# MPI: an exception on one rank
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("fail_rank", [1])
def test_an_exception_on_one_rank_ends_all_ranks_at_once(shared_tmp, fail_rank):
    def check():
        r = rel.inject_rank_failure(shared_tmp / "fault", fail_rank=fail_rank, timeout=60)
        ok = (r["exit"] == 1 and not r["hung"] and r["messages"] == 1 and not r["traceback"]
              and not r["left"] and r["seconds"] < 30)
        return ok, json.dumps(r)

    ok, msg = _on_rank0(check)
    assert ok, msg


def test_a_rank_without_any_task_ends_with_the_others(shared_tmp):
    """A phase diagram whose tasks all fall to rank 0 (a rerun with fewer tasks left than
    ranks) ends on every rank with all its points: it hung at exit, SLEPc having been
    initialised on rank 0 alone."""
    def check():
        r = rel.idle_rank(shared_tmp / "idle", timeout=90)
        ok = (r["exit"] == 0 and not r["hung"] and not r["traceback"] and not r["left"]
              and r["points"] == 5 and r["ranks_that_computed"] == [0])
        return ok, json.dumps(r)

    ok, msg = _on_rank0(check)
    assert ok, msg

