"""``shells snap`` (``shells.analyses.snap``): where a cap lands past its snap fold.

A shallow cap (θ̄ = 3 < θ̄_c ≈ 3.85) snaps into its axisymmetric everted state: the
minimiser's landing, reached from the fold's state perturbed along its unstable modes, must be
the state Newton finds from the shell mirrored through its rim plane (an independent route),
stable and symmetric. Bad input is one line on stderr and exit status 2."""

import math
import subprocess

import pytest
from conftest import child_env
from mpi4py import MPI

from shells.analyses import snap
from shells.errors import InputError
from shells.geometry.shapes import Sphere, SphericalCap


def test_a_shallow_cap_lands_on_its_everted_state(shared_tmp):
    h = 0.04
    # P3 (P2 locks: on coarse P2 meshes the minimiser finds a wrinkled m = 8 state that the
    # default mesh does not have)
    cfg = snap.SnapConfig(shape=SphericalCap(1.0, 3.0 * math.sqrt(h)), h_over_r=h, past=0.02,
                          size=0.3, degree=3, layer_elements=2.0)
    res = snap.run(cfg, shared_tmp / "snap3", render=False)
    ld, ev = res["landing"], res["axisymmetric_everted"]
    assert res["start"]["kind"] == "fold"
    assert res["start"]["kappa_R"] == pytest.approx(1.02 * res["start"]["kappa_fold_R"], rel=1e-12)
    assert ld["stable"] and ld["symmetric"] and ld["mode_m"] == 0
    assert ev["negative_count"] == 0
    # two routes to one state: the minimiser's landing and Newton from the mirrored shell (in
    # the mirror chart, whose energy differs by the coarse mesh's departure from the sphere)
    assert ld["energy"] == pytest.approx(ev["energy"], rel=3e-3)
    assert ld["rim_rotation_deg"] == pytest.approx(ev["rim_rotation_deg"], abs=0.01)
    # everted: the rim turned by far more than the opening angle (θ = 34.4°)
    assert 60 < ld["rim_rotation_deg"] < 70
    assert ld["iterations"] > 0
    if MPI.COMM_WORLD.rank == 0:
        assert (shared_tmp / "snap3" / "snap.json").exists()
    # a rerun resumes from the checkpoint (the minimiser's last saved iterate, no branch to
    # follow again) and lands on the same state
    again = snap.run(cfg, shared_tmp / "snap3", render=False)
    assert again["landing"]["energy"] == pytest.approx(ld["energy"], rel=1e-9)
    assert again["critical_points"] == res["critical_points"]


def test_config_refusals():
    cap = SphericalCap(1.0, 0.6)
    with pytest.raises(InputError, match="open shell"):
        snap.SnapConfig(shape=Sphere(1.0), h_over_r=0.01)
    for bad in ({"past": 0.0}, {"past": 2.0}, {"amplitude": -1.0}, {"method": "newton"},
                {"damping": -1.0},
                {"h_over_r": 0.9}):
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
