"""shells branch: the JSON contract, the branch file, resume after an interruption.

The field files are checked in real ParaView by the ParaView check of the test command."""

import json

import pytest
from mpi4py import MPI

from shells.algorithms.settings import ContinuationSettings
from shells.analyses.branch import BranchConfig, read_branch, run_branch
from shells.cli import main
from shells.geometry.shapes import Sphere


def _last_json(out):
    return json.loads(out.strip().splitlines()[-1])


def test_branch_cli_json_contract(capsys, shared_tmp):
    out = shared_tmp / "b"
    rc = main(["branch", "--shape", "sphere", "--h-over-r", "0.05", "--nu", "0.5",
               "--kappa-h-max", "0.5", "--size", "0.3", "--degree", "2", "--method", "natural",
               "--ds", "5", "--ds-max", "5", "-o", str(out), "--json"])
    assert rc == 0
    if MPI.COMM_WORLD.rank == 0:
        d = _last_json(capsys.readouterr().out)
        pts = d["points"]
        for key in ("kappa_R", "kappa_h", "psi3_over_h", "energy", "newton_its"):
            assert all(key in p for p in pts), key
        assert pts[0]["kappa_h"] == 0 and pts[-1]["kappa_h"] == pytest.approx(0.5, rel=1e-12)
        # landed on kappa R = 5 and 10 exactly, the sphere's linear law holds along the way
        for p in pts[1:]:
            assert p["psi3_over_h"] == pytest.approx(-p["kappa_h"] / 12, rel=0.01)
        header, recs = read_branch(out / "branch.jsonl")
        assert header["dofs"] == d["dofs"] > 1000 and len(recs) == len(pts)


@pytest.mark.parametrize("argv, needle", [
    (["branch", "--shape", "cap", "--h-over-r", "0.05", "--kappa-r-max", "1"], "opening angle"),
    (["branch", "--shape", "cap", "--theta-deg", "190", "--h-over-r", "0.05",
      "--kappa-r-max", "1"], "(0, 180]"),
    (["branch", "--shape", "sphere", "--h-over-r", "-0.05", "--kappa-h-max", "1"], "positive"),
    (["branch", "--shape", "sphere", "--h-over-r", "0.05"], "exactly one of"),
    (["branch", "--shape", "sphere", "--h-over-r", "0.05", "--kappa-h-max", "1", "--nu", "0.7"],
     "nu must lie"),
])
def test_branch_bad_input(capsys, argv, needle):
    assert main(argv) == 2
    err = capsys.readouterr().err
    if MPI.COMM_WORLD.rank == 0:
        assert len(err.strip().splitlines()) == 1 and needle in err


def test_resume_after_interruption(shared_tmp):
    """A run stopped after 3 points resumes from its checkpoint and ends where a full run does."""
    cfg = BranchConfig(shape=Sphere(1.0), h_over_r=0.05, kappa_end=20.0, size=0.3, degree=2,
                       continuation=ContinuationSettings(method="natural", ds=4.0, ds_max=4.0))
    full = list(run_branch(cfg, shared_tmp / "full"))
    gen = run_branch(cfg, shared_tmp / "cut")
    first = [next(gen) for _ in range(3)]
    gen.close()  # the "crash": points 0..2 are on disk
    _, on_disk = read_branch(shared_tmp / "cut" / "branch.jsonl")
    assert [p["index"] for p in on_disk] == [0, 1, 2]
    resumed = list(run_branch(cfg, shared_tmp / "cut"))
    assert [p["index"] for p in resumed] == [p["index"] for p in full]
    # the first three came from the file, not recomputed (the wall times written there, by
    # rank 0; on rank 0 also the ones this run measured before the interruption)
    assert [p["wall_time"] for p in resumed[:3]] == [p["wall_time"] for p in on_disk]
    if MPI.COMM_WORLD.rank == 0:
        assert [p["wall_time"] for p in on_disk] == [p["wall_time"] for p in first]
    assert resumed[-1]["psi3_over_h"] == pytest.approx(full[-1]["psi3_over_h"], rel=1e-9)
    assert resumed[-1]["kappa_R"] == pytest.approx(20.0, rel=1e-12)


def test_resume_on_another_rank_count(shared_tmp):
    """The checkpoint is keyed by node coordinates: a run interrupted on all ranks resumes on
    one (on 2 ranks: written by 2, read by 1) and ends where the uninterrupted run does."""
    cfg = BranchConfig(shape=Sphere(1.0), h_over_r=0.05, kappa_end=20.0, size=0.3, degree=2,
                       continuation=ContinuationSettings(method="natural", ds=4.0, ds_max=4.0))
    c = MPI.COMM_WORLD
    gen = run_branch(cfg, shared_tmp / "cut")
    first = [next(gen) for _ in range(2)]
    gen.close()
    c.barrier()
    ok, msg = True, ""
    if c.rank == 0:  # the others wait: the resumed run is on rank 0 alone
        resumed = list(run_branch(cfg, shared_tmp / "cut", comm=MPI.COMM_SELF))
        full = list(run_branch(cfg, shared_tmp / "full", comm=MPI.COMM_SELF))
        checks = {
            "from the file": [p["wall_time"] for p in resumed[:2]]
            == [p["wall_time"] for p in first],
            "same points": [p["index"] for p in resumed] == [p["index"] for p in full],
            "same end": abs(resumed[-1]["psi3_over_h"] / full[-1]["psi3_over_h"] - 1) < 1e-8,
        }
        ok = all(checks.values())
        msg = str(checks)
    ok, msg = c.bcast((ok, msg), root=0)
    assert ok, msg


def test_resume_with_the_quadratic_predictor_takes_the_uninterrupted_runs_points(shared_tmp):
    """Arclength steps with ``predictor="quadratic"``: the first step after a resume starts
    from the quadratic through the checkpoint's point and the one before it (both in the
    checkpoint) as the uninterrupted run's did: the same points to round-off (1e-9; to the
    last bit on one process, where the checkpoint holds the very values)."""
    st = ContinuationSettings(ds=0.2, ds_max=0.2, ds_min=1e-4, predictor="quadratic")
    cfg = BranchConfig(shape=Sphere(1.0), h_over_r=0.05, kappa_end=4.0, size=0.3, degree=2,
                       continuation=st)
    full = list(run_branch(cfg, shared_tmp / "full"))
    gen = run_branch(cfg, shared_tmp / "cut")
    [next(gen) for _ in range(4)]
    gen.close()
    resumed = list(run_branch(cfg, shared_tmp / "cut"))
    assert [p["index"] for p in resumed] == [p["index"] for p in full]
    assert len(full) >= 7 and resumed[-1]["kappa_R"] == pytest.approx(4.0, rel=1e-12)
    keys = ("kappa_R", "psi3_over_h", "newton_its", "step")
    for a, b in zip(resumed[4:], full[4:], strict=True):
        for k in keys:
            assert a[k] == pytest.approx(b[k], rel=1e-9, abs=1e-12), (k, a[k], b[k])
    if MPI.COMM_WORLD.size == 1:
        assert [[p[k] for k in keys] for p in resumed] == [[p[k] for k in keys] for p in full]
