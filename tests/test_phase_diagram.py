"""Phase diagram driver: a small diagram on any number of ranks, the rerun after an interruption,
the mirror symmetry of the everted branch, fits, the CLI contract and bad input.

A handful of axisymmetric points at h/R = 0.04 keeps this fast; the benchmark
(benchmarks/phase_diagram.py) runs the full diagram.
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np
import pytest
from mpi4py import MPI

from shells.analyses import phase_diagram
from shells.analyses.phase_diagram import PhaseDiagramConfig, Task, compute_task, fit_all
from shells.errors import InputError
from shells.files import read_records

#: shallow caps at h/R = 0.04 lose symmetry in m = 2 (κ < 0 and the inverted shell) and snap with
#: m = 0: modes up to 6 cover them, at half the inertia cost of the default 12
SMALL = dict(h_over_r=(0.04,), thetabar_range=(1.5, 3.5), points=3, refine=1, m_max=6)


@pytest.fixture(scope="module")
def diagram(tmp_path_factory):
    """The small diagram on all ranks, interrupted after one task per rank, then completed."""
    c = MPI.COMM_WORLD
    path = str(tmp_path_factory.mktemp("pd")) if c.rank == 0 else None
    out = c.bcast(path, root=0)
    cfg = PhaseDiagramConfig(**SMALL)
    first = phase_diagram.run(cfg, out, limit=1, figure=False)
    recs_after_first = read_records(__import__("pathlib").Path(out) / "points.jsonl")
    second = phase_diagram.run(cfg, out)
    recs = read_records(__import__("pathlib").Path(out) / "points.jsonl")
    return cfg, out, first, recs_after_first, second, recs


def test_interrupted_run_resumes_without_recomputing(diagram):
    cfg, out, first, recs1, second, recs = diagram
    c = MPI.COMM_WORLD
    n_grid = 2 * cfg.points  # up and down per theta-bar
    # the interrupted run computed one task per rank, all written to the points file
    assert first["stats"]["computed"] == c.size == len(recs1)
    # the rerun computed exactly the rest of the grid (+ the theta-bar_s bisection step)
    grid = [r for r in recs if r["tag"] == "grid"]
    assert len(grid) == n_grid
    keys = [(r["thetabar"], r["direction"]) for r in grid]
    assert len(set(keys)) == n_grid  # nothing computed twice
    refine = [r for r in recs if r["tag"] == "refine"]
    assert second["stats"]["computed"] == n_grid - c.size + len(refine)
    assert all(r["status"] == "ok" for r in recs)
    # a third run finds everything done
    third = phase_diagram.run(cfg, out, figure=False)
    assert third["stats"]["computed"] == 0


def test_points_and_phases(diagram):
    _, _, _, _, res, _ = diagram
    pts = {round(p["thetabar"], 6): p for p in res["points"] if p["tag"] == "grid"}
    assert sorted(pts) == [1.5, 2.5, 3.5]
    # shallow: no snap, smooth inversion then loss of symmetry (m = 2); deeper: snap first
    assert pts[1.5]["up_kind"] == "inversion" and pts[1.5]["mode_up"] == 2
    assert pts[1.5]["kappa_snap_R"] is None
    # source: the independent spectral reference's folds (tests/reference/axisym_reference.py,
    # h/R = 0.04, θ = θ̄ √(h/R)); the diagram locates them to rel_tol = 1e-3
    reference = {2.5: 1.2766767, 3.5: 2.1723575}
    for tb in (2.5, 3.5):
        assert pts[tb]["up_kind"] == "snap" and pts[tb]["mode_up"] == 0
        assert pts[tb]["kappa_snap_R"] == pytest.approx(reference[tb], rel=1e-3)
        # the paper's snapping line, a fit to its own simulations with no error given: ours
        # lies 12 % (θ̄ = 2.5) and 6 % (3.5) below it, as over all the shallow caps
        # (docs/paper-comparison.md); a comparison of models and fits, not a validation
        assert pts[tb]["kappa_snap_R"] == pytest.approx(0.85 * tb - 0.67, rel=0.15)
    for p in pts.values():
        assert p["kappa_down_R"] < 0 and p["mode_down"] == 2
    # κ_b grows less negative with θ̄ (the plate term a/θ̄² dominates for shallow caps)
    assert pts[1.5]["kappa_down_R"] < pts[2.5]["kappa_down_R"] < pts[3.5]["kappa_down_R"]
    # theta-bar_s bracketed by the grid and refined by one bisection step inside it: a bracket
    # of width 0.5 (the error is its half) that holds the true value. Source: the spectral
    # reference (tests/reference) has a fold at θ̄ = 2.0850 and none at 2.0840 (h/R = 0.04,
    # CapReference(θ̄ √0.04, 0.04).fold(step=0.005)); the paper's θ̄_s = 2.09
    s, err = res["fits"]["thetabar_s"], res["fits_error"]["thetabar_s"]
    assert err <= 0.25 + 1e-12 and abs(s - 2.0845) <= err


def test_mirror_symmetry_of_the_inverted_branch(diagram):
    """A shallow cap inverts smoothly, so its up-branch is the mirror of its down-branch: the
    loss of symmetry going up is at 2 - κ_b R (an exact symmetry of the energy; the two are
    computed independently, on different meshes of the reflected state)."""
    _, _, _, _, res, _ = diagram
    p = next(p for p in res["points"] if abs(p["thetabar"] - 1.5) < 1e-9)
    assert p["kappa_up_R"] == pytest.approx(2.0 - p["kappa_down_R"], rel=3e-3)


def test_same_results_as_a_single_process(diagram):
    """Every task runs on COMM_SELF, so a task recomputed here alone gives the same numbers as
    the diagram computed by whichever rank claimed it."""
    _, _, _, _, res, recs = diagram
    c = MPI.COMM_WORLD
    cfg = PhaseDiagramConfig(**SMALL)
    mine = [r for r in recs if r["tag"] == "grid"][c.rank]  # a different one on each rank
    again = compute_task(Task(mine["h_over_R"], mine["thetabar"], mine["direction"]), cfg)
    diff = abs(again["first"]["kappa_R"] - mine["first"]["kappa_R"])
    worst = c.allreduce(diff, op=MPI.MAX)
    assert worst <= 1e-8
    assert c.allreduce(int(again["first"]["mode_m"] != mine["first"]["mode_m"])) == 0
    # every rank returns the same result object
    blob = json.dumps(res["fits"], sort_keys=True)
    assert c.allreduce(int(blob != c.bcast(blob, root=0))) == 0


def test_fits_recover_known_lines():
    """Synthetic points on the paper's lines plus known noise: the fits return the parameters
    within their standard errors (and the errors are of the noise's size)."""
    rng = np.random.default_rng(1)
    pts = []
    for h in (0.01, 0.04):
        for tb in np.linspace(1.0, 12.0, 23):
            if tb * math.sqrt(h) > 0.9 * math.pi:
                continue
            from shells.theory import buckling_kappa_R, snap_kappa_R

            kb = buckling_kappa_R(tb, h) + 0.01 * rng.standard_normal()
            p = {"h_over_R": h, "thetabar": float(tb), "kappa_down_R": kb,
                 "kappa_everted_R": 2 - kb, "up_kind": "snap" if tb > 2.09 else "inversion"}
            p["kappa_snap_R"] = (snap_kappa_R(tb) + 0.01 * rng.standard_normal()
                                 if tb > 2.09 else None)
            pts.append(p)
    fit = fit_all(pts)
    f, e = fit["fits"], fit["fits_error"]
    for k, ref in (("alpha", 0.67), ("beta", 0.85), ("b", 3.6), ("c", -0.98)):
        assert abs(f[k] - ref) < 4 * e[k], (k, f[k], e[k])
        assert e[k] < 0.1
    assert 1.5 < f["thetabar_s"] < 2.5
    # the paper's lines cross at its triple point: 3.85 for the h/R of its figure
    assert f["thetabar_c"] == pytest.approx(3.85, abs=0.3)


def test_cli_contract_and_bad_input(diagram, capsys):
    """The subcommand on a parser: --json last line (rank 0) from the finished directory
    (nothing recomputed), bad input is an InputError."""
    from shells.cli.common import Parser as _Parser
    from shells.cli.phase_diagram import add_subcommand

    _, out, *_ = diagram
    parser = _Parser(prog="shells")
    sub = parser.add_subparsers(dest="command", parser_class=_Parser)
    add_subcommand(sub)
    args = parser.parse_args(["phase-diagram", "--h-over-r", "0.04", "--thetabar-range", "1.5",
                              "3.5", "--points", "3", "--refine", "1", "--m-max", "6", "-o",
                              out, "--json", "--no-figure"])
    assert args.func(args) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    if MPI.COMM_WORLD.rank == 0:
        res = json.loads(lines[-1])
        assert set(res["fits"]) >= {"alpha", "beta", "b", "c", "thetabar_s", "thetabar_c"}
        assert res["stats"]["computed"] == 0 and len(res["points"]) >= 3
    else:
        assert lines == []
    for bad in (["--h-over-r", "0", "--thetabar-range", "1", "2", "--points", "2"],
                ["--h-over-r", "0.04", "--thetabar-range", "3", "2", "--points", "2"],
                ["--h-over-r", "0.04", "--thetabar-range", "1", "2", "--points", "0"],
                ["--h-over-r", "0.04", "--thetabar-range", "16", "17", "--points", "2"]):
        with pytest.raises(InputError):
            a = parser.parse_args(["phase-diagram", *bad, "-o", out])
            a.func(a)
    with pytest.raises(InputError):
        PhaseDiagramConfig(h_over_r=(0.04,), thetabar_range=(1, 2), points=2, model="beam")
    assert isinstance(parser, argparse.ArgumentParser)


def test_landings_of_snap_runs_in_the_figure_and_the_result(diagram, capsys, tmp_path):
    """``--landings``: the snap runs kept in benchmarks/results/snap (surface model, h/R =
    0.04 and 0.01) are read, sorted by h/R and θ̄ (θ/√(h/R): the θ̄ their folders are named
    by), listed in the JSON as their snap.json has them and drawn; a folder without snap.json
    and a file that is not one are refused."""
    from pathlib import Path

    from shells.cli.common import Parser as _Parser
    from shells.cli.phase_diagram import add_subcommand

    _, out, *_ = diagram
    snaps = Path(__file__).resolve().parent.parent / "benchmarks" / "results" / "snap"
    parser = _Parser(prog="shells")
    sub = parser.add_subparsers(dest="command", parser_class=_Parser)
    add_subcommand(sub)
    args = parser.parse_args(["phase-diagram", "--h-over-r", "0.04", "--thetabar-range", "1.5",
                              "3.5", "--points", "3", "--refine", "1", "--m-max", "6", "-o",
                              out, "--json", "--landings", str(snaps)])
    assert args.func(args) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    ok = True
    if MPI.COMM_WORLD.rank == 0:
        res = json.loads(lines[-1])
        marks = res["landings"]
        keys = [(r["h_over_R"], r["thetabar"]) for r in marks]
        ok = keys == sorted(keys) and sum(r["h_over_R"] == 0.04 for r in marks) >= 7
        for r in marks:
            src = json.loads(Path(r["source"]).read_text())
            named = Path(r["source"]).parent.name.removeprefix("thetabar_")
            ok = ok and (r["symmetric"], r["mode_m"], r["kappa_R"]) == (
                src["landing"]["symmetric"], src["landing"]["mode_m"], src["start"]["kappa_R"])
            ok = ok and r["kappa_R"] > r["kappa_fold_R"]
            ok = ok and r["h_over_R"] == src["config"]["h_over_r"]
            if named != Path(r["source"]).parent.name:
                ok = ok and r["thetabar"] == pytest.approx(float(named), rel=1e-9)
        ok = ok and (Path(out) / "phase_diagram.png").stat().st_size > 0
    assert MPI.COMM_WORLD.allreduce(ok, op=MPI.LAND)
    empty = tmp_path / "empty"
    empty.mkdir()
    (tmp_path / "other.json").write_text('{"points": []}')
    for bad in (empty, tmp_path / "other.json", tmp_path / "missing"):
        with pytest.raises(InputError):
            phase_diagram.read_landings([bad])
