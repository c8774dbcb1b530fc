"""``shells snap`` (``shells.analyses.snap``): where a cap lands past its snap fold.

A shallow cap (θ̄ = 3 < θ̄_c ≈ 3.85) snaps into its axisymmetric everted state: the
minimiser's landing, reached from the fold's state perturbed along its unstable modes, must be
the state Newton finds from the shell mirrored through its rim plane (an independent route),
stable and symmetric (the gallery's Fig. 1 (d) demo in its quick mode asserts it; run here,
not by tests/test_demos.py). A rerun resumes. Bad input is one line on stderr and exit
status 2.

``--method dynamics`` comes to rest where the minimiser lands; its motion is written for
ParaView (``snap.bp``, read back with ADIOS2: one frame per kept step, at the CSV's times) and
as an animation (``snap.gif``, read back with Pillow); an interrupted integration continues
from its checkpoint and takes the very steps of a run that was never stopped."""

import json
import math
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest
from conftest import child_env
from mpi4py import MPI
from petsc4py import PETSc

from shells.analyses import snap
from shells.errors import InputError
from shells.geometry.shapes import Sphere, SphericalCap


@pytest.mark.skipif(MPI.COMM_WORLD.size > 1, reason="the gallery demo runs on one process; a "
                    "snap resumed on 2 ranks: test_dynamics_outputs_and_resume")
def test_the_fig1d_demo_quick_mode_and_a_resumed_rerun(shared_tmp, monkeypatch):
    """The gallery's Fig. 1 (d) demo in its quick mode (its own asserts: the θ̄ = 3 cap lands,
    stable and symmetric, on the everted state Newton finds from the mirrored cap), then the
    same snap again into the same folder: it resumes from the minimiser's checkpoint (no
    branch followed again) and lands on the same state."""
    import pathlib
    import runpy

    import matplotlib

    matplotlib.use("Agg")
    import shells

    demo = pathlib.Path(__file__).parent.parent / "demos" / "fig1d_snap.py"
    monkeypatch.setenv("SHELLS_DEMO_QUICK", "1")
    monkeypatch.setenv("SHELLS_DEMO_OUT", str(shared_tmp / "demos"))
    ns = runpy.run_path(str(demo), run_name="__main__")
    res = ns["res"]
    ld = res.landing
    assert res.start["kappa_R"] == pytest.approx(1.02 * res.start["kappa_fold_R"], rel=1e-12)
    # everted: the rim turned by far more than the opening angle (θ = 34.4°)
    assert 60 < ld["rim_rotation_deg"] < 70 and ld["iterations"] > 0
    out = shared_tmp / "demos" / "fig1d_snap"
    if MPI.COMM_WORLD.rank == 0:
        assert (out / "snap.json").exists() and (out / "landing.png").stat().st_size > 0
    if MPI.COMM_WORLD.size > 1:
        return  # the resumed rerun is checked in the serial pass (the snap itself on both)
    again = shells.snap(ns["shell"], past=0.02, outdir=out, render=False, **ns["mesh"])
    assert again.landing["energy"] == pytest.approx(ld["energy"], rel=1e-9)
    assert again.critical_points == res.critical_points


def test_config_refusals():
    cap = SphericalCap(1.0, 0.6)
    with pytest.raises(InputError, match="open shell"):
        snap.SnapConfig(shape=Sphere(1.0), h_over_r=0.01)
    for bad in ({"past": 0.0}, {"past": 2.0}, {"amplitude": -1.0}, {"method": "newton"},
                {"damping": -1.0}, {"settle": -1e-4}, {"settle": 1.0}, {"settle": math.nan},
                {"t_max": 0.0}, {"t_max": math.inf},
                {"step_tol": 0.0}, {"step_tol": 1.0}, {"h_over_r": 0.9}):
        with pytest.raises(InputError):
            snap.SnapConfig(**{"shape": cap, "h_over_r": 0.04, **bad})


@pytest.mark.parametrize("args", [["--shape", "sphere", "--h-over-r", "0.01"],
                                  ["--shape", "cap", "--theta-deg", "30", "--h-over-r", "0.04",
                                   "--past", "2"],
                                  ["--shape", "cap", "--theta-deg", "30", "--h-over-r", "0.04",
                                   "--amplitude", "-1"],
                                  ["--shape", "cap", "--theta-deg", "30", "--h-over-r", "0.04",
                                   "--method", "dynamics", "--settle", "2"],
                                  ["--shape", "cap", "--theta-deg", "30", "--h-over-r", "0.04",
                                   "--method", "dynamics", "--t-max", "-1"]])
def test_cli_refusals_are_one_line(args):
    if MPI.COMM_WORLD.rank != 0:
        return
    r = subprocess.run(["python3", "-m", "shells", "snap", *args], capture_output=True,
                       text=True, env=child_env())
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr


#: the coarse cap of the dynamics tests (P2, 1398 DOFs; it wrinkles at m = 8 on this mesh, a
#: discretisation artefact, but both methods must find the same state), damping 2
_H = 0.04
_CAP = dict(shape=SphericalCap(1.0, 3.0 * math.sqrt(_H)), h_over_r=_H, past=0.3, size=0.6,
            degree=2, layer_elements=1.0)
#: the output tests' run to rest: adaptive steps of at least 0.1 (not 0.05) at a tolerance of
#: 1e-3 (at rest in about 80 steps; the landing is the same as at 1e-4), checkpointed every 50
_STEPS = (("DT_STEP", 0.1), ("DYNAMICS_SAVE_EVERY", 50))
_STEP_TOL = 1e-3


def _series(folder):
    """``snap_series.csv`` of a run's folder."""
    return np.loadtxt(folder / "snap_series.csv", delimiter=",", skiprows=1, ndmin=2)


def _same_series(a, b):
    """Whether two series are one: time, energies, Ψ3 and rim rotation to 1e-10 of their
    column's largest magnitude (the CSV's 12 digits), the amplitudes of m = 1..4 (relative to
    m = 0's; on this mesh up to 2e-5, their roundoff ~1e-12 as sums that nearly cancel) to
    1e-10."""
    tol = np.maximum(1e-10 * np.abs(a).max(axis=0), [0.0] * 5 + [1e-10] * 4)
    return a.shape == b.shape and bool(np.all(np.abs(a - b) <= tol))


def _vtx_times(bp):
    """The times of the steps of a VTX (ADIOS2) file and its point arrays, read on this rank
    alone."""
    os.environ.setdefault("ADIOS2_ALWAYS_USE_MPI", "1")  # Debian's bindings: the MPI build
    import adios2

    with adios2.FileReader(str(bp), comm=MPI.COMM_SELF) as f:
        names = set(f.available_variables())
        n = int(f.available_variables()["step"]["AvailableStepsCount"])
        times = np.atleast_1d(f.read("step", step_selection=[0, n]))
    return times, names


def _gif_frames(path):
    """(frame count, the frames' sizes, the frames' durations in ms) of a GIF."""
    from PIL import Image

    with Image.open(path) as im:
        sizes, durations = set(), []
        for k in range(im.n_frames):
            im.seek(k)
            sizes.add(im.size)
            durations.append(im.info.get("duration"))
        return im.n_frames, sizes, durations


def _expected_frames(steps, every):
    """The steps that ``snap.bp`` holds: multiples of the stride, and the last."""
    return sorted(set(range(0, steps + 1, every)) | {steps})


def _stage(folder):
    """The stage of the checkpoint in ``folder`` (read on rank 0, told to all)."""
    comm = MPI.COMM_WORLD
    meta = (json.loads((folder / "checkpoint" / "meta.json").read_text())
            if comm.rank == 0 else None)
    return comm.bcast(meta, root=0)["stage"]


class _InterruptedError(Exception):
    """The interruption of a run (a kill) simulated in the tests."""


#: what an interrupted run raises: the interruption, or PETSc's error around it (raised in the
#: time stepper's callback)
_STOPPED = (_InterruptedError, PETSc.Error)


def _interrupted(monkeypatch, cfg, folder, steps):
    """``snap.run`` of ``cfg`` in ``folder`` (resumed), its time integration failing after
    ``steps`` steps of this run: a run killed mid-segment, after its checkpoints before then.
    On every rank alike."""
    from shells.algorithms import dynamics

    real, done = dynamics.Integrator, {"steps": 0}

    class Interrupted(real):
        def __init__(self, *args, monitor, **kwargs):
            start = {"call": True}

            def stop(t, p, kinetic):
                if not start.pop("call", False):
                    done["steps"] += 1
                    if done["steps"] > steps:
                        raise _InterruptedError(t)
                return monitor(t, p, kinetic)

            super().__init__(*args, monitor=stop, **kwargs)

    monkeypatch.setattr(dynamics, "Integrator", Interrupted)
    with pytest.raises(_STOPPED):
        snap.run(cfg, folder)
    monkeypatch.setattr(dynamics, "Integrator", real)


@pytest.fixture(scope="module")
def dynamics_run(tmp_path_factory):
    """``--method dynamics`` on ``_CAP`` to rest with an output folder (``_STEPS``; at most 10
    frames in the animation): (its result, its folder, the same on every rank)."""
    comm = MPI.COMM_WORLD
    out = Path(comm.bcast(str(tmp_path_factory.mktemp("dyn")) if comm.rank == 0 else None))
    with pytest.MonkeyPatch.context() as mp:
        for name, value in (*_STEPS, ("ANIMATION_FRAMES", 10)):
            mp.setattr(snap, name, value)
        res = snap.run(snap.SnapConfig(**_CAP, method="dynamics", damping=2.0,
                                       step_tol=_STEP_TOL, settle=0.0), out, render=True,
                       resume=False)
    comm.barrier()  # snap.json written
    return res, out


@pytest.fixture(scope="module")
def minimise_run():
    """``--method minimise`` on ``_CAP`` without an output folder (the same on every rank)."""
    return snap.run(snap.SnapConfig(**_CAP), None, render=False)


def test_dynamics_comes_to_rest_where_minimisation_lands(dynamics_run, minimise_run):
    """``--method dynamics`` on a coarse cap (``_CAP``: it wrinkles at m = 8 on this mesh, a
    discretisation artefact, but both methods must find the same state): the damped motion
    comes to rest, the polish changes the rest state's energy by less than 1e-6 of it, and the
    landing is the minimiser's to 1e-6, on 1 and 2 ranks (the same on every rank). Read in the
    shell's best-fit rigid frame, the two landings have the same shape: spectrum, rim rotation
    and Ψ3 at the pole, whatever their patterns' orientations."""
    dyn, _ = dynamics_run
    d, ld = dyn["dynamics"], dyn["landing"]
    assert dyn["method"] == "dynamics" and d["reason"] == "rest" and d["damping"] == 2.0
    assert dyn["snap_time"] == d["snap_time"] and d["snap_time"] > 0
    assert ld["stable"] and ld["minimiser_reason"].startswith("CONVERGED")
    assert abs(ld["rest_energy"] - ld["energy"]) < 1e-6 * abs(ld["energy"])
    mini = minimise_run
    assert mini["snap_time"] is None and mini["dynamics"] is None
    assert ld["energy"] == pytest.approx(mini["landing"]["energy"], rel=1e-6)
    ml = mini["landing"]
    # this coarse mesh has nearby wrinkled m = 8 minima (test_dynamics_outputs_and_resume):
    # measured among its landings, energies 2.1e-6 apart, spectra 3e-4, rims 3.5e-3°, Ψ3 5e-5 h
    assert ld["mode_m"] == ml["mode_m"]
    assert np.abs(np.subtract(ld["spectrum"], ml["spectrum"])).max() < 1e-3
    assert ld["rim_rotation_deg"] == pytest.approx(ml["rim_rotation_deg"], abs=1e-2)
    assert ld["psi3_pole_over_h"] == pytest.approx(ml["psi3_pole_over_h"], abs=2e-4)


def test_a_settled_run_stops_early_and_lands_where_the_ring_down_does(dynamics_run,
                                                                     shared_tmp, monkeypatch):
    """The fixture's run (``settle`` 0: to rest) with checkpoints every 20 steps, killed
    after step 21 and continued from step 20 with ``settle`` = 1e-2 (a run under way goes on
    under another ``settle``): it stops at the first segment's end where the kinetic energy is
    below 1e-2 of its peak and the Hessian is stable, before the run to rest has come to rest;
    the polish from there lands on the rest run's state, to 1e-6 of its energy, stable, with
    the same pattern; the same on every rank."""
    ref = dynamics_run[0]
    for name, value in (*_STEPS, ("DYNAMICS_SAVE_EVERY", 20)):
        monkeypatch.setattr(snap, name, value)
    cfg = dict(_CAP, method="dynamics", damping=2.0, step_tol=_STEP_TOL)
    _interrupted(monkeypatch, snap.SnapConfig(**cfg, settle=0.0), shared_tmp, 21)
    assert _stage(shared_tmp) == "dynamics 20"
    res = snap.run(snap.SnapConfig(**cfg, settle=1e-2), shared_tmp, render=False)
    d, d0 = res["dynamics"], ref["dynamics"]
    assert d["reason"] == "settled" and d["settle"] == 1e-2 and d0["settle"] == 0.0
    assert res["config"]["settle"] == 1e-2
    assert res["start"]["kappa_R"] == pytest.approx(ref["start"]["kappa_R"], rel=1e-9)
    assert d["steps"] % 20 == 0 and d["end_time"] < d0["end_time"]
    # the same motion (its steps part where a segment ends: the adaptive step starts afresh)
    assert d["kinetic_peak_time"] == pytest.approx(d0["kinetic_peak_time"], rel=0.05)
    assert res["snap_time"] == pytest.approx(ref["snap_time"], rel=1e-2)
    ld, ld0 = res["landing"], ref["landing"]
    assert ld["stable"] and (ld["mode_m"], ld["symmetric"]) == (ld0["mode_m"], ld0["symmetric"])
    assert ld["energy"] == pytest.approx(ld0["energy"], rel=1e-6)
    assert ld["rest_energy"] - ld["energy"] > ld0["rest_energy"] - ld0["energy"]
    for x in (d["steps"], ld["energy"]):
        assert MPI.COMM_WORLD.allreduce(x, op=MPI.MAX) == MPI.COMM_WORLD.allreduce(
            x, op=MPI.MIN)


def test_dynamics_writes_its_files(dynamics_run, minimise_run):
    """A run to rest (adaptive steps) with an output folder: one CSV row per step, ``files``
    names what the folder holds, the checkpoint keeps the rest state, not the frames; the same
    on every rank."""
    dyn, out = dynamics_run
    d = dyn["dynamics"]
    assert d["reason"] == "rest" and d["step_tol"] == _STEP_TOL and 20 < d["steps"] < 200
    for x in (d["snap_time"], dyn["landing"]["energy"]):
        assert MPI.COMM_WORLD.allreduce(x, op=MPI.MAX) - MPI.COMM_WORLD.allreduce(
            x, op=MPI.MIN) <= 1e-12 * abs(x)
    lines = (out / "snap_series.csv").read_text().splitlines()
    assert lines[0].split(",") == list(snap.SERIES_COLUMNS)
    assert len(lines) == d["steps"] + 2
    t = np.array([float(r.split(",")[0]) for r in lines[1:]])
    assert t[0] == 0.0 and np.diff(t).min() >= 0.1 * (1 - 1e-6)  # steps no shorter than DT_STEP
    assert dyn["files"] == {"result": "snap.json", "series": "snap_series.csv",
                            "fields": "snap.bp", "animation": "snap.gif",
                            "landing_image": "landing.png", "landing_fields": "landing.vtu",
                            "everted_image": "everted.png"}
    assert all((out / f).exists() for f in dyn["files"].values())
    assert not any((out / "checkpoint" / "frames").iterdir())
    assert minimise_run["files"] == {}


def test_dynamics_fields_over_time_for_paraview(dynamics_run):
    """``snap.bp`` holds every k-th step from the start (k the least power of 2 that keeps at
    most ``FRAMES_MAX`` of them) and the last, each at its CSV row's time, with the fields
    that ``landing.vtu`` has."""
    dyn, out = dynamics_run
    d = dyn["dynamics"]
    times, names = _vtx_times(out / "snap.bp")
    rows = _series(out)
    every = d["frame_every"]
    steps = _expected_frames(d["steps"], every)
    assert every & (every - 1) == 0 and len(steps) - 1 <= snap.FRAMES_MAX
    assert every == 1 or d["steps"] // (every // 2) + 1 > snap.FRAMES_MAX
    assert len(times) == len(steps) == d["frames"]
    np.testing.assert_allclose(times, rows[steps, 0], rtol=1e-11, atol=1e-12)  # the CSV: 12 digits
    assert {"displacement", "director", "bending_energy_density",
            "stretching_energy_density", "mean_curvature_change"} <= names


def test_dynamics_animation(dynamics_run):
    """``snap.gif``: at most ``ANIMATION_FRAMES`` (10 here) evenly spaced frames of
    ``snap.bp``'s and its last, all of one size, the last held longest."""
    dyn, out = dynamics_run
    d = dyn["dynamics"]
    frames = _expected_frames(d["steps"], d["frame_every"])
    every = math.ceil(len(frames) / 10)
    expected = len(set(frames[::every]) | {frames[-1]})
    n, sizes, durations = _gif_frames(out / "snap.gif")
    assert n == expected == d["animation_frames"] and 10 <= n <= 11
    assert len(sizes) == 1 and durations[-1] > durations[0]


@pytest.mark.skipif(MPI.COMM_WORLD.size > 1, reason="two runs on 2 ranks part at roundoff from "
                    "the fold on (the snap amplifies it): test_dynamics_outputs_and_resume "
                    "continues copies of one run on any rank count")
def test_an_interrupted_dynamics_run_continues_where_it_stopped(dynamics_run, shared_tmp,
                                                               monkeypatch):
    """Killed 10 steps after its checkpoint at step 50, the run's rerun continues from step
    50 (no fold followed again): its series up to there is the uninterrupted run's (the CSV's
    digits); from there its time stepper starts afresh, so its steps differ, but it comes to
    rest in the same state (rest energy 1e-8, landing 1e-9), its frames (``snap.bp``) at its
    CSV's times."""
    dyn, ref = dynamics_run
    d0 = dyn["dynamics"]
    for name, value in _STEPS:
        monkeypatch.setattr(snap, name, value)
    cfg = snap.SnapConfig(**_CAP, method="dynamics", damping=2.0, step_tol=_STEP_TOL,
                          settle=0.0)
    _interrupted(monkeypatch, cfg, shared_tmp, 60)
    assert _stage(shared_tmp) == "dynamics 50"
    assert not (shared_tmp / "snap_series.csv").exists()
    res = snap.run(cfg, shared_tmp, render=False)
    assert res["critical_points"] == dyn["critical_points"]
    d = res["dynamics"]
    assert d["reason"] == d0["reason"] == "rest" and d["steps"] > 50
    # crossed before step 50, at the level halfway to the rest state's Ψ3 (which moved)
    assert d["snap_time"] == pytest.approx(d0["snap_time"], rel=1e-6)
    assert d["rest_energy"] == pytest.approx(d0["rest_energy"], rel=1e-8)
    assert res["landing"]["energy"] == pytest.approx(dyn["landing"]["energy"], rel=1e-9)
    a, b = _series(ref), _series(shared_tmp)
    assert _same_series(a[:51], b[:51]), np.abs(a[:51] - b[:51]).max(axis=0)
    assert b[-1, 0] == pytest.approx(a[-1, 0], rel=0.1)  # at rest at about the same time
    times, _ = _vtx_times(shared_tmp / "snap.bp")
    steps = _expected_frames(d["steps"], d["frame_every"])
    assert d["frames"] == len(steps) == len(times)
    np.testing.assert_allclose(times, b[steps, 0], rtol=1e-11, atol=1e-12)
    assert "animation" not in res["files"] and not (shared_tmp / "snap.gif").exists()


def test_dynamics_outputs_and_resume(shared_tmp, monkeypatch):
    """A short integration (adaptive steps to ``t_max`` = 3, checkpointed every 5; at most 4 frames,
    3 in the animation; then polished), killed after 7 steps and continued from step 5 twice
    from copies of its folder: once to the end (a), once killed again at step 14 and
    continued from step 10 (b). Up to step 10 both are one run to the CSV's digits (a
    continued run's steps are decided by its checkpoint); from there b's time stepper starts
    afresh, and both reach t = 3 in the same state within the steps' tolerance and land in
    the same wrinkled m = 8 state; b, run without rendering, keeps its frames, and its rerun
    draws the animation from them;
    in each the frames' stride doubled, ``snap.bp`` holds them at their CSV times,
    ``snap.gif`` 3 of them. The same on every rank."""
    import shutil

    comm = MPI.COMM_WORLD
    for name, value in (("DT_STEP", 0.1), ("STEP_TOL", 3e-3), ("DYNAMICS_SAVE_EVERY", 5),
                        ("FRAMES_MAX", 4), ("ANIMATION_FRAMES", 3)):
        monkeypatch.setattr(snap, name, value)
    cfg = snap.SnapConfig(**_CAP, method="dynamics", damping=2.0, t_max=3.0)
    a, b = shared_tmp / "a", shared_tmp / "b"
    _interrupted(monkeypatch, cfg, a, 7)
    assert _stage(a) == "dynamics 5"
    if comm.rank == 0:
        shutil.copytree(a, b)
    comm.barrier()
    res = snap.run(cfg, a)
    _interrupted(monkeypatch, cfg, b, 8)
    assert _stage(b) == "dynamics 10"
    # b without rendering: no animation, its frames kept; a rerun that renders draws it
    quiet = snap.run(cfg, b, render=False)
    comm.barrier()
    assert quiet["dynamics"]["animation_frames"] == 0 and "animation" not in quiet["files"]
    assert not (b / "snap.gif").exists()
    kept = _expected_frames(quiet["dynamics"]["steps"], quiet["dynamics"]["frame_every"])
    assert sorted(int(f.name) for f in (b / "checkpoint" / "frames").iterdir()) == kept
    res2 = snap.run(cfg, b)
    comm.barrier()
    assert not any((b / "checkpoint" / "frames").iterdir())
    assert res2["dynamics"]["steps"] == quiet["dynamics"]["steps"]
    for r, folder in ((res, a), (res2, b)):
        d = r["dynamics"]
        assert d["reason"] == "time" and d["t_max"] == 3.0 and d["steps"] >= 15
        assert d["animation_frames"] == 3
        frames = _expected_frames(d["steps"], d["frame_every"])
        assert d["frames"] == len(frames) <= snap.FRAMES_MAX + 1 and d["frame_every"] >= 4
        rows = _series(folder)
        assert rows[-1, 0] == pytest.approx(3.0, rel=1e-12)
        times = _vtx_times(folder / "snap.bp")[0]
        np.testing.assert_allclose(times, rows[frames, 0], rtol=1e-11, atol=1e-12)  # 12 digits
        assert _gif_frames(folder / "snap.gif")[0] == 3
        for x in (d["steps"], times[-1]):  # 2 ranks: the same steps to round-off
            assert comm.allreduce(x, op=MPI.MAX) - comm.allreduce(x, op=MPI.MIN) <= 1e-12 * x
    rows, rows2 = _series(a), _series(b)
    assert _same_series(rows[:11], rows2[:11])
    # at t = 3 the two integrations, b's stepper restarted at step 10, agree within the steps'
    # tolerance (measured: elastic energy 2e-6 apart, Ψ3 at the pole 1.8e-5 h)
    assert rows2[-1, 2] == pytest.approx(rows[-1, 2], rel=1e-5)
    assert rows2[-1, 3] == pytest.approx(rows[-1, 3], abs=1e-4)
    # the polish from there (mid-snap) lands on this coarse mesh in a wrinkled m = 8 state
    # among nearby ones: on 2 ranks its path follows the factorisations' round-off, and the
    # landings measured lie up to 2.1e-6 apart in energy (the orbit's energy varies by 3e-8
    # only), with the same spectrum to 1e-4 of m = 0
    l1, l2 = res["landing"], res2["landing"]
    assert l1["stable"] and l2["stable"] and l1["mode_m"] == l2["mode_m"] == 8
    assert l2["energy"] == pytest.approx(l1["energy"], rel=1e-5)
    assert np.abs(np.subtract(l1["spectrum"], l2["spectrum"])).max() < 1e-3
    assert res2["files"] == res["files"] and {"fields", "animation"} <= set(res["files"])


def test_frames_stride_doubles_when_full(monkeypatch):
    """``DynamicsProgress.take_frame``: every step kept until ``FRAMES_MAX`` are, then the
    stride doubles and the frames off it are dropped: at most ``FRAMES_MAX`` (+ the last step,
    added at the end) for any number of steps, evenly spaced from step 0."""
    monkeypatch.setattr(snap, "FRAMES_MAX", 4)
    prog = snap.DynamicsProgress()
    kept = [s for s in range(21) if prog.take_frame(s)]
    assert prog.frame_every == 8 and prog.frames == [0, 8, 16]
    assert kept == [0, 1, 2, 3, 4, 6, 8, 12, 16]
    assert _expected_frames(20, prog.frame_every) == [0, 8, 16, 20]
