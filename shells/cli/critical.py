"""``shells critical`` (CLI layer; no library module imports it): the critical points of the
fundamental branch; the run is ``shells.analyses.critical.run``.
"""

from __future__ import annotations

import argparse
from typing import Any

from shells.analyses.setup import kappa_end
from shells.cli import common


def add_subcommand(sub: Any) -> argparse.ArgumentParser:
    """Add ``shells critical`` to ``sub`` (the CLI's subparsers); returns its parser."""
    c = sub.add_parser("critical", help="first critical point (fold or bifurcation) along the "
                       "fundamental branch", description="Follow the fundamental branch from "
                       "kappa = 0 with the Hessian inertia at every point; locate every critical "
                       "point (to 1e-4 in kappa) up to the first fold or the end of the range, "
                       "classify it (fold/bifurcation) and its mode (n on spheres, m otherwise).")
    common.add_shape_args(c, positional=False, user_mesh=True)
    common.add_physics_args(c, "surface",
                            "surface (2D mesh, default) or axisym (shell of revolution)")
    common.add_kappa_range(c)
    common.add_field_args(c)
    c.add_argument("--first-only", action="store_true", help="stop at the first critical point")
    common.add_mesh_size_args(c, None, "bulk element size / R (default 0.1; caps deeper than "
                              "thetabar = 3 and ellipsoids 0.2; closed spheres: 4.25 elements per "
                              "wavelength of the critical degree n, at most 0.21, refused above "
                              "150k DOFs)")
    c.add_argument("--shear-penalty", type=common.positive_float("shear-penalty"), default=1.0e3,
                   help="Kirchhoff-Love penalty, times the Naghdi shear stiffness (default 1e3)")
    common.add_degree_arg(c)
    c.add_argument("--ds", type=common.positive_float("ds"), default=None,
                   help="initial step, in kappa L (default: range/16)")
    c.add_argument("--ds-max", type=common.positive_float("ds-max"), default=None,
                   help="largest step, in kappa L (default: range/10)")
    c.add_argument("-o", "--output", default=None,
                   help="directory for branch.jsonl (points and critical points as computed; "
                   "surface model: a rerun resumes from DIR/checkpoint/), critical.json and "
                   "the critical modes for ParaView (modes.bp)")
    c.add_argument("--restart", action="store_true",
                   help="ignore an existing branch file (surface model; the 1D model always "
                   "computes again)")
    return common.add_outputs(c, _cmd_critical)


def _cmd_critical(args: argparse.Namespace) -> int:
    from shells.analyses import critical

    shape, fld = common.shape_and_field(args)
    surface = {} if args.model != "surface" else dict(
        size=args.size, layer_elements=args.layer_elements,
        shear_penalty=args.shear_penalty, degree=args.degree, ds=args.ds, ds_max=args.ds_max,
        mesh_file=args.mesh, resume=not args.restart)
    result = critical.run(shape, args.h_over_r, args.nu, direction=args.direction,
                          model=args.model, outdir=args.output, kappa_field=fld,
                          first_only=args.first_only,
                          kappa_end=kappa_end(shape, args.h_over_r, args.kappa_h_max,
                                                     args.kappa_r_max, args.direction),
                          **surface)

    def human() -> None:
        print(f"{shape.kind}, h/L = {args.h_over_r}, nu = {args.nu}, {args.direction}, "
              f"{result.get('dofs')} DOFs, {common.model_words(args)}")
        cps = result["critical_points"]
        if not cps:
            print(f"no critical point up to kappa R = {result['kappa_R_end']:.4f} "
                  f"(kappa h = {result['kappa_h_end']:.4f})")
        for c in cps:
            mode = (f"n = {c['mode_n']}" if c.get("mode_n") is not None
                    else f"m = {c.get('mode_m')}")
            print(f"{c['kind']:>12} at kappa R = {c['kappa_R']:.6f}, kappa h = "
                  f"{c['kappa_h']:.6f}  ({mode})")

    common.emit(result, args, human)
    return 0
