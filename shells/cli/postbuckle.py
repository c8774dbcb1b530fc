"""``shells postbuckle``: the command line of ``shells.analyses.postbuckle`` (CLI layer; no library
module imports it); the run is ``shells.analyses.postbuckle.run``.

    shells postbuckle --shape S --h-over-r H [--nu NU] [--theta-deg T] [--direction up|down]
        [--model axisym|surface] [--at K] [--kappa-r-max X | --kappa-h-max X] [-o DIR]
        [--fields none|last|all] [--json]

Follows the fundamental branch, locates its K-th bifurcation, switches and follows the
bifurcated branch on both sides. JSON (last line with --json): ``critical_point`` (the keys of
an entry of ``shells critical``'s ``critical_points``), ``points`` (fundamental and bifurcated:
the keys of ``shells branch``'s points plus ``branch``, ``stable``, ``negative_count``,
``orientation_modes`` (the negative ones that only turn a pattern about the axis or slide a
sphere's dimple over it: neutral, not counted against ``stable``), ``psi3_pole_over_h``,
``mode_amplitude``, and on bifurcated points ``side``, ``start``,
``subcritical``), ``sides`` (per side: points, how it ended, up/down, ``parameter``),
``branch_file``, and the shapes written. A closed sphere (either model) follows the dimple at
the pole with its depth Ψ3(pole)/h as the parameter (side -1: the pole in; points past a fold of
the depth, followed by arclength, carry ``control_parameter`` 0). With -o, every point is
appended to DIR/postbuckle.jsonl as computed; with ``--fields``, the 1D model writes each
bifurcated state (``last``: the last one of each side) as a 3D surface
DIR/shapes/side{+1,-1}_NNN.vts (arrays ``displacement``, ``normal_displacement``) and its
meridian as CSV; the surface model writes VTX fields DIR/fields_side{+1,-1}.bp.
"""

from __future__ import annotations

import argparse
import math
from typing import Any

from shells.analyses.setup import kappa_end
from shells.cli import common
from shells.errors import InputError

__all__ = ["add_subcommand"]


def add_subcommand(sub: Any) -> argparse.ArgumentParser:
    """Add ``shells postbuckle`` to ``sub`` (the CLI's subparsers); returns its parser."""
    p = sub.add_parser("postbuckle", help="follow the branch that bifurcates from the "
                       "fundamental one (post-buckling), both sides",
                       description="Follow the fundamental branch from kappa = 0, locate its "
                       "K-th bifurcation, switch onto the bifurcated branch along the critical "
                       "mode and follow it on both sides by pseudo-arclength, with the "
                       "stability at every point. The 1D model (axisym) follows axisymmetric "
                       "branches only (a closed sphere's buckling with rotational symmetry "
                       "enforced, as in the paper).")
    common.add_shape_args(p, positional=False, user_mesh=True)
    common.add_physics_args(p, "axisym", "axisym (1D, default) or surface (2D mesh)")
    p.add_argument("--at", type=int, default=1, help="the K-th bifurcation (default 1)")
    common.add_kappa_range(p)
    common.add_field_args(p)
    p.add_argument("--kappa-min-ratio", type=float, default=0.5,
                   help="bifurcated branches end below this kappa/kappa_c (default 0.5)")
    p.add_argument("--max-points", type=int, default=60,
                   help="points per side of the bifurcated branch (default 60)")
    p.add_argument("--size", type=common.positive_float("size"), default=None,
                   help="surface model: bulk element size / R (default 0.2)")
    p.add_argument("--layer-elements", type=common.positive_float("layer-elements"), default=3.0,
                   help="surface model: elements across sqrt(R h) at the rim (default 3)")
    common.add_degree_arg(p)
    p.add_argument("--fields", default="none", choices=("none", "last", "all"),
                   help="write the bifurcated states for ParaView (needs -o)")
    p.add_argument("--sides", default="both", choices=("both", "+1", "-1"),
                   help="the sides of the critical mode to follow (default both; a "
                        "pitchfork's are mirror images)")
    p.add_argument("-o", "--output", default=None,
                   help="directory: postbuckle.jsonl (points as computed) and shapes")
    return common.add_outputs(p, _cmd_postbuckle)


def _cmd_postbuckle(args: argparse.Namespace) -> int:
    from shells.analyses import postbuckle
    from shells.analyses.postbuckle import PostbuckleConfig

    shape, fld = common.shape_and_field(args)
    k_end = kappa_end(shape, args.h_over_r, args.kappa_h_max, args.kappa_r_max,
                             args.direction)
    if k_end is not None and not (math.isfinite(k_end) and k_end != 0):
        raise InputError("the end of the kappa range must be a nonzero number")
    if args.fields != "none" and args.output is None:
        raise InputError("--fields needs an output directory (-o DIR)")
    cfg = PostbuckleConfig(shape=shape, h_over_r=args.h_over_r, nu=args.nu, model=args.model,
                           direction=args.direction, at=args.at, kappa_end=k_end,
                           kappa_min_ratio=args.kappa_min_ratio, max_points=args.max_points,
                           size=args.size, layer_elements=args.layer_elements,
                           degree=args.degree,
                           sides=(1, -1) if args.sides == "both" else (int(args.sides),),
                           kappa_field=fld, mesh_file=args.mesh)
    result = postbuckle.run(cfg, args.output, fields=args.fields)
    cp, points, sides = result["critical_point"], result["points"], result["sides"]

    def human() -> None:
        print(f"{shape.kind} h/L = {args.h_over_r}, nu = {args.nu}, {common.model_words(args)}")
        print(f"{cp['kind']} at kappa R = {cp['kappa_R']:.6f} (kappa h = {cp['kappa_h']:.6f}), "
              f"m = {cp['mode_m']}, n = {cp['mode_n']}")
        print(f"{'branch':>11} {'side':>4} {'kappa R':>10} {'kappa/kc':>8} {'Psi3 pole/h':>11} "
              f"{'amplitude':>9} {'neg':>4} {'orbit':>5}")
        for p in points:
            if p["branch"] == "fundamental" and p is not points[-1] and p["index"] % 10:
                continue
            print(f"{p['branch']:>11} {p.get('side', ''):>4} {p['kappa_R']:10.4f} "
                  f"{p['kappa'] / cp['kappa']:8.4f} {p['psi3_pole_over_h']:11.4f} "
                  f"{p['mode_amplitude']:9.3f} {p['negative_count']:4d} "
                  f"{p.get('orientation_modes', 0):5d}")
        for side, s in (sides or {}).items():
            print(f"side {int(side):+d}: {s['points']} points, starts {s['start']}, "
                  f"ended: {s['ended']}")
            for c in s.get("critical", []):
                print(f"  {c['kind']} of the branch at kappa R = {c['kappa_R']:.6f} "
                      f"(kappa/kc = {c['kappa_over_kappa_c']:.5f}), m = {c['mode_m']}, "
                      f"accuracy {c['accuracy']:.1e}")

    common.emit(result, args, human)
    return 0
