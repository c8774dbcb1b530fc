"""``shells snap`` (``shells.analyses.snap``): where a cap lands past its snap fold.

A shallow cap (θ̄ = 3 < θ̄_c ≈ 3.85) snaps into its axisymmetric everted state: the
minimiser's landing, reached from the fold's state perturbed along its unstable modes, must be
the state Newton finds from the shell mirrored through its rim plane (an independent route),
stable and symmetric (the gallery's Fig. 1 (d) demo in its quick mode asserts it; run here,
not by tests/test_demos.py). A rerun resumes. Bad input is one line on stderr and exit
status 2."""

import math
import subprocess

import pytest
from conftest import child_env
from mpi4py import MPI

from shells.analyses import snap
from shells.errors import InputError
from shells.geometry.shapes import Sphere, SphericalCap


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
                {"damping": -1.0},
                {"step_tol": 0.0}, {"step_tol": 1.0}, {"h_over_r": 0.9}):
        with pytest.raises(InputError):
            snap.SnapConfig(**{"shape": cap, "h_over_r": 0.04, **bad})


@pytest.mark.parametrize("args", [["--shape", "sphere", "--h-over-r", "0.01"],
                                  ["--shape", "cap", "--theta-deg", "30", "--h-over-r", "0.04",
                                   "--past", "2"],
                                  ["--shape", "cap", "--theta-deg", "30", "--h-over-r", "0.04",
                                   "--amplitude", "-1"]])
def test_cli_refusals_are_one_line(args):
    if MPI.COMM_WORLD.rank != 0:
        return
    r = subprocess.run(["python3", "-m", "shells", "snap", *args], capture_output=True,
                       text=True, env=child_env())
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr


def test_dynamics_comes_to_rest_where_minimisation_lands(shared_tmp, monkeypatch):
    """``--method dynamics`` on a coarse cap (P2, 1398 DOFs; it wrinkles at m = 8 on this mesh,
    a discretisation artefact, but both methods must find the same state): the damped motion
    comes to rest, the polish changes the rest state's energy by less than 1e-6 of it, and the
    landing is the minimiser's to 1e-6, on 1 and 2 ranks. A first step of 0.1 and a step tolerance
    of 1e-3 (not the defaults 0.05 and 1e-4) keep it short: the polish decides the landing."""
    monkeypatch.setattr(snap, "DT_STEP", 0.1)
    h = 0.04
    common = dict(shape=SphericalCap(1.0, 3.0 * math.sqrt(h)), h_over_r=h, past=0.3, size=0.6,
                  degree=2, layer_elements=1.0)
    dyn = snap.run(snap.SnapConfig(**common, method="dynamics", damping=2.0, step_tol=1e-3),
                   shared_tmp / "dyn", render=False, resume=False)
    d, ld = dyn["dynamics"], dyn["landing"]
    assert dyn["method"] == "dynamics" and d["reason"] == "rest" and d["damping"] == 2.0
    assert dyn["snap_time"] == d["snap_time"] and d["snap_time"] > 0 and d["step_tol"] == 1e-3
    assert ld["stable"]
    assert abs(ld["rest_energy"] - ld["energy"]) < 1e-6 * abs(ld["energy"])
    # the same on every rank
    for x in (d["snap_time"], ld["energy"]):
        assert MPI.COMM_WORLD.allreduce(x, op=MPI.MAX) - MPI.COMM_WORLD.allreduce(
            x, op=MPI.MIN) <= 1e-12 * abs(x)
    mini = snap.run(snap.SnapConfig(**common), None, render=False)
    assert mini["snap_time"] is None and mini["dynamics"] is None
    assert ld["energy"] == pytest.approx(mini["landing"]["energy"], rel=1e-6)
    if MPI.COMM_WORLD.rank == 0:
        lines = (shared_tmp / "dyn" / "snap_series.csv").read_text().splitlines()
        assert lines[0].split(",") == list(snap.SERIES_COLUMNS)
        assert len(lines) == d["steps"] + 2
        t = [float(r.split(",")[0]) for r in lines[1:]]
        assert t[0] == 0.0 and all(b > a for a, b in zip(t, t[1:], strict=False))
