"""``shells frequencies``: the lowest natural frequencies of a shell at a natural curvature (CLI
layer; no library module imports it); the run is ``shells.analyses.frequencies.run``.

    shells frequencies --shape sphere --h-over-r H [--nu NU] [--kappa-R K] [--count K]
        [--m-max M] [--model axisym|surface] [--size S] [--degree D] [--json]

JSON (last line with --json): ``kappa_R``, ``kappa_h``, ``model``, ``dofs`` and
``frequencies`` [{``omega`` (units √(E/ρ)/R), ``omega2``, ``mode_m``, ``mode_n``,
``block``}, ...], ascending.
"""

from __future__ import annotations

import argparse
from typing import Any

from shells.cli import common

__all__ = ["add_subcommand"]


def add_subcommand(sub: Any) -> argparse.ArgumentParser:
    """Add ``shells frequencies`` to ``sub`` (the CLI's subparsers); returns its parser."""
    description = ("The lowest natural frequencies of the free shell prestressed at kappa R "
                   "(reached by Newton from kappa = 0), omega in units of sqrt(E/rho)/R, "
                   "rigid motions excluded, each with its mode (n on a sphere, else m).")
    p = sub.add_parser("frequencies", description=description,
                       help="lowest natural frequencies at a natural curvature")
    common.add_shape_args(p, positional=False)
    common.add_shell_args(p)
    p.add_argument("--kappa-R", dest="kappa_R", type=float, default=0.0,
                   help="kappa R of the state (default 0: the unstressed shell)")
    p.add_argument("--model", default="axisym", choices=("axisym", "surface"),
                   help="axisym (1D model, every Fourier block m, default) or surface")
    p.add_argument("--count", type=int, default=4,
                   help="frequencies per Fourier block (1D model) or in all (surface; "
                   "default 4)")
    p.add_argument("--m-max", dest="m_max", type=int, default=6,
                   help="1D model: largest wavenumber m (default 6)")
    p.add_argument("--cells", type=int, default=None, help="1D model: bulk cells")
    common.add_mesh_size_args(p, None, "surface model: bulk element size / R (default: as "
                              "`shells critical`)")
    common.add_degree_arg(p)
    common.add_json(p)
    p.set_defaults(func=_cmd_frequencies)
    return p


def _cmd_frequencies(args: argparse.Namespace) -> int:
    from shells.analyses import frequencies

    shape = common.shape_from_args(args)
    result = frequencies.run(shape, args.h_over_r, args.nu, kappa_R=args.kappa_R,
                             model=args.model, count=args.count, m_max=args.m_max,
                             cells=args.cells, size=args.size, degree=args.degree)

    def human() -> None:
        print(f"{shape.kind}, h/R = {args.h_over_r}, nu = {args.nu}, kappa R = "
              f"{args.kappa_R:g}, model {args.model}, {result['dofs']} DOFs")
        print("  omega [sqrt(E/rho)/R]   omega^2      m     n")
        for f in result["frequencies"]:
            m = "-" if f["mode_m"] is None else f["mode_m"]
            n = "-" if f["mode_n"] is None else f["mode_n"]
            print(f"  {f['omega']:>20.8g}  {f['omega2']:>10.6g}  {m:>4}  {n:>4}")

    common.emit(result, args, human)
    return 0
