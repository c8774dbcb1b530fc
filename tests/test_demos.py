"""Demos run and end with their own asserts: the main demo, and every gallery demo's quick mode
(SHELLS_DEMO_QUICK=1), in this process, so on 1 rank in the serial pass and on 2 in the MPI
pass. The Docker image's `demo` entry point lists and runs them (scripts/demo)."""

import importlib.util
import pathlib
import runpy
import subprocess

import pytest
from conftest import child_env
from mpi4py import MPI

DEMOS = pathlib.Path(__file__).parent.parent / "demos"
GALLERY = sorted(p.stem for p in DEMOS.glob("*.py") if p.stem != "main")
#: demos whose quick mode a test of their own runs (and checks further): not run twice
OWN_TEST = {"fig1d_snap": "tests/test_snap.py"}


def _load(name: str):
    spec = importlib.util.spec_from_file_location(name, DEMOS / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.skipif(MPI.COMM_WORLD.size > 1, reason="the README's main demo runs on one "
                    "process; the analyses it calls run on 2 ranks in their own tests "
                    "(test_critical, test_switching, test_cross_validation)")
def test_main_demo(shared_tmp):
    out = _load("main").run(shared_tmp / "demo", quick=True)
    assert out["snap_onset"]["kappa_R"] == 1.35 and out["axisymmetric"]["kappa_R"] == -0.69
    assert out["buckled"]["kappa_R"] == pytest.approx(-0.69, rel=1e-9)


def test_the_gallery_has_its_demos():
    """At least the demos the gallery's figure table names."""
    assert {"fig1c_buckled_cap", "fig2_phase_diagram", "fig3_sphere", "ellipsoids",
            "own_cap_cli", "own_cap_python", "own_mesh", "kappa_field", "knockdown",
            "sweep_mpi", "fig1d_snap"} <= set(GALLERY)


@pytest.mark.parametrize("name", [g for g in GALLERY if g not in OWN_TEST])
def test_gallery_demo_quick_mode(name, shared_tmp, monkeypatch):
    """``python3 demos/NAME.py --quick``, run as a script (``__main__``): its asserts pass."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    monkeypatch.setenv("SHELLS_DEMO_QUICK", "1")
    monkeypatch.setenv("SHELLS_DEMO_OUT", str(shared_tmp / "demos"))
    try:
        runpy.run_path(str(DEMOS / f"{name}.py"), run_name="__main__")
    finally:
        plt.close("all")
    MPI.COMM_WORLD.barrier()


def test_the_demo_entry_point_lists_and_refuses():
    """``scripts/demo`` (the image's ``docker run --rm shells [demo NAME]``): no argument lists
    every demo with its title; an unknown name is one line on stderr and exit status 2."""
    if MPI.COMM_WORLD.rank != 0:
        return
    script = str(DEMOS.parent / "scripts" / "demo")
    out = subprocess.run([script], capture_output=True, text=True, env=child_env(),
                         check=True).stdout
    for name in GALLERY + ["main"]:
        assert f"\n  {name} " in "\n" + out or out.startswith(f"  {name} ")
    bad = subprocess.run([script, "nope"], capture_output=True, text=True, env=child_env())
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1
    assert "nope" in bad.stderr


def test_the_demo_entry_point_runs_one(shared_tmp):
    """``demo NAME --quick`` runs the demo as a script (one process, its own output folder)."""
    if MPI.COMM_WORLD.rank != 0:
        return
    script = str(DEMOS.parent / "scripts" / "demo")
    r = subprocess.run([script, "own_cap_cli", "--quick"], capture_output=True, text=True,
                       env=child_env(SHELLS_DEMO_OUT=str(shared_tmp / "entry")))
    assert r.returncode == 0, r.stderr
    assert "fold at kappa R = 1.39342" in r.stdout
