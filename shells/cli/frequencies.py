"""``shells frequencies``: the lowest natural frequencies of a shell at a natural curvature (CLI
layer; no library module imports it); the run is ``shells.analyses.frequencies.run``.

    shells frequencies --shape sphere --h-over-r H [--nu NU] [--kappa-R K [K ...]]
        [--count K] [--m-max M] [--model axisym|surface] [--size S] [--degree D]
        [--plot FILE.png] [--json]

JSON (last line with --json): ``kappa_R``, ``kappa_h``, ``model``, ``dofs`` and
``frequencies`` [{``omega`` (units √(E/ρ)/R), ``omega2``, ``mode_m``, ``mode_n``,
``block``}, ...], ascending. With several κ (followed in the order given,
``shells.analyses.frequencies.along``): those of the last κ, ``points`` (one such record per
κ) and ``critical_estimate`` {``kappa_R``, ``block``, ``mode_n``}: where the first mode's ω²,
extrapolated linearly, reaches zero (the vibration-correlation technique); ``--plot``: ω² of
each mode against κR.
"""

from __future__ import annotations

import argparse
from typing import Any

from shells.cli import common
from shells.errors import InputError

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
    p.add_argument("--plot", dest="figure", default=None, metavar="FILE.png",
                   help="with several --kappa-R: omega^2 of each mode against kappa R, the "
                   "estimated critical point marked")
    p.add_argument("--kappa-R", dest="kappa_R", type=float, default=[0.0], nargs="+",
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
    kw = {"model": args.model, "count": args.count, "m_max": args.m_max, "cells": args.cells,
          "size": args.size, "degree": args.degree}
    several = len(args.kappa_R) > 1
    if args.figure is not None and not several:
        raise InputError("--plot draws omega^2 along kappa: give several --kappa-R values")
    result = (frequencies.along(shape, args.h_over_r, args.nu, kappa_R=args.kappa_R, **kw)
              if several else
              frequencies.run(shape, args.h_over_r, args.nu, kappa_R=args.kappa_R[0], **kw))
    if args.figure is not None and common.rank() == 0:
        frequencies.make_figure(result, args.figure)

    def table(point: dict) -> None:
        print(f"kappa R = {point['kappa_R']:g}")
        print("  omega [sqrt(E/rho)/R]   omega^2      m     n")
        for f in point["frequencies"]:
            m = "-" if f["mode_m"] is None else f["mode_m"]
            n = "-" if f["mode_n"] is None else f["mode_n"]
            print(f"  {f['omega']:>20.8g}  {f['omega2']:>10.6g}  {m:>4}  {n:>4}")

    def human() -> None:
        print(f"{shape.kind}, h/R = {args.h_over_r}, nu = {args.nu}, "
              f"{common.model_words(args)}, {result['dofs']} DOFs")
        for point in result.get("points", [result]):
            table(point)
        est = result.get("critical_estimate")
        if several:
            print("vibration-correlation estimate of the next critical point: " + (
                "none (no frequency falls)" if est is None else
                f"kappa R = {est['kappa_R']:.6g} (block {est['block']}, n = {est['mode_n']})"))

    common.emit(result, args, human)
    return 0
