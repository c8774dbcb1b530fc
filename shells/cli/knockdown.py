"""``shells knockdown`` (CLI layer; no library module imports it): the knock-down of a closed
sphere's curvature buckling by an imperfection (axisymmetric, or on the surface model a
spherical harmonic); the run is ``shells.analyses.knockdown.run``.
"""

from __future__ import annotations

import argparse
from typing import Any

from shells.cli import common

__all__ = ["add_subcommand"]


def add_subcommand(sub: Any) -> argparse.ArgumentParser:
    """Add ``shells knockdown`` to ``sub`` (the CLI's subparsers); returns its parser."""
    p = sub.add_parser("knockdown", help="knock-down of a closed sphere's buckling curvature by "
                       "an imperfection", description="For each imperfection amplitude delta/h: "
                       "follow the imperfect sphere (rotational symmetry enforced) from kappa = 0 "
                       "to its limit point kappa_max and report kappa_max / kappa_b, kappa_b the "
                       "perfect sphere's bifurcation. Points are appended to DIR/points.jsonl as "
                       "computed and a rerun skips them.")
    p.add_argument("--shape", default="sphere", choices=("sphere",),
                   help="sphere (the only shape so far)")
    p.add_argument("--h-over-r", type=common.positive_float("h/R"), required=True,
                   help="thickness over R")
    p.add_argument("--nu", type=float, default=0.5, help="Poisson ratio (default 0.5)")
    p.add_argument("--imperfection", required=True, choices=("mode", "dimple", "harmonic"),
                   help="mode: the buckling mode's shape P_n(cos beta); dimple: "
                   "-delta h exp(-(beta/beta0)^2) at the pole; harmonic (--model surface): "
                   "-delta h P_n^m(cos theta) cos(m phi) / max|P_n^m|")
    p.add_argument("--mode-n", type=int, default=None, metavar="N",
                   help="degree n of the mode or harmonic imperfection (default: the perfect "
                   "sphere's critical degree; on the surface model the thin-shell estimate, "
                   "rounded)")
    p.add_argument("--mode-m", type=int, default=0, metavar="M",
                   help="order m of the harmonic imperfection, 0 <= m <= n (default 0: the "
                   "mode's shape)")
    p.add_argument("--width", type=common.positive_float("width"), default=1.0,
                   help="dimple width beta0 in units of sqrt(h/R) (default 1)")
    p.add_argument("--amplitudes", type=float, nargs="+", required=True, metavar="A",
                   help="imperfection amplitudes delta/h")
    p.add_argument("--load", default="curvature", choices=("curvature", "pressure"),
                   help="curvature (natural curvature, default) or pressure (a dead external "
                   "pressure, reported as its equivalent curvature of Eq. (5): kappa h = "
                   "6 (1 - nu) (R/h)^2 p/E)")
    p.add_argument("--model", default="axisym", choices=("axisym", "surface"),
                   help="axisym (1D, rotational symmetry enforced; default) or surface (2D, "
                   "any mode; minutes per amplitude on a laptop)")
    p.add_argument("--size", type=common.positive_float("size"), default=0.21,
                   help="surface model: bulk element size / R (default 0.21, P3)")
    p.add_argument("--no-figure", action="store_true", help="skip the figure")
    p.add_argument("-o", "--output", default=None, help="output directory (points, figure)")
    common.add_json(p)
    p.set_defaults(func=_cmd_knockdown)
    return p


def _cmd_knockdown(args: argparse.Namespace) -> int:
    from shells.analyses import knockdown
    from shells.analyses.knockdown import KnockdownConfig
    from shells.errors import InputError

    if args.mode_n is not None and args.imperfection == "dimple":
        raise InputError("--mode-n is the degree of the mode or harmonic imperfection, not of "
                         "the dimple")
    cfg = KnockdownConfig(args.h_over_r, tuple(args.amplitudes), nu=args.nu,
                          imperfection=args.imperfection, width=args.width, load=args.load,
                          model=args.model, degree=args.mode_n, order=args.mode_m,
                          size=args.size)
    # the 1D model is serial: rank 0 computes and writes, the others compute without files;
    # the surface model computes on all ranks, rank 0 writes
    outdir = args.output if common.rank() == 0 else None
    res = knockdown.run(cfg, outdir, figure=not args.no_figure)

    def human() -> None:
        load = "" if cfg.load == "curvature" else (
            f" (pressure: p_b/E = {res['p_b_over_E']:.5g}, classical "
            f"{res['p_c_over_E_classical']:.5g})")
        m = f", m = {cfg.order}" if cfg.imperfection == "harmonic" else ""
        print(f"closed sphere h/R = {cfg.h_over_r:g}, nu = {cfg.nu:g}, "
              f"{common.model_words(args)}")
        print(f"{cfg.load}, {cfg.imperfection} (n = {res['degree']}{m}): kappa_b h = "
              f"{res['kappa_b_h']:.6f}{load}")
        law = res["asymptotics"]
        c = law and law.get("coefficient")
        print("Koiter: not computed (surface model)" if law is None else
              f"Koiter: {law['kind']} bifurcation" + (
                  f", 1 - kappa_max/kappa_b = {c:.4g} sqrt(delta/h)" if c else
                  ", no sqrt(delta) law for this imperfection's sign"
                  if law["kind"] == "asymmetric" else " (knock-down ~ delta^(2/3))"))
        print(f"{'delta/h':>9} {'kappa_max h':>12} {'knock-down':>11} {'Koiter':>9}")
        for q in res["points"]:
            k = q.get("knockdown_asymptotic")
            law_col = f"{'-':>9}" if k is None else f"{k:9.5f}"
            if q["knockdown"] is None:
                print(f"{q['delta_over_h']:9g} {'none':>12} {'-':>11} {law_col}  "
                      f"({q.get('error', 'no limit point')})")
            else:
                print(f"{q['delta_over_h']:9g} {q['kappa_max_h']:12.6f} {q['knockdown']:11.5f} "
                      f"{law_col}")

    common.emit(res, args, human)
    return 0
