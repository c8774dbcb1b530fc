"""``shells branch`` (CLI layer; no library module imports it): follow a shell in kappa from 0,
either model; the run is ``shells.analyses.branch.run``.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any

from shells.analyses.setup import kappa_end
from shells.cli.common import (
    add_degree_arg,
    add_field_args,
    add_kappa_range,
    add_outputs,
    add_shape_args,
    add_shell_args,
    emit,
    field_from_args,
    model_words,
    positive_float,
    shape_from_args,
)
from shells.errors import InputError


def add_subcommand(sub: Any) -> argparse.ArgumentParser:
    """Add ``shells branch`` to ``sub`` (the CLI's subparsers); returns its parser."""
    b = sub.add_parser("branch", help="follow the equilibrium branch in kappa (continuation)",
                       description="Follow a shell from kappa = 0 to a final natural curvature "
                       "with pseudo-arclength (through folds) or natural continuation; each point "
                       "is appended to DIR/branch.jsonl as it is computed and a rerun resumes.")
    add_shape_args(b, positional=False, user_mesh=True)
    add_shell_args(b)
    add_kappa_range(b, "final kappa h (sign: direction)", "final kappa R (sign: direction)")
    b.add_argument("--model", default="surface", choices=("surface", "axisym"),
                   help="surface (2D mesh, default) or axisym (shell of revolution, 1D)")
    add_field_args(b)
    b.add_argument("--method", default="arclength", choices=("arclength", "natural"))
    b.add_argument("--ds", type=positive_float("ds"), default=0.1, help="initial step")
    b.add_argument("--ds-max", type=positive_float("ds-max"), default=1.0, help="largest step")
    b.add_argument("--size", type=positive_float("size"), default=None,
                   help="bulk element size / R (default 0.1; caps deeper than thetabar = 3 and "
                   "ellipsoids 0.2; closed spheres 0.21)")
    add_degree_arg(b)
    b.add_argument("--layer-elements", type=positive_float("layer-elements"), default=4.0,
                   help="elements across sqrt(R h) at the rim (default 4)")
    b.add_argument("--shear-penalty", type=positive_float("shear-penalty"), default=1.0e3,
                   help="Kirchhoff-Love penalty, times the Naghdi shear stiffness (default 1e3)")
    b.add_argument("--fields", default="none", choices=("none", "last", "all"),
                   help="write VTX fields (DIR/fields.bp) for ParaView")
    b.add_argument("--restart", action="store_true", help="ignore an existing branch file")
    b.add_argument("-o", "--output", default=None, help="output directory (results/branch)")
    return add_outputs(b, _cmd_branch)


def _cmd_branch(args: argparse.Namespace) -> int:
    from shells.analyses import branch

    if (args.kappa_h_max is None) == (args.kappa_r_max is None):
        raise InputError("give exactly one of --kappa-h-max, --kappa-r-max and --kappa-max")
    shape = shape_from_args(args)
    outdir = args.output or "results/branch"
    fld = field_from_args(args, shape, args.model)
    k_end = kappa_end(shape, args.h_over_r, args.kappa_h_max, args.kappa_r_max)  # checked
    if args.model == "axisym":
        result = branch.run(shape, args.h_over_r, args.nu, k_end, model="axisym",
                            outdir=outdir, kappa_field=fld)
        header = f"{'kappa R':>10} {'kappa h':>10} {'Psi3/h':>12} {'energy':>12} its unstable m"

        def row(p: dict[str, Any]) -> str:
            return (f"{p['kappa_R']:10.4f} {p['kappa_h']:10.4f} {p['psi3_over_h']:12.4e} "
                    f"{p['energy']:12.5e} {p['newton_its']:3d} {p.get('unstable_modes')}")

        title, with_last = (f"{shape.kind} h/L = {args.h_over_r}, nu = {args.nu}, "
                            f"{model_words(args)}", False)
    else:
        from shells.algorithms.settings import ContinuationSettings

        cont = ContinuationSettings(method=args.method, ds=args.ds,
                                    ds_max=max(args.ds, args.ds_max))
        result = branch.run(shape, args.h_over_r, args.nu, k_end, model="surface",
                            outdir=outdir, kappa_field=fld, fields=args.fields,
                            resume=not args.restart, size=args.size,
                            layer_elements=args.layer_elements,
                            shear_penalty=args.shear_penalty, continuation=cont,
                            degree=args.degree, mesh_file=args.mesh)
        header = (f"{'kappa R':>10} {'kappa h':>10} {'Psi3/h':>12} {'apex/h':>10} "
                  f"{'energy':>12} its")

        def row(p: dict[str, Any]) -> str:
            return (f"{p['kappa_R']:10.4f} {p['kappa_h']:10.4f} {p['psi3_over_h']:12.4e} "
                    f"{p['apex_uz_over_h']:10.4f} {p['energy']:12.5e} {p['newton_its']:3d}")

        title, with_last = (f"{shape.kind} h/L = {args.h_over_r}, nu = {args.nu}, "
                            f"{model_words(args)}", True)
    emit(result, args, lambda: _print_branch(result, title, header, row, with_last))
    return 0


def _print_branch(result: dict[str, Any], title: str, header: str,
                  row: Callable[[dict[str, Any]], str], with_last: bool) -> None:
    """About 25 rows of the branch (``with_last``: and its last point), then its folds."""
    points = result["points"]
    print(title)
    print(f"{len(points)} points -> {result['branch_file']}")
    print(header)
    step = max(1, len(points) // 25)
    rows = points[::step]
    if with_last and (len(points) - 1) % step:
        rows = rows + [points[-1]]
    for p in rows:
        print(row(p))
    for f in result["folds"]:
        print(f"fold (turning point in kappa) near kappa R = {f['kappa_R']:.4f}")
