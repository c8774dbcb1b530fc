"""Command-line interface: ``shells <subcommand>``; ``main(argv=None) -> int``.

Conventions for every analysis subcommand: human-readable output on rank 0 only; with ``--json``
the last line of stdout is one JSON object; bad input is one line on stderr and exit status 2,
never a traceback.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import sys
from collections.abc import Callable, Sequence
from typing import Any

from shells import __version__, paths
from shells.errors import InputError
from shells.store import json_default

__all__ = ["main"]

log = logging.getLogger("shells")


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose usage errors are a single line on stderr (exit 2)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise InputError(f"{self.prog}: {message} (see {self.prog} --help)")


def _rank() -> int:
    try:
        from mpi4py import MPI

        return MPI.COMM_WORLD.rank
    except ImportError:  # pragma: no cover - the stack always has mpi4py
        return 0


class _StderrHandler(logging.StreamHandler):  # type: ignore[type-arg]
    """Writes to whatever ``sys.stderr`` is at the time of the record, not at set-up (so a
    replaced and closed stderr, as in a test harness, is never written to)."""

    @property  # type: ignore[override]
    def stream(self) -> Any:
        return sys.stderr

    @stream.setter
    def stream(self, value: Any) -> None:
        pass


def _setup_logging(verbose: bool) -> None:
    """Progress and logs go to stderr on rank 0 only."""
    handler: logging.Handler = _StderrHandler()
    if _rank() != 0:
        handler = logging.NullHandler()
    logging.basicConfig(format="%(message)s", handlers=[handler], force=True)
    log.setLevel(logging.DEBUG if verbose else logging.INFO)


def emit(result: dict[str, Any], args: argparse.Namespace, human: Callable[[], None]) -> None:
    """Print a result on rank 0: the human summary, then (with --json) the JSON last line."""
    if _rank() != 0:
        return
    if not getattr(args, "json", False):
        human()
    else:
        print(json.dumps(result, default=json_default), flush=True)


def _positive_float(name: str) -> Callable[[str], float]:
    def conv(text: str) -> float:
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a number, got {text!r}") from None
        if not (math.isfinite(v) and v > 0):
            raise argparse.ArgumentTypeError(f"{name} must be positive, got {text}")
        return v

    return conv


#: Accepted --radius (and --r3 up to the upper bound). Every result is dimensionless (kappa R,
#: kappa h, h/R): the radius only sets the unit. The mesher's test that drops a cap's flat base
#: (height < 1e-6 R, shells.mesh) fails against OCC's absolute bounding-box slack (~2e-7) below
#: R = 0.25 (measured: R = 0.2 and 0.1 mesh a closed lens, twice the area, no rim; 0.25 and 0.3
#: are right), and R = 1e200 fails in OCC ("Could not fix wire"); 1e6 .. 1e20 mesh correctly.
RADIUS_RANGE = (0.5, 1.0e6)


def _length(name: str, lo: float | None) -> Callable[[str], float]:
    """A length in [lo, RADIUS_RANGE[1]] (lo None: any positive value)."""
    hi = RADIUS_RANGE[1]

    def conv(text: str) -> float:
        v = _positive_float(name)(text)
        if v > hi or (lo is not None and v < lo):
            rng = f"[{lo:g}, {hi:g}]" if lo is not None else f"(0, {hi:g}]"
            raise argparse.ArgumentTypeError(f"{name} must lie in {rng} (results are "
                                             f"dimensionless: R sets the unit), got {text}")
        return v

    return conv


def _add_shape_args(p: argparse.ArgumentParser, positional: bool) -> None:
    from shells.geometry import SHAPES

    if positional:
        p.add_argument("shape", metavar="SHAPE", help=f"one of: {', '.join(SHAPES)}")
    else:
        p.add_argument("--shape", required=True, help=f"one of: {', '.join(SHAPES)}")
    p.add_argument("--radius", type=_length("radius", RADIUS_RANGE[0]), default=1.0,
                   help="sphere/cap radius R, ellipsoid semi-axes r1 = r2, disk radius (default 1)")
    p.add_argument("--theta-deg", type=float, default=None,
                   help="half opening angle theta from the pole to the rim, degrees (0, 180]")
    p.add_argument("--r3", type=_length("r3", None), default=None,
                   help="ellipsoid semi-axis along the symmetry axis (default 1.5 R)")


def _shape_from_args(args: argparse.Namespace):
    from shells.geometry import make_shape

    theta = None
    if args.theta_deg is not None:
        if not math.isfinite(args.theta_deg) or not 0 < args.theta_deg <= 180:
            raise InputError(f"--theta-deg must lie in (0, 180], got {args.theta_deg:g}")
        theta = math.radians(args.theta_deg)
    return make_shape(args.shape, radius=args.radius, theta=theta, r3=args.r3)


# --------------------------------------------------------------------------------------------
# shells mesh
# --------------------------------------------------------------------------------------------
def _cmd_mesh(args: argparse.Namespace) -> int:
    from mpi4py import MPI

    from shells.mesh import MeshSpec, check_mesh_size, generate, load_mesh

    if args.spec is not None:
        spec = _load_spec(args.spec)
    else:
        if args.shape is None:
            raise InputError("shells mesh: give a SHAPE or --spec FILE")
        shape = _shape_from_args(args)
        h = None if args.h_over_r is None else args.h_over_r * shape.characteristic_size()
        spec = MeshSpec(shape, h=h, size=args.size, layer_elements=args.layer_elements,
                        order=args.order)
    if args.output is not None and not str(args.output).endswith(".msh"):
        raise InputError(f"-o must name a gmsh .msh file, got {args.output!r}")
    check_mesh_size(spec)  # before the log line: a refused mesh is one line on stderr
    log.info("meshing %s ...", spec.shape.describe())
    sm = generate(spec, MPI.COMM_WORLD, msh_path=args.output)
    if args.output is not None:
        sm = load_mesh(args.output, MPI.COMM_WORLD)  # prove the file reads back
    summary = sm.summary()
    summary["file"] = args.output
    if args.png:
        from shells.render import render_mesh

        render_mesh(sm, args.png)
        summary["png"] = args.png

    def human() -> None:
        print(f"{spec.shape.kind}: {summary['cells']} cells, {summary['nodes']} nodes "
              f"(order {spec.order})")
        print(f"  area   {summary['area']:.10g}  exact {summary['area_exact']:.10g}  "
              f"rel. error {summary['area_rel_error']:.2e}")
        if summary.get("rim_length_exact"):
            print(f"  rim    {summary['rim_length']:.10g}  exact {summary['rim_length_exact']:.10g}"
                  f"  rel. error {summary['rim_rel_error']:.2e}")
        if args.output:
            print(f"  wrote {args.output} (+ {args.output}.json)")
        if args.png:
            print(f"  wrote {args.png}")

    emit(summary, args, human)
    return 0


def _load_spec(path: str):
    from pathlib import Path

    from shells.mesh import MeshSpec

    p = Path(path)
    if not p.is_file():
        raise InputError(f"mesh parameter file not found: {path!r}")
    try:
        d = json.loads(p.read_text())
        if not isinstance(d, dict) or not isinstance(d.get("spec", d), dict):
            raise TypeError("not a JSON object")
        spec = MeshSpec.from_description(d.get("spec", d))
        for name in ("radius", "r3"):  # the ranges of --radius and --r3
            if hasattr(spec.shape, name):
                lo = RADIUS_RANGE[0] if name == "radius" else None
                try:
                    _length(name, lo)(repr(getattr(spec.shape, name)))
                except argparse.ArgumentTypeError as e:
                    raise InputError(str(e)) from None
        return spec
    except InputError as e:
        raise InputError(f"{path!r}: {e}") from None
    except (ValueError, KeyError, TypeError, AttributeError, OSError) as e:
        # ValueError: bad JSON, not UTF-8, a value that is not a number
        raise InputError(f"{path!r} is not a valid mesh parameter file: {e}") from None


# --------------------------------------------------------------------------------------------
# shells info / render
# --------------------------------------------------------------------------------------------
def _cmd_info(args: argparse.Namespace) -> int:
    from mpi4py import MPI

    from shells.mesh import load_mesh

    sm = load_mesh(args.mesh, MPI.COMM_WORLD)
    summary = sm.summary()
    summary["file"] = args.mesh

    def human() -> None:
        for k, v in summary.items():
            print(f"{k:18s} {v}")

    emit(summary, args, human)
    return 0


def _cmd_render(args: argparse.Namespace) -> int:
    from mpi4py import MPI

    from shells.mesh import load_mesh
    from shells.render import render_mesh

    sm = load_mesh(args.mesh, MPI.COMM_WORLD)
    render_mesh(sm, args.output)
    emit({"png": args.output}, args, lambda: print(f"wrote {args.output}"))
    return 0


# --------------------------------------------------------------------------------------------
# shells branch
# --------------------------------------------------------------------------------------------
def _cmd_branch(args: argparse.Namespace) -> int:
    from shells.branch import BranchConfig, run_branch
    from shells.continuation import ContinuationSettings

    if args.model not in ("surface", "axisym"):
        raise InputError(f"--model must be surface or axisym, got {args.model!r}")
    shape = _shape_from_args(args)
    if args.model == "axisym":
        return _branch_axisym(args, shape)
    L = shape.characteristic_size()
    h = args.h_over_r * L
    if (args.kappa_h_max is None) == (args.kappa_r_max is None):
        raise InputError("give exactly one of --kappa-h-max and --kappa-r-max")
    kappa_end = args.kappa_h_max / h if args.kappa_h_max is not None else args.kappa_r_max / (
        shape.R if math.isfinite(shape.R) else L)
    cont = ContinuationSettings(method=args.method, ds=args.ds, ds_max=max(args.ds, args.ds_max))
    cfg = BranchConfig(shape=shape, h_over_r=args.h_over_r, nu=args.nu, kappa_end=kappa_end,
                       size=args.size, layer_elements=args.layer_elements,
                       shear_penalty=args.shear_penalty, continuation=cont)
    outdir = args.output or "results/branch"
    from shells.branch import read_branch
    from shells.mesh import check_mesh_size

    check_mesh_size(cfg.mesh_spec())  # before run_branch creates its folder

    points = list(run_branch(cfg, outdir, fields=args.fields, resume=not args.restart))
    header, _ = read_branch(f"{outdir}/branch.jsonl")
    folds = [p for a, p in zip(points, points[1:], strict=False)
             if a["dkappa_ds"] * p["dkappa_ds"] < 0]
    result = {"config": cfg.describe(), "dofs": header.get("dofs"),
              "branch_file": f"{outdir}/branch.jsonl",
              "points": points, "folds": [{"kappa_R": f["kappa_R"], "kappa_h": f["kappa_h"],
                                           "index": f["index"]} for f in folds]}

    def human() -> None:
        print(f"{shape.kind} h/L = {args.h_over_r}, nu = {args.nu}: {len(points)} points "
              f"-> {outdir}/branch.jsonl")
        print(f"{'kappa R':>10} {'kappa h':>10} {'Psi3/h':>12} {'apex/h':>10} {'energy':>12} its")
        step = max(1, len(points) // 25)
        for p in points[::step] + ([points[-1]] if (len(points) - 1) % step else []):
            print(f"{p['kappa_R']:10.4f} {p['kappa_h']:10.4f} {p['psi3_over_h']:12.4e} "
                  f"{p['apex_uz_over_h']:10.4f} {p['energy']:12.5e} {p['newton_its']:3d}")
        for f in folds:
            print(f"fold (turning point in kappa) near kappa R = {f['kappa_R']:.4f}")

    emit(result, args, human)
    return 0


def _branch_axisym(args: argparse.Namespace, shape: Any) -> int:
    """``shells branch --model axisym``: the shell-of-revolution model, same JSON contract."""
    from pathlib import Path

    from shells import axisym

    L = shape.characteristic_size()
    R_or_L = shape.R if math.isfinite(shape.R) else L
    h = args.h_over_r * L
    if (args.kappa_h_max is None) == (args.kappa_r_max is None):
        raise InputError("give exactly one of --kappa-h-max and --kappa-r-max")
    kr = args.kappa_h_max * R_or_L / h if args.kappa_h_max is not None else args.kappa_r_max
    outdir = Path(args.output or "results/branch")
    points = []
    if _rank() == 0:
        outdir.mkdir(parents=True, exist_ok=True)
        (outdir / "branch.jsonl").write_text(json.dumps({"header": {
            "model": "axisym", "shape": shape.describe(), "h_over_r": args.h_over_r,
            "nu": args.nu, "kappa_R_end": kr}}) + "\n")
    for i, p in enumerate(axisym.branch(shape, args.h_over_r, args.nu,
                                        direction="up" if kr > 0 else "down",
                                        kappa_max=abs(kr))):
        rec = {"index": i, **p}
        points.append(rec)
        if _rank() == 0:
            with open(outdir / "branch.jsonl", "a") as f:
                f.write(json.dumps(rec, default=json_default) + "\n")
    folds = [p for a, p in zip(points, points[1:], strict=False)
             if a["dkappa_ds"] * p["dkappa_ds"] < 0]
    result = {"model": "axisym", "branch_file": str(outdir / "branch.jsonl"), "points": points,
              "folds": [{"kappa_R": f["kappa_R"], "kappa_h": f["kappa_h"], "index": f["index"]}
                        for f in folds]}

    def human() -> None:
        print(f"{shape.kind} h/L = {args.h_over_r}, nu = {args.nu}, axisym: {len(points)} "
              f"points -> {outdir}/branch.jsonl")
        print(f"{'kappa R':>10} {'kappa h':>10} {'Psi3/h':>12} {'energy':>12} its unstable m")
        step = max(1, len(points) // 25)
        for p in points[::step]:
            print(f"{p['kappa_R']:10.4f} {p['kappa_h']:10.4f} {p['psi3_over_h']:12.4e} "
                  f"{p['energy']:12.5e} {p['newton_its']:3d} {p.get('unstable_modes')}")
        for f in folds:
            print(f"fold (turning point in kappa) near kappa R = {f['kappa_R']:.4f}")

    emit(result, args, human)
    return 0


# --------------------------------------------------------------------------------------------
# shells critical
# --------------------------------------------------------------------------------------------
def _cmd_critical(args: argparse.Namespace) -> int:
    import time
    from pathlib import Path

    shape = _shape_from_args(args)
    L = shape.characteristic_size()
    h = args.h_over_r * L
    if not (0 < args.h_over_r < 1):
        raise InputError(f"h/R must lie in (0, 1), got {args.h_over_r:g}")
    if not (-1.0 < args.nu <= 0.5):
        raise InputError(f"nu must lie in (-1, 0.5], got {args.nu:g}")
    sign = 1.0 if args.direction == "up" else -1.0
    R_or_L = shape.R if math.isfinite(shape.R) else L
    if args.kappa_h_max is not None:
        kappa_end = sign * abs(args.kappa_h_max) / h
    elif args.kappa_r_max is not None:
        kappa_end = sign * abs(args.kappa_r_max) / R_or_L
    else:
        from shells.theory import default_kappa_range

        kappa_end = default_kappa_range(shape, args.h_over_r, args.nu, args.direction)
    theta_deg = math.degrees(shape.theta) if hasattr(shape, "theta") and not shape.closed \
        else None
    base = {"h_over_R": args.h_over_r, "nu": args.nu, "theta_deg": theta_deg,
            "model": args.model, "shape": shape.describe(), "direction": args.direction,
            "kappa_R_end": kappa_end * R_or_L, "kappa_h_end": kappa_end * h}
    if args.model == "axisym":
        try:
            from shells import axisym
        except ImportError as e:
            raise InputError("--model axisym is not available in this installation") from e
        user_range = args.kappa_h_max is not None or args.kappa_r_max is not None
        result = {**base, **axisym.critical(
            shape, args.h_over_r, args.nu, direction=args.direction,
            kappa_max=abs(kappa_end) * R_or_L if user_range else None)}
    elif args.model == "surface":
        result = {**base, **_critical_surface(args, shape, h, kappa_end, R_or_L)}
    else:
        raise InputError(f"--model must be surface or axisym, got {args.model!r}")
    if args.output and _rank() == 0:
        Path(args.output).mkdir(parents=True, exist_ok=True)
        (Path(args.output) / "critical.json").write_text(
            json.dumps(result, indent=1, default=json_default))
    _ = time

    def human() -> None:
        print(f"{shape.kind}, h/L = {args.h_over_r}, nu = {args.nu}, {args.direction}, "
              f"model {args.model}, {result.get('dofs')} DOFs")
        cps = result["critical_points"]
        if not cps:
            print(f"no critical point up to kappa R = {kappa_end * R_or_L:.4f} "
                  f"(kappa h = {kappa_end * h:.4f})")
        for c in cps:
            mode = (f"n = {c['mode_n']}" if c.get("mode_n") is not None
                    else f"m = {c.get('mode_m')}")
            print(f"{c['kind']:>12} at kappa R = {c['kappa_R']:.6f}, kappa h = "
                  f"{c['kappa_h']:.6f}  ({mode})")

    emit(result, args, human)
    return 0


def _critical_surface(args: argparse.Namespace, shape: Any, h: float, kappa_end: float,
                      R_or_L: float) -> dict[str, Any]:
    from pathlib import Path

    from mpi4py import MPI

    from shells.continuation import ContinuationSettings
    from shells.critical import CriticalSettings, follow
    from shells.mesh import MeshSpec, generate
    from shells.model import ModelParameters, ShellModel

    comm = MPI.COMM_WORLD
    from shells.model import default_discretisation

    args.degree, args.size = default_discretisation(shape, args.degree, args.size)
    sm = generate(MeshSpec(shape, h=h, size=args.size, layer_elements=args.layer_elements), comm)
    model = ShellModel(sm, ModelParameters(h=h, nu=args.nu, shear_penalty=args.shear_penalty,
                                           degree=args.degree,
                                           quadrature_degree=2 * args.degree))
    L = shape.characteristic_size()
    lam_end = abs(kappa_end) * L
    ds = args.ds if args.ds is not None else lam_end / 16
    ds_max = args.ds_max if args.ds_max is not None else max(ds, lam_end / 10)
    st = ContinuationSettings(ds=ds, ds_max=max(ds, ds_max), ds_min=1e-7 * lam_end,
                              ds_unit="kappa")
    crit = CriticalSettings(stop_at_first=args.first_only)
    log.info("critical: %s, %d DOFs, following kappa up to kappa R = %.4f", shape.describe(),
             model.num_dofs(), kappa_end * R_or_L)
    out = Path(args.output) if args.output else None
    bfile = None
    if out is not None and comm.rank == 0:
        out.mkdir(parents=True, exist_ok=True)
        bfile = out / "branch.jsonl"
        bfile.write_text("")
    cps = []
    found_points: list[Any] = []
    t0 = time_now()
    for p, res, found in follow(model, st, kappa_end, crit):
        rec = {"index": p.index, "kappa_R": p.kappa * R_or_L, "kappa_h": p.kappa * h,
               "negative_count": res.negative_count, "dkappa_ds": p.dkappa_ds,
               "newton_its": p.newton_its, **p.scalars}
        if bfile is not None:
            with open(bfile, "a") as f:
                f.write(json.dumps(rec) + "\n")
        log.info("  kappa R = %+.5f  kappa h = %+.5f  negative = %d  (%.0f s)", rec["kappa_R"],
                 rec["kappa_h"], res.negative_count, time_now() - t0)
        for c in found:
            found_points.append(c)
            d = c.as_dict()
            d.update(kappa_R=c.kappa * R_or_L, kappa_h=c.kappa * h,
                     kappa_R_bracket=[c.kappa_lo * R_or_L, c.kappa_hi * R_or_L])
            cps.append(d)
            log.info("  %s at kappa R = %.6f (kappa h = %.6f), m = %s, n = %s", c.kind,
                     d["kappa_R"], d["kappa_h"], c.mode_m, c.mode_n)
    first = cps[0] if cps else None
    if out is not None and found_points:
        from shells.fields import write_modes

        first_cp = found_points[0]  # its state and critical mode
        if first_cp.mode is not None:
            write_modes(model, first_cp.state, [first_cp.mode], out / "modes.bp")
            log.info("critical mode (ParaView, ADIOS2 VTX Reader): %s", out / "modes.bp")
    return {"kind": first["kind"] if first else "none",
            "kappa_R": first["kappa_R"] if first else None,
            "kappa_h": first["kappa_h"] if first else None,
            "mode_m": first["mode_m"] if first else None,
            "mode_n": first["mode_n"] if first else None,
            "dofs": model.num_dofs(), "critical_points": cps,
            "mesh": {"size": args.size, "layer_elements": args.layer_elements,
                     "degree": args.degree},
            "wall_time": time_now() - t0}


def time_now() -> float:
    import time

    return time.perf_counter()


def _build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="shells", description="Thin elastic shells with natural curvature "
                "(FEniCSx): meshes, branches, buckling and snap-through.")
    p.add_argument("--version", action="version", version=f"shells {__version__}")
    p.add_argument("-v", "--verbose", action="store_true", help="more log output (rank 0)")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    from shells.phase_diagram import add_subcommand as _add_phase_diagram

    m = sub.add_parser("mesh", help="mesh a sphere, cap, ellipsoidal cap or disk with gmsh",
                       description="Mesh a shape with gmsh (second-order geometry, refined in the "
                       "rim boundary layer of width sqrt(R h)) and report area and rim errors.")
    m.add_argument("shape", metavar="SHAPE", nargs="?", help="sphere, cap, ellipsoid or disk")
    m.add_argument("--radius", type=_length("radius", RADIUS_RANGE[0]), default=1.0,
                   help="R (sphere, cap), r1 = r2 (ellipsoid), disk radius (default 1)")
    m.add_argument("--theta-deg", type=float, default=None,
                   help="half opening angle, pole to rim, in degrees (0, 180]")
    m.add_argument("--r3", type=_length("r3", None), default=None,
                   help="ellipsoid semi-axis along z (default 1.5 R)")
    m.add_argument("--h-over-r", type=_positive_float("h/R"), default=None,
                   help="thickness h/R: refines the rim layer of width sqrt(R h)")
    m.add_argument("--size", type=_positive_float("size"), default=0.1,
                   help="bulk element size relative to R (default 0.1)")
    m.add_argument("--layer-elements", type=_positive_float("layer-elements"), default=4.0,
                   help="elements across sqrt(R h) at the rim (default 4)")
    m.add_argument("--order", type=int, default=2, choices=(1, 2), help="geometric order")
    m.add_argument("--spec", default=None, help="read the parameters from a JSON file (meshes/)")
    m.add_argument("-o", "--output", default=None, help="write a gmsh .msh file (+ .msh.json)")
    m.add_argument("--png", default=None, help="render the mesh to a PNG")
    m.add_argument("--json", action="store_true", help="print a JSON object as the last line")
    m.set_defaults(func=_cmd_mesh)

    i = sub.add_parser("info", help="read a .msh file and report its size, area, rim")
    i.add_argument("mesh", help="gmsh .msh file")
    i.add_argument("--json", action="store_true", help="print a JSON object as the last line")
    i.set_defaults(func=_cmd_info)

    b = sub.add_parser("branch", help="follow the equilibrium branch in kappa (continuation)",
                       description="Follow a shell from kappa = 0 to a final natural curvature "
                       "with pseudo-arclength (through folds) or natural continuation; each point "
                       "is appended to DIR/branch.jsonl as it is computed and a rerun resumes.")
    _add_shape_args(b, positional=False)
    b.add_argument("--h-over-r", type=_positive_float("h/R"), required=True,
                   help="thickness over R (disk: over its radius)")
    b.add_argument("--nu", type=float, default=0.5, help="Poisson ratio (default 0.5)")
    g = b.add_mutually_exclusive_group()
    g.add_argument("--kappa-h-max", type=float, default=None,
                   help="final kappa h (sign: direction)")
    g.add_argument("--kappa-r-max", type=float, default=None,
                   help="final kappa R (sign: direction)")
    b.add_argument("--model", default="surface", choices=("surface", "axisym"),
                   help="surface (2D mesh, default) or axisym (shell of revolution, 1D)")
    b.add_argument("--method", default="arclength", choices=("arclength", "natural"))
    b.add_argument("--ds", type=_positive_float("ds"), default=0.1, help="initial step")
    b.add_argument("--ds-max", type=_positive_float("ds-max"), default=1.0, help="largest step")
    b.add_argument("--size", type=_positive_float("size"), default=0.1,
                   help="bulk element size / R (default 0.1)")
    b.add_argument("--layer-elements", type=_positive_float("layer-elements"), default=4.0,
                   help="elements across sqrt(R h) at the rim (default 4)")
    b.add_argument("--shear-penalty", type=_positive_float("shear-penalty"), default=1.0e3,
                   help="Kirchhoff-Love penalty, times the Naghdi shear stiffness (default 1e3)")
    b.add_argument("--fields", default="none", choices=("none", "last", "all"),
                   help="write VTX fields (DIR/fields.bp) for ParaView")
    b.add_argument("--restart", action="store_true", help="ignore an existing branch file")
    b.add_argument("-o", "--output", default=None, help="output directory (results/branch)")
    b.add_argument("--json", action="store_true", help="print a JSON object as the last line")
    b.set_defaults(func=_cmd_branch)

    c = sub.add_parser("critical", help="first critical point (fold or bifurcation) along the "
                       "fundamental branch", description="Follow the fundamental branch from "
                       "kappa = 0 with the Hessian inertia at every point; locate every critical "
                       "point (to 1e-4 in kappa) up to the first fold or the end of the range, "
                       "classify it (fold/bifurcation) and its mode (n on spheres, m otherwise).")
    _add_shape_args(c, positional=False)
    c.add_argument("--h-over-r", type=_positive_float("h/R"), required=True,
                   help="thickness over R (disk: over its radius)")
    c.add_argument("--nu", type=float, default=0.5, help="Poisson ratio (default 0.5)")
    c.add_argument("--direction", default="up", choices=("up", "down"),
                   help="up: kappa > 0 (default), down: kappa < 0")
    c.add_argument("--model", default="surface", choices=("surface", "axisym"),
                   help="surface (2D mesh, default) or axisym (shell of revolution)")
    g = c.add_mutually_exclusive_group()
    g.add_argument("--kappa-h-max", type=float, default=None, help="end of the range, |kappa h|")
    g.add_argument("--kappa-r-max", type=float, default=None, help="end of the range, |kappa R|")
    c.add_argument("--first-only", action="store_true", help="stop at the first critical point")
    c.add_argument("--size", type=_positive_float("size"), default=None,
                   help="bulk element size / R (default 0.1; closed spheres 0.21)")
    c.add_argument("--layer-elements", type=_positive_float("layer-elements"), default=4.0,
                   help="elements across sqrt(R h) at the rim (default 4)")
    c.add_argument("--shear-penalty", type=_positive_float("shear-penalty"), default=1.0e3,
                   help="Kirchhoff-Love penalty, times the Naghdi shear stiffness (default 1e3)")
    c.add_argument("--degree", type=int, choices=(2, 3), default=None,
                   help="surface model: polynomial degree, full quadrature 2 x degree (default "
                   "2; closed spheres 3: P2 locks there, docs/model.md)")
    c.add_argument("--ds", type=_positive_float("ds"), default=None,
                   help="initial step, in kappa L (default: range/16)")
    c.add_argument("--ds-max", type=_positive_float("ds-max"), default=None,
                   help="largest step, in kappa L (default: range/10)")
    c.add_argument("-o", "--output", default=None,
                   help="directory for branch.jsonl (points as computed), critical.json and "
                   "the critical modes for ParaView (modes.bp)")
    c.add_argument("--json", action="store_true", help="print a JSON object as the last line")
    c.set_defaults(func=_cmd_critical)

    _add_phase_diagram(sub)
    from shells.postbuckle_cli import add_subcommand as _add_postbuckle

    _add_postbuckle(sub, _positive_float, _add_shape_args)

    r = sub.add_parser("render", help="render a .msh surface to PNG (off-screen)")
    r.add_argument("mesh", help="gmsh .msh file")
    r.add_argument("-o", "--output", required=True, help="PNG file")
    r.add_argument("--json", action="store_true", help="print a JSON object as the last line")
    r.set_defaults(func=_cmd_render)
    return p


# --------------------------------------------------------------------------------------------
# argument validation before any work: ranges common to the subcommands, every path argument
# --------------------------------------------------------------------------------------------
#: Largest h/R (h over the shape's length scale) accepted. The model is Koiter's thin-shell
#: energy (bending h^3/12, no transverse shear or thickness change), an expansion in h/R: at
#: h/R = 0.5 the faces lie at 0.75 R and 1.25 R and the expansion has no meaning any more. The
#: thickest shells in tests/ and benchmarks/ have h/R = 0.05.
H_OVER_R_MAX = 0.5

#: Path arguments per subcommand: (attribute, label, kind, value used when the attribute is
#: None). Kinds: "in" (a file read), "msh"/"png" (a file written, with that suffix), "dir" (an
#: output folder), "shared" (only: shared with the host). Every one is checked by
#: ``shells.paths`` before the subcommand starts; a subcommand not listed here has its -o
#: (``output``), if any, checked as "shared".
_PATH_ARGS: dict[str, list[tuple[str, str, str, str | None]]] = {
    "mesh": [("spec", "--spec", "in", None), ("output", "-o", "msh", None),
             ("png", "--png", "png", None)],
    "info": [("mesh", "mesh file", "in", None)],
    "render": [("mesh", "mesh file", "in", None), ("output", "-o", "png", None)],
    "branch": [("output", "-o", "dir", "results/branch")],
    "critical": [("output", "-o", "dir", None)],
    "phase-diagram": [("output", "-o", "dir", None)],
    "postbuckle": [("output", "-o", "dir", None)],
}


def _check_ranges(args: argparse.Namespace) -> None:
    """Ranges shared by several subcommands (nu, the kappa range, h/R; the phase diagram's
    smallest cap), before any work or any file is written."""
    from shells.geometry import THETA_MIN_DEG

    nu = getattr(args, "nu", None)
    if nu is not None and not (math.isfinite(nu) and -1.0 < nu <= 0.5):
        raise InputError(f"nu must lie in (-1, 0.5], got {nu:g}")
    for opt in ("kappa_h_max", "kappa_r_max"):
        k = getattr(args, opt, None)
        if k is not None and not (math.isfinite(k) and k != 0):
            raise InputError(f"--{opt.replace('_', '-')} must be a finite nonzero number, "
                             f"got {k:g}")
    hs = getattr(args, "h_over_r", None)
    if hs is None:
        return
    for h in hs if isinstance(hs, list) else [hs]:
        if not (math.isfinite(h) and 0 < h <= H_OVER_R_MAX):
            raise InputError(f"--h-over-r must lie in (0, {H_OVER_R_MAX:g}] (a thin shell), "
                             f"got {h:g}")
    rng = getattr(args, "thetabar_range", None)
    if args.command == "phase-diagram" and rng and all(math.isfinite(v) for v in rng):
        theta_deg = math.degrees(min(rng) * math.sqrt(min(hs)))
        if theta_deg < THETA_MIN_DEG:
            raise InputError(f"theta-bar {min(rng):g} at h/R = {min(hs):g} is a cap of theta = "
                             f"{theta_deg:.3g} deg, below the {THETA_MIN_DEG:g} deg minimum")


def _check_paths(args: argparse.Namespace) -> None:
    """Every path argument of the subcommand (``_PATH_ARGS``), checked on rank 0; the verdict is
    broadcast so that all ranks stop (or go on) together."""
    from mpi4py import MPI

    specs = _PATH_ARGS.get(args.command, [("output", "-o", "shared", None)])
    comm = MPI.COMM_WORLD
    err = None
    if comm.rank == 0:
        try:
            for attr, label, kind, default in specs:
                value = getattr(args, attr, None)
                value = default if value is None else value
                if value is None:
                    continue
                if kind == "in":
                    paths.check_input_file(value, label)
                elif kind == "shared":
                    paths.check_shared(value, label)
                elif kind == "dir":
                    paths.check_output_dir(value, label)
                else:
                    paths.check_output_file(value, label, suffixes=(f".{kind}",))
        except InputError as e:
            err = str(e)
        except Exception as e:  # never leave the other ranks waiting in the broadcast
            err = f"cannot check the paths: {type(e).__name__}: {e}"
    if comm.size > 1:
        err = comm.bcast(err, root=0)
    if err:
        raise InputError(err)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit status (0 ok, 2 bad input, 1 failure)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = _build_parser()
    signalled: list[int] = []

    def _terminate(signum: int, frame: Any) -> None:
        signalled.append(signum)
        raise KeyboardInterrupt

    import signal
    import threading

    if threading.current_thread() is threading.main_thread():
        old_term = signal.signal(signal.SIGTERM, _terminate)
    try:
        args = parser.parse_args(argv)
        _setup_logging(args.verbose)
        if args.command is None:
            if _rank() == 0:
                parser.print_help()
            return 0
        _check_ranges(args)
        _check_paths(args)
        return int(args.func(args) or 0)
    except InputError as e:
        msg = " ".join(str(e).splitlines())  # one line, whatever the message holds
        if _rank() == 0:
            print(msg if msg.startswith("shells") else f"shells: error: {msg}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        # every file a run writes is whole at any moment (appended lines, renamed checkpoints):
        # the same command resumes
        if _rank() == 0:
            name = "SIGTERM" if signalled else "SIGINT"
            print(f"shells: interrupted ({name}); rerun the same command to resume",
                  file=sys.stderr)
        return 143 if signalled else 130
    except Exception as e:  # noqa: BLE001 - a failure is one line, never a traceback
        import traceback

        from mpi4py import MPI

        comm = MPI.COMM_WORLD
        if "-v" in argv or "--verbose" in argv:
            traceback.print_exc()
        msg = " ".join(f"{type(e).__name__}: {e}".splitlines())
        where = f" (rank {comm.rank} of {comm.size})" if comm.size > 1 else ""
        print(f"shells: failed{where}: {msg}", file=sys.stderr, flush=True)
        if comm.size > 1:
            # the other ranks may wait in a collective for this one: end them all now
            comm.Abort(1)
        return 1
    finally:
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGTERM, old_term)
