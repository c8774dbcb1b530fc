"""``shells postbuckle``: the command line of ``shells.postbuckle`` (CLI layer; the library never
imports it).

    shells postbuckle --shape S --h-over-r H [--nu NU] [--theta-deg T] [--direction up|down]
        [--model axisym|surface] [--at K] [--kappa-r-max X | --kappa-h-max X] [-o DIR]
        [--fields none|last|all] [--json]

Follows the fundamental branch, locates its K-th bifurcation, switches and follows the
bifurcated branch on both sides. JSON (last line with --json): ``critical_point`` (the keys of
an entry of ``shells critical``'s ``critical_points``), ``points`` (fundamental and bifurcated:
the keys of ``shells branch``'s points plus ``branch``, ``stable``, ``negative_count``,
``psi3_pole_over_h``, ``mode_amplitude``, and on bifurcated points ``side``, ``start``,
``subcritical``), ``sides`` (per side: points, how it ended, up/down), ``branch_file``, and the
shapes written. With -o, every point is appended to DIR/postbuckle.jsonl as computed; with
``--fields``, the 1D model writes each bifurcated state (``last``: the last one of each side) as
a 3D surface DIR/shapes/side{+1,-1}_NNN.vts (arrays ``displacement``, ``normal_displacement``)
and its meridian as CSV; the surface model writes VTX fields DIR/fields_side{+1,-1}.bp.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from shells.errors import InputError

__all__ = ["add_subcommand"]


def add_subcommand(sub: Any, positive: Any, add_shape_args: Any) -> argparse.ArgumentParser:
    p = sub.add_parser("postbuckle", help="follow the branch that bifurcates from the "
                       "fundamental one (post-buckling), both sides",
                       description="Follow the fundamental branch from kappa = 0, locate its "
                       "K-th bifurcation, switch onto the bifurcated branch along the critical "
                       "mode and follow it on both sides by pseudo-arclength, with the "
                       "stability at every point. The 1D model (axisym) follows axisymmetric "
                       "branches only (a closed sphere's buckling with rotational symmetry "
                       "enforced, as in the paper).")
    add_shape_args(p, positional=False)
    p.add_argument("--h-over-r", type=positive("h/R"), required=True,
                   help="thickness over R (disk: over its radius)")
    p.add_argument("--nu", type=float, default=0.5, help="Poisson ratio (default 0.5)")
    p.add_argument("--direction", default="up", choices=("up", "down"),
                   help="up: kappa > 0 (default), down: kappa < 0")
    p.add_argument("--model", default="axisym", choices=("axisym", "surface"),
                   help="axisym (1D, default) or surface (2D mesh)")
    p.add_argument("--at", type=int, default=1, help="the K-th bifurcation (default 1)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--kappa-h-max", type=float, default=None, help="end of the range, |kappa h|")
    g.add_argument("--kappa-r-max", type=float, default=None, help="end of the range, |kappa R|")
    p.add_argument("--kappa-min-ratio", type=float, default=0.5,
                   help="bifurcated branches end below this kappa/kappa_c (default 0.5)")
    p.add_argument("--max-points", type=int, default=60,
                   help="points per side of the bifurcated branch (default 60)")
    p.add_argument("--size", type=positive("size"), default=0.2,
                   help="surface model: bulk element size / R (default 0.2)")
    p.add_argument("--layer-elements", type=positive("layer-elements"), default=3.0,
                   help="surface model: elements across sqrt(R h) at the rim (default 3)")
    p.add_argument("--degree", type=int, choices=(2, 3), default=2,
                   help="surface model: polynomial degree (default 2)")
    p.add_argument("--fields", default="none", choices=("none", "last", "all"),
                   help="write the bifurcated states for ParaView (needs -o)")
    p.add_argument("-o", "--output", default=None,
                   help="directory: postbuckle.jsonl (points as computed) and shapes")
    p.add_argument("--json", action="store_true", help="print a JSON object as the last line")
    p.set_defaults(func=_cmd_postbuckle)
    return p


class _Shapes:
    """Writes the requested bifurcated states while the model holds them (``all``), or the
    last one of each side at the end (``last``): 1D, a revolved surface (.vts) and the meridian
    (.csv); 2D, VTX fields (one .bp per side)."""

    def __init__(self, out: Path | None, fields: str, model_kind: str, h: float) -> None:
        self.out, self.fields, self.kind, self.h = out, fields, model_kind, h
        self.files: list[str] = []
        self.last: dict[int, tuple[Any, Any, dict[str, Any]]] = {}
        self.writers: dict[int, Any] = {}

    def __call__(self, model: Any, rec: dict[str, Any]) -> None:
        if self.out is None or self.fields == "none" or rec["branch"] != "bifurcated":
            return
        if self.fields == "all":
            self._write(model, rec)
        else:
            from shells.problem import get_state

            self.last[rec["side"]] = (model, get_state(model), dict(rec))

    def _write(self, model: Any, rec: dict[str, Any]) -> None:
        from mpi4py import MPI

        side = rec["side"]
        if self.kind == "axisym":
            if MPI.COMM_WORLD.rank != 0:
                return
            from shells.revolve import revolve, write_profile_csv, write_vts

            prof = model.meridian_profile()
            d = self.out / "shapes"
            d.mkdir(parents=True, exist_ok=True)
            stem = d / f"side{side:+d}_{rec['index']:03d}"
            self.files.append(write_vts(revolve(prof), str(stem) + ".vts"))
            write_profile_csv(prof, str(stem) + ".csv", self.h)
            self.files.append(str(stem) + ".csv")
            return
        from shells.fields import FieldWriter

        if side not in self.writers:
            path = self.out / f"fields_side{side:+d}.bp"
            self.writers[side] = FieldWriter(model, path)
            self.files.append(str(path))
        self.writers[side].write(float(rec["index"]))

    def close(self) -> None:
        from shells.problem import set_state

        for model, state, rec in self.last.values():
            set_state(model, state)
            self._write(model, rec)
        for w in self.writers.values():
            w.close()


def _cmd_postbuckle(args: argparse.Namespace) -> int:
    from shells.cli import _shape_from_args, emit
    from shells.postbuckle import PostbuckleConfig, run_postbuckle

    shape = _shape_from_args(args)
    L = shape.characteristic_size()
    R_or_L = shape.R if math.isfinite(shape.R) else L
    h = args.h_over_r * L
    sign = 1.0 if args.direction == "up" else -1.0
    kappa_end = None
    if args.kappa_h_max is not None:
        kappa_end = sign * abs(args.kappa_h_max) / h
    elif args.kappa_r_max is not None:
        kappa_end = sign * abs(args.kappa_r_max) / R_or_L
    if kappa_end is not None and not (math.isfinite(kappa_end) and kappa_end != 0):
        raise InputError("the end of the kappa range must be a nonzero number")
    if args.fields != "none" and args.output is None:
        raise InputError("--fields needs an output directory (-o DIR)")
    cfg = PostbuckleConfig(shape=shape, h_over_r=args.h_over_r, nu=args.nu, model=args.model,
                           direction=args.direction, at=args.at, kappa_end=kappa_end,
                           kappa_min_ratio=args.kappa_min_ratio, max_points=args.max_points,
                           size=args.size, layer_elements=args.layer_elements,
                           degree=args.degree)
    out = Path(args.output) if args.output else None
    shapes = _Shapes(out, args.fields, args.model, h)
    try:
        recs = run_postbuckle(cfg, out, on_point=shapes)
    finally:
        shapes.close()
    cp = next(r["critical_point"] for r in recs if "critical_point" in r)
    points = [r for r in recs if "branch" in r]
    summary = recs[-1].get("summary", {})
    result = {"config": cfg.describe(), "critical_point": cp, "points": points,
              "sides": summary.get("sides"), "dofs": summary.get("dofs"),
              "branch_file": str(out / "postbuckle.jsonl") if out else None,
              "files": shapes.files}

    def human() -> None:
        print(f"{shape.kind} h/L = {args.h_over_r}, nu = {args.nu}, {args.model}: "
              f"{cp['kind']} at kappa R = {cp['kappa_R']:.6f} (kappa h = {cp['kappa_h']:.6f}), "
              f"m = {cp['mode_m']}, n = {cp['mode_n']}")
        print(f"{'branch':>11} {'side':>4} {'kappa R':>10} {'kappa/kc':>8} {'Psi3 pole/h':>11} "
              f"{'amplitude':>9} {'neg':>4}")
        for p in points:
            if p["branch"] == "fundamental" and p is not points[-1] and p["index"] % 10:
                continue
            print(f"{p['branch']:>11} {p.get('side', ''):>4} {p['kappa_R']:10.4f} "
                  f"{p['kappa'] / cp['kappa']:8.4f} {p['psi3_pole_over_h']:11.4f} "
                  f"{p['mode_amplitude']:9.3f} {p['negative_count']:4d}")
        for side, s in (summary.get("sides") or {}).items():
            print(f"side {int(side):+d}: {s['points']} points, starts {s['start']}, "
                  f"ended: {s['ended']}")

    emit(result, args, human)
    return 0
