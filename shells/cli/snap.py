"""``shells snap``: where a cap lands when it snaps (CLI layer; no library module imports it); the
run is ``shells.analyses.snap.run``.

    shells snap --shape cap --theta-deg T --h-over-r H [--nu NU] [--past P | --kappa-R K]
        [--amplitude A] [--method minimise|dynamics] [--damping ALPHA] [--step-tol T]
        [--settle F] [--t-max T] [--size S] [--degree D] [-o DIR] [--json]

Follows the fundamental branch (the surface model) to its snap fold, steps past it and
minimises the energy there (TAO) from the fold's state perturbed along its unstable modes;
with ``--method dynamics`` integrates the equations of motion from there to rest (damping
C = ALPHA M, ALPHA in units of √(E/ρ)/R), until the shell has settled in a minimum's basin
(kinetic energy below F of its peak, the Hessian stable) or until the time T, and polishes
that state by the same minimiser.
JSON (last line with --json): ``start`` {``kappa_R``, ``kind``, ``kappa_fold_R``,
``unstable``}, ``method``, ``landing`` {``kappa_R``, ``energy``, ``stable``,
``negative_count``, ``orbit_modes``, ``mode_m``, ``symmetric``, ``spectrum``,
``rim_rotation_deg``, ``psi3_pole_over_h``, ``iterations``}, ``axisymmetric_everted``
{``energy``, ``negative_count``, ``rim_rotation_deg``}, ``snap_time`` (null for minimisation;
in units of R √(ρ/E)), ``dynamics`` (null for minimisation; ``reason``, ``steps``,
``snap_time``, ``kinetic_peak_time``, ``end_time``, ``rest_energy``, ``damping``,
``step_tol``, ``settle``, ``t_max``;
``reason`` "rest", "settled" or "time"; ``landing.rest_energy`` is
the energy at rest before the polish; ``frames``, ``animation_frames``, ``frame_every``: what
snap.bp and snap.gif hold), ``critical_points``, ``dofs``, ``mesh``, ``files`` (each file
written, by what it is). With -o DIR: snap.json, landing.png/.vtu, everted.png, and with
dynamics snap_series.csv (one row per time step: time, kinetic and elastic energy, Ψ3 at the
pole, rim rotation, m = 1..4 amplitudes), snap.bp (the fields over time for ParaView, VTX:
every k-th step, at most 200, and the last) and snap.gif (the animation, at most 100 frames;
not with --no-render); and a checkpoint a rerun resumes from (the dynamics every 100 steps).
"""

from __future__ import annotations

import argparse
from typing import Any

from shells.cli import common
from shells.errors import InputError

__all__ = ["add_subcommand"]


def add_subcommand(sub: Any) -> argparse.ArgumentParser:
    """Add ``shells snap`` to ``sub`` (the CLI's subparsers); returns its parser."""
    p = sub.add_parser(
        "snap", help="where a cap lands when it snaps through (surface model)",
        description="Follow the fundamental branch (surface model) to its snap fold, step past "
        "it, perturb the state along its unstable modes and minimise the energy at that kappa "
        "(PETSc TAO, Newton with negative curvature): the landing state, its stability and "
        "symmetry, against the axisymmetric everted state.")
    common.add_shape_args(p, positional=False)
    common.add_shell_args(p)
    g = p.add_mutually_exclusive_group()
    g.add_argument("--past", type=common.positive_float("past"), default=0.01,
                   help="land at kappa = (1 + PAST) kappa_fold (default 0.01)")
    g.add_argument("--kappa-R", dest="kappa_R", type=float, default=None,
                   help="land at this kappa R instead (past the fold)")
    p.add_argument("--method", default="minimise", choices=("minimise", "dynamics"),
                   help="minimise: the energy's local minimum reached by TAO (default); "
                   "dynamics: the equations of motion integrated to rest, then polished")
    p.add_argument("--step-tol", type=common.positive_float("step-tol"), default=None,
                   help="dynamics: the adaptive time steps' tolerance on the local error "
                        "(default 1e-4; the steps stay between 0.05 and 1 R sqrt(rho/E))")
    p.add_argument("--settle", type=common.nonnegative_float("settle"), default=None,
                   help="dynamics: stop once settled, where the kinetic energy is below this "
                   "fraction of its peak (checked every 100 steps) and the Hessian is stable, "
                   "and polish from there (default 1e-4; 0: integrate until at rest; a run "
                   "under way continues under another value)")
    p.add_argument("--t-max", dest="t_max", type=common.positive_float("t-max"), default=None,
                   help="dynamics: stop at this time in R sqrt(rho/E) if not at rest or settled "
                   "before, and polish from there (default 5000; a run under way continues "
                   "under another value)")
    p.add_argument("--damping", type=common.nonnegative_float("damping"), default=None,
                   help="dynamics: mass-proportional damping alpha in sqrt(E/rho)/R "
                   "(default 1; a saddle's unstable direction mu is left at the rate s, "
                   "s^2 + alpha s + mu = 0)")
    p.add_argument("--amplitude", type=common.positive_float("amplitude"), default=0.1,
                   help="the perturbation along each unstable mode, RMS / h (default 0.1)")
    p.add_argument("--kappa-R-max", dest="kappa_R_max", type=common.positive_float("kappa-R-max"),
                   default=None, help="search the fold up to this kappa R (default 2 thetabar + 6)")
    common.add_mesh_size_args(p, None, "bulk element size / R (default: as `shells critical`)")
    common.add_degree_arg(p)
    p.add_argument("--no-render", action="store_true",
                   help="no landing.png / everted.png / snap.gif")
    p.add_argument("-o", "--output", default=None,
                   help="directory: snap.json, landing.png/.vtu, everted.png, checkpoint/; "
                   "dynamics: snap_series.csv, snap.bp (fields over time, ParaView), snap.gif")
    common.add_json(p)
    p.set_defaults(func=_cmd_snap, model="surface")
    return p


def _cmd_snap(args: argparse.Namespace) -> int:
    from shells.analyses import snap

    shape = common.shape_from_args(args)
    if args.past > 1:
        raise InputError(f"--past must lie in (0, 1], got {args.past:g}")
    cfg = snap.SnapConfig(shape=shape, h_over_r=args.h_over_r, nu=args.nu, past=args.past,
                          kappa_R=args.kappa_R, amplitude=args.amplitude,
                          kappa_R_max=args.kappa_R_max, size=args.size, degree=args.degree,
                          layer_elements=args.layer_elements, method=args.method,
                          damping=args.damping, step_tol=args.step_tol, settle=args.settle,
                          t_max=args.t_max)
    result = snap.run(cfg, args.output, render=not args.no_render)
    st, ld, ev = result["start"], result["landing"], result["axisymmetric_everted"]

    def human() -> None:
        print(f"{shape.kind} h/R = {args.h_over_r}, nu = {args.nu}, model surface, "
              f"{result['dofs']} DOFs")
        for c in result["critical_points"]:
            print(f"  {c['kind']} at kappa R = {c['kappa_R']:.6f}, m = {c['mode_m']}")
        print(f"start: kappa R = {st['kappa_R']:.6f} ({st['kappa_R'] / st['kappa_fold_R'] - 1:.3g}"
              f" past the fold), unstable m = {[u['mode_m'] for u in st['unstable']]}")
        sym = "symmetric" if ld["symmetric"] else f"broken symmetry, m = {ld['mode_m']}"
        print(f"landing: {'stable' if ld['stable'] else 'UNSTABLE'}, {sym}, energy "
              f"{ld['energy']:.8g}, rim rotation {ld['rim_rotation_deg']:.1f} deg, "
              f"Psi3(pole)/h = {ld['psi3_pole_over_h']:.3f}")
        if result.get("dynamics"):
            d = result["dynamics"]
            t = "none" if d["snap_time"] is None else f"{d['snap_time']:.4g}"
            print(f"dynamics: damping {d['damping']:g}, {d['reason']} after {d['steps']} "
                  f"steps, snap time {t} R sqrt(rho/E), energy at rest "
                  f"{d['rest_energy']:.10g} (polished {ld['energy']:.10g})")
        if ev["energy"] is not None:
            print(f"axisymmetric everted state: energy {ev['energy']:.8g}, negative "
                  f"{ev['negative_count']}")

    common.emit(result, args, human)
    return 0
