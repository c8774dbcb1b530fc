"""``shells phase-diagram`` (CLI layer; no library module imports it): the phase diagram of open
caps; the run is ``shells.analyses.phase_diagram.run``.
"""

from __future__ import annotations

import argparse
from typing import Any

from shells.cli.common import add_json, emit, model_words, positive_float

__all__ = ["add_subcommand"]


def add_subcommand(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``shells phase-diagram`` on the command line's subparsers.

    Args:
        subparsers: the subparsers (``add_subparsers``' result).

    Returns:
        The subcommand's parser.
    """
    p = subparsers.add_parser(
        "phase-diagram", help="phase diagram of open caps: snap, loss of symmetry, fits",
        description="For each h/R and theta-bar = theta/sqrt(h/R): the first instability going up "
        "(kappa > 0: snap-through fold, loss of symmetry, or smooth inversion), the loss of "
        "symmetry going down (kappa < 0) and on the everted branch (2 - kappa_b R, mirror "
        "symmetry); fits of the paper's laws with standard errors; figure. Points run in "
        "parallel (one per MPI process), are appended to DIR/points.jsonl as computed, and a "
        "rerun skips finished points.")
    p.add_argument("--h-over-r", type=positive_float("h/R"), nargs="+", required=True,
                   metavar="H", help="thicknesses h/R")
    p.add_argument("--thetabar-range", type=positive_float("theta-bar"), nargs=2, required=True,
                   metavar=("A", "B"), help="theta-bar interval")
    p.add_argument("--points", type=int, required=True, metavar="N",
                   help="theta-bar values per h/R, evenly spaced in [A, B]")
    p.add_argument("--nu", type=float, default=0.5, help="Poisson ratio (default 0.5)")
    p.add_argument("--model", default="axisym", choices=("axisym", "surface"),
                   help="axisym (1D shell of revolution, default) or surface (2D, slow)")
    p.add_argument("--m-max", type=int, default=12, help="Fourier modes 0..M checked (axisym)")
    p.add_argument("--rel-tol", type=positive_float("rel-tol"), default=1e-3,
                   help="location accuracy of bifurcations, relative in kappa (default 1e-3)")
    p.add_argument("--refine", type=int, default=3,
                   help="bisection steps in theta-bar for theta-bar_s per h/R (default 3)")
    p.add_argument("--cells", type=int, default=200, help="axisym bulk cells (default 200)")
    p.add_argument("--size", type=positive_float("size"), default=0.1,
                   help="surface model: bulk element size / R (default 0.1)")
    p.add_argument("--layer-elements", type=positive_float("layer-elements"), default=4.0,
                   help="surface model: elements across sqrt(R h) (default 4)")
    p.add_argument("--no-figure", action="store_true", help="skip the figure")
    p.add_argument("--landings", nargs="+", metavar="PATH", default=None,
                   help="show where caps landed in these `shells snap` outputs (snap.json "
                        "files or folders searched for them)")
    p.add_argument("-o", "--output", default="results/phase-diagram",
                   help="output directory (default results/phase-diagram)")
    add_json(p)
    p.set_defaults(func=_cmd_phase_diagram)
    return p


def _cmd_phase_diagram(args: argparse.Namespace) -> int:
    from shells.analyses import phase_diagram
    from shells.theory import PAPER

    cfg = phase_diagram.PhaseDiagramConfig(
        h_over_r=tuple(args.h_over_r), thetabar_range=tuple(args.thetabar_range),
        points=args.points, nu=args.nu, model=args.model, m_max=args.m_max,
        rel_tol=args.rel_tol, refine=args.refine,
        discretisation=phase_diagram.Discretisation(cells=args.cells, size=args.size,
                                                    layer_elements=args.layer_elements))
    landings = (phase_diagram.read_landings(args.landings) if args.landings is not None
                else None)
    res = phase_diagram.run(cfg, args.output, figure=not args.no_figure, landings=landings)

    def human() -> None:
        f, e = res["fits"], res["fits_error"]
        print(f"{len(res['points'])} points (h/R = {', '.join(f'{h:g}' for h in cfg.h_over_r)}),"
              f" {res['stats']['computed']} computed in this run -> {res['points_file']}; "
              f"{model_words(args)}")
        print(f"{'h/R':>6} {'thetabar':>8} {'up':>11} {'kappaR':>8} {'m':>3} {'snap':>8} "
              f"{'down':>8} {'m':>3} {'everted':>8}")
        fmt = lambda v: f"{v:8.3f}" if v is not None else f"{'-':>8}"  # noqa: E731
        for p in res["points"]:
            print(f"{p['h_over_R']:6g} {p['thetabar']:8.3f} {p.get('up_kind', '-'):>11} "
                  f"{fmt(p.get('kappa_up_R'))} {str(p.get('mode_up', '-')):>3} "
                  f"{fmt(p.get('kappa_snap_R'))} {fmt(p.get('kappa_down_R'))} "
                  f"{str(p.get('mode_down', '-')):>3} {fmt(p.get('kappa_everted_R'))}")
        print("fits (ours ± standard error | paper):")
        for k in ("alpha", "beta", "b", "c", "thetabar_s", "thetabar_c"):
            v = f"{f[k]:.4g} ± {e[k]:.2g}" if f.get(k) is not None else "n/a"
            print(f"  {k:>10}: {v:>20} | {PAPER[k]}")
        for r in res.get("landings", []):
            print(f"landing: thetabar {r['thetabar']:.4g} (h/R = {r['h_over_R']:g}) snapped at "
                  f"kappa R = {r['kappa_R']:.5g}: "
                  + ("symmetric" if r["symmetric"] else f"broken symmetry, m = {r['mode_m']}"))
        for fig in res.get("figures", []):
            print(f"wrote {fig}")

    emit(res, args, human)
    return 0
