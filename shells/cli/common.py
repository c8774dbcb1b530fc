"""What the subcommands share (CLI layer; no library module imports it): the parser class, logging
on rank 0, ``emit``, argument types, the shape and physics arguments, and the checks of ranges
and paths that run before any work.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import sys
from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext
from typing import Any

from shells.cli import paths
from shells.errors import InputError, on_rank_zero
from shells.files import hold_output_folder, json_default
from shells.parameters import check_h_over_r, check_nu

log = logging.getLogger("shells")


class Parser(argparse.ArgumentParser):
    """ArgumentParser whose usage errors are a single line on stderr (exit 2)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise InputError(f"{self.prog}: {message} (see {self.prog} --help)")


def rank() -> int:
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


def setup_logging(verbose: bool) -> None:
    """Progress and logs go to stderr on rank 0 only."""
    handler: logging.Handler = _StderrHandler()
    if rank() != 0:
        handler = logging.NullHandler()
    logging.basicConfig(format="%(message)s", handlers=[handler], force=True)
    log.setLevel(logging.DEBUG if verbose else logging.INFO)


def emit(result: dict[str, Any], args: argparse.Namespace, human: Callable[[], None]) -> None:
    """Print a result on rank 0: the human summary, then (with --json) the JSON last line."""
    if rank() != 0:
        return
    full = with_units(with_bilayer(result, args), args)
    if getattr(args, "plot", None) or getattr(args, "csv", None):
        from shells.api.results import Result

        res = Result(args.command.replace("-", "_"), full)
        if args.plot:
            res.plot(args.plot)
        if args.csv:
            res.to_csv(args.csv)
    if not getattr(args, "json", False):
        human()
        b = full.get("bilayer")
        if b is not None:
            at = b.get("mismatch_at_critical")
            print(f"bilayer: h = {b['thickness']:.4g}, natural curvature kappa R = "
                  f"{b['kappa_R']:.6g} at mismatch {b['mismatch']:g}"
                  + ("" if at is None else f"; the first critical point at mismatch {at:.6g}"))
    else:
        print(json.dumps(full, default=json_default), flush=True)


def add_outputs(p: argparse.ArgumentParser, func: Callable[[argparse.Namespace], int]
                ) -> argparse.ArgumentParser:
    """--plot, --csv and --json on an analysis's parser, ``func`` its command; returns ``p``."""
    add_table_args(p)
    add_json(p)
    p.set_defaults(func=func)
    return p


def shape_and_field(args: argparse.Namespace) -> tuple[Any, Any]:
    """The shape of the arguments and its natural-curvature field (``--kappa-field``, checked
    for the model)."""
    shape = shape_from_args(args)
    return shape, field_from_args(args, shape, args.model)


#: why each model is the default where it is, for the human output's first line
_DEFAULT_MODEL_WHY = {
    "surface": "the default of this command (any state, in minutes; --model axisym: the 1D "
               "model of shells of revolution, every Fourier mode, in seconds)",
    "axisym": "the default of this command (rotational symmetry of the branch enforced, in "
              "seconds; --model surface: the 2D model, any state)",
}


def model_words(args: argparse.Namespace) -> str:
    """``model M``, and why where M is the subcommand's default (not given with --model)."""
    if getattr(args, "model_given", True):
        return f"model {args.model}"
    return f"model {args.model}: {_DEFAULT_MODEL_WHY[args.model]}"


def add_degree_arg(p: argparse.ArgumentParser) -> None:
    """--degree: the surface model's polynomial degree (None: its default)."""
    p.add_argument("--degree", type=int, choices=(2, 3), default=None,
                   help="surface model: polynomial degree, full quadrature 2 x degree (default "
                   "2; closed spheres, caps deeper than thetabar = 3, ellipsoids and any "
                   "--kappa-field or --anisotropy 3: P2 locks there, docs/model.md)")


def add_table_args(p: argparse.ArgumentParser) -> None:
    """--plot FILE.png and --csv FILE.csv: the run's figure and table."""
    p.add_argument("--plot", default=None, metavar="FILE.png",
                   help="a figure of the result (a branch's Psi3/h against kappa R, stable and "
                   "unstable parts, critical points marked)")
    p.add_argument("--csv", default=None, metavar="FILE.csv",
                   help="the result's table (its points, or its critical points) as CSV")


# --------------------------------------------------------------------------------------------
# argument types and shared arguments
# --------------------------------------------------------------------------------------------
def _number_type(name: str, zero: bool) -> Callable[[str], float]:
    """An argparse type: a finite number > 0 (≥ 0 with ``zero``), the message naming
    ``name``."""
    def conv(text: str) -> float:
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a number, got {text!r}") from None
        if not (math.isfinite(v) and (v >= 0 if zero else v > 0)):
            raise argparse.ArgumentTypeError(
                f"{name} must be {'non-negative' if zero else 'positive'}, got {text}")
        return v

    return conv


def nonnegative_float(name: str) -> Callable[[str], float]:
    """An argparse type: a finite number ≥ 0 (the message names ``name``)."""
    return _number_type(name, zero=True)


def positive_float(name: str) -> Callable[[str], float]:
    """An argparse type: a finite number > 0 (the message names ``name``)."""
    return _number_type(name, zero=False)


#: Accepted --radius (and --r3 up to the upper bound). Every result is dimensionless (kappa R,
#: kappa h, h/R): the radius only sets the unit. The mesher's test that drops a cap's flat base
#: (height < 1e-6 R, shells.surface.mesh) fails against OCC's absolute bounding-box slack (~2e-7)
#: below R = 0.25, and OCC fails on huge radii; the range keeps a margin from both
#: (docs/design-notes.md, "Meshes").
RADIUS_RANGE = (0.5, 1.0e6)


class SILength(float):
    """A length given with units on the command line (``25mm``), in metres."""


def length(name: str, lo: float | None) -> Callable[[str], float]:
    """A length: a plain number in [lo, RADIUS_RANGE[1]] (lo None: any positive value), the
    unit of the dimensionless results, or a length with units (``25mm``, ``0.025 m``), any
    positive value, kept as an ``SILength`` in metres."""
    hi = RADIUS_RANGE[1]

    def conv(text: str) -> float:
        try:
            float(text)
            with_units = False
        except ValueError:
            with_units = True
        if with_units:
            from shells.units import length as si_length

            try:
                si = si_length(text, f"--{name}")
            except InputError as e:
                raise argparse.ArgumentTypeError(str(e)) from None
            if not si > 0:
                raise argparse.ArgumentTypeError(f"--{name} must be positive, got {text}")
            return SILength(si)
        v = positive_float(name)(text)
        if v > hi or (lo is not None and v < lo):
            rng = f"[{lo:g}, {hi:g}]" if lo is not None else f"(0, {hi:g}]"
            raise argparse.ArgumentTypeError(f"{name} must lie in {rng} (results are "
                                             f"dimensionless: R sets the unit), got {text}; a "
                                             f"length with units is any size (25mm)")
        return v

    return conv


def add_json(p: argparse.ArgumentParser) -> None:
    p.add_argument("--json", action="store_true", help="print a JSON object as the last line")


def add_mesh_size_args(p: argparse.ArgumentParser, size_default: float | None,
                       size_help: str) -> None:
    """``--size`` (bulk element size / R) and ``--layer-elements`` (across sqrt(R h))."""
    p.add_argument("--size", type=positive_float("size"), default=size_default, help=size_help)
    p.add_argument("--layer-elements", type=positive_float("layer-elements"), default=4.0,
                   help="elements across sqrt(R h) at the rim (default 4)")


def add_shape_args(p: argparse.ArgumentParser, positional: bool,
                   user_mesh: bool = False) -> None:
    """The shape's arguments; ``user_mesh``: also ``--mesh FILE`` (then --shape is optional,
    ``shape_from_args`` checks that exactly one of them is given)."""
    from shells.geometry.catalogue import SHAPES

    if positional:
        p.add_argument("shape", metavar="SHAPE", help=f"one of: {', '.join(SHAPES)}")
    else:
        p.add_argument("--shape", required=not user_mesh, default=None,
                       help=f"one of: {', '.join(SHAPES)}, meridian (with --meridian FILE)")
    if user_mesh:
        p.add_argument("--mesh", default=None, metavar="FILE",
                       help="instead of --shape: a gmsh .msh surface mesh (second order "
                       "advised), made by `shells mesh` or elsewhere; one made elsewhere must be "
                       "a surface of revolution about z with a node at its pole, or a torus about "
                       "z centred on z = 0 (its meridian is recovered from the nodes; the surface "
                       "model runs on the mesh as given)")
    p.add_argument("--radius", type=length("radius", RADIUS_RANGE[0]), default=1.0,
                   help="sphere/cap radius R, ellipsoid semi-axes r1 = r2, disk radius, torus "
                   "tube radius (default 1)")
    p.add_argument("--theta-deg", type=float, default=None,
                   help="half opening angle theta from the pole to the rim, degrees (0, 180]")
    p.add_argument("--r3", type=length("r3", None), default=None,
                   help="ellipsoid semi-axis along the symmetry axis (default 1.5 R)")
    add_ring_arg(p)
    p.add_argument("--meridian", default=None, metavar="FILE",
                   help="with --shape meridian: any shell of revolution about z, its meridian "
                   "a table of rows 'r z' (spaces or commas) from the pole (r = 0) to the rim, "
                   "or to the other pole (closed); a cubic spline through them. Both models take "
                   "it (the surface model on a cap's or sphere's mesh moved onto it); h/R is "
                   "over the pole's radius of curvature")


def add_ring_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--ring", type=length("ring", None), default=None,
                   help="torus: distance from the axis to the tube's centre circle, above the "
                   "tube's radius --radius (default 3 R)")


def shape_from_args(args: argparse.Namespace):
    """The shape of the arguments; with ``--mesh``, the mesh file's (its mesh is built by the
    run)."""
    from shells.geometry.catalogue import make_shape
    from shells.geometry.meridian import MeridianTable

    if getattr(args, "mesh", None) is not None:
        if args.shape is not None or getattr(args, "meridian", None) is not None:
            raise InputError("--mesh gives the shape: drop --shape and --meridian")
        from mpi4py import MPI

        from shells.surface.mesh import read_mesh_shape

        return read_mesh_shape(args.mesh, MPI.COMM_WORLD)
    if args.shape is None:
        raise InputError("give the shape: --shape (or --mesh FILE)")
    path = getattr(args, "meridian", None)
    if (args.shape == "meridian") != (path is not None):
        raise InputError("--shape meridian and --meridian FILE go together")
    if path is not None:
        return MeridianTable.from_file(path)
    theta = None
    if args.theta_deg is not None:
        if not math.isfinite(args.theta_deg) or not 0 < args.theta_deg <= 180:
            raise InputError(f"--theta-deg must lie in (0, 180], got {args.theta_deg:g}")
        theta = math.radians(args.theta_deg)
    ring = getattr(args, "ring", None)
    if ring is not None and args.shape != "torus":
        raise InputError("--ring is the torus's: drop it or use --shape torus")
    return make_shape(args.shape, radius=args.radius, theta=theta, r3=args.r3, ring=ring)


def add_shell_args(p: argparse.ArgumentParser) -> None:
    """--h-over-r or --thickness (one of them required) and --nu."""
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--h-over-r", type=positive_float("h/R"), default=None,
                   help="thickness over R (disk: over its radius)")
    g.add_argument("--thickness", type=length("thickness", None), default=None,
                   help="instead of --h-over-r: the thickness, a length with units (1mm) with "
                   "--radius given with units, or a number in the unit of --radius")
    g.add_argument("--bilayer", default=None, metavar="H1,H2,E1,E2,EPS",
                   help="instead of --h-over-r: a bilayer, its outer and inner layers' "
                   "thicknesses (lengths with units with --radius given with units, else "
                   "numbers in its unit), Young's moduli (any one unit) and the mismatch strain "
                   "EPS by which the outer layer expands (Timoshenko's formula; both layers take "
                   "--nu). The thickness is the layers' sum; the kappa range, unless given, "
                   "ends at the bilayer's natural curvature (its sign: the direction)")
    p.add_argument("--nu", type=float, default=0.5, help="Poisson ratio (default 0.5)")


def add_physics_args(p: argparse.ArgumentParser, model_default: str, model_help: str) -> None:
    """The arguments of the analyses that start on the fundamental branch (critical,
    postbuckle): --h-over-r, --nu, --direction and --model (default ``model_default``, listed
    first among the choices)."""
    add_shell_args(p)
    p.add_argument("--direction", default="up", choices=("up", "down"),
                   help="up: kappa > 0 (default), down: kappa < 0")
    other = "axisym" if model_default == "surface" else "surface"
    p.add_argument("--model", default=model_default, choices=(model_default, other),
                   help=model_help)


def add_field_args(p: argparse.ArgumentParser) -> None:
    """--kappa-field EXPR and --anisotropy F1 F2: the stimulus K of b̄ = b° + κ K."""
    p.add_argument("--kappa-field", default=None, metavar="EXPR",
                   help="natural curvature f(x) kappa instead of a uniform kappa: an expression "
                   "of the reference position x, y, z, r (distance from the axis), phi, theta "
                   "(angle from the pole), constants pi and R, with + - * / **, < <= > >=, "
                   "and/or, sin cos tan exp log sqrt tanh sinh cosh atan asin acos abs atan2 min "
                   "max, where(c, a, b) and step(s, w) = (1 + tanh(s/w))/2; e.g. "
                   "'step(0.3 - theta, 0.02)' (a smoothed polar disk of the cap); or a table "
                   "file (.csv .txt .dat .tsv) of rows 'theta f' (piecewise linear in theta) "
                   "or 'x y z f' (values at points of the surface); default 1")
    p.add_argument("--anisotropy", type=float, nargs=2, default=None, metavar=("F1", "F2"),
                   help="anisotropic natural curvature f kappa (F1 e1 x e1 + F2 e2 x e2), e1 "
                   "along the meridian, e2 along the parallel (default 1 1: isotropic)")


def field_from_args(args: argparse.Namespace, shape: Any, model: str) -> Any:
    """The ``CurvatureField`` of --kappa-field/--anisotropy (the uniform one if neither is
    given), checked on ``shape`` (finite, not zero everywhere; axisymmetric for the 1D model)
    before any work."""
    from shells.geometry.stimulus import UNIFORM, CurvatureField, names_table

    expr, an = getattr(args, "kappa_field", None), getattr(args, "anisotropy", None)
    if expr is None and an is None:
        return UNIFORM
    an = (1.0, 1.0) if an is None else tuple(an)
    if expr is not None and names_table(expr):
        fld = CurvatureField.from_file(expr.strip(), an)
    else:
        fld = CurvatureField("1" if expr is None else expr, an)
    fld.check_on(shape, axisymmetric=model == "axisym")
    return fld


def add_kappa_range(p: argparse.ArgumentParser, help_h: str = "end of the range, |kappa h|",
                    help_r: str = "end of the range, |kappa R|") -> None:
    """--kappa-h-max | --kappa-r-max | --kappa-max: the end of the range (--kappa-max a
    curvature with units, for a --radius with units)."""
    g = p.add_mutually_exclusive_group()
    g.add_argument("--kappa-h-max", type=float, default=None, help=help_h)
    g.add_argument("--kappa-r-max", type=float, default=None, help=help_r)
    g.add_argument("--kappa-max", default=None, metavar="K",
                   help="the same as a curvature with units (40/m), with --radius in units")


# --------------------------------------------------------------------------------------------
# argument validation before any work: ranges common to the subcommands, every path argument
# --------------------------------------------------------------------------------------------
#: Path arguments per subcommand: (attribute, label, kind, value used when the attribute is
#: None). Kinds: "in" (a file read), "msh"/"png" (a file written, with that suffix), "dir" (an
#: output folder), "shared" (only: shared with the host), "field" (--kappa-field: "in" if it
#: names a table file). Every one is checked by
#: ``shells.cli.paths`` before the subcommand starts; a subcommand not listed here has its -o
#: (``output``), if any, checked as "shared".
PATH_ARGS: dict[str, list[tuple[str, str, str, str | None]]] = {
    "mesh": [("spec", "--spec", "in", None), ("output", "-o", "msh", None),
             ("png", "--png", "png", None), ("meridian", "--meridian", "in", None)],
    "info": [("mesh", "mesh file", "in", None)],
    "render": [("mesh", "mesh file", "in", None), ("output", "-o", "png", None)],
    "branch": [("plot", "--plot", "png", None), ("csv", "--csv", "csv", None),
               ("output", "-o", "dir", "results/branch"),
               ("kappa_field", "--kappa-field", "field", None),
               ("meridian", "--meridian", "in", None), ("mesh", "--mesh", "in", None)],
    "plot": [("folder", "run folder", "shared", None), ("output", "-o", "png", None)],
    "critical": [("plot", "--plot", "png", None), ("csv", "--csv", "csv", None),
                 ("output", "-o", "dir", None), ("kappa_field", "--kappa-field", "field", None),
                 ("meridian", "--meridian", "in", None), ("mesh", "--mesh", "in", None)],
    "phase-diagram": [("output", "-o", "dir", None)],
    "postbuckle": [("plot", "--plot", "png", None), ("csv", "--csv", "csv", None),
                   ("output", "-o", "dir", None),
                   ("kappa_field", "--kappa-field", "field", None),
                   ("meridian", "--meridian", "in", None), ("mesh", "--mesh", "in", None)],
    "knockdown": [("output", "-o", "dir", None)],
    "snap": [("output", "-o", "dir", None), ("meridian", "--meridian", "in", None)],
    "frequencies": [("meridian", "--meridian", "in", None), ("figure", "--plot", "png", None)],
}


def apply_units(args: argparse.Namespace) -> None:
    """Lengths and curvatures given with units, turned into the dimensionless arguments: a
    --radius with units becomes R = 1 (the computation is the dimensionless one) with
    ``args.radius_m`` its length in metres; --r3 and --ring with units become ratios to it;
    --thickness becomes --h-over-r; --kappa-max (1/m) becomes --kappa-r-max."""
    radius = getattr(args, "radius", None)
    args.radius_m = float(radius) if isinstance(radius, SILength) else None
    if args.radius_m is not None and args.command in ("mesh", "render", "info"):
        raise InputError("a mesh is written in the shape's own numbers: give --radius as a "
                         "number (the runs take lengths with units)")
    if args.radius_m is not None:
        for opt in ("r3", "ring"):
            v = getattr(args, opt, None)
            if v is not None and not isinstance(v, SILength):
                raise InputError(f"--{opt} needs units when --radius has them (e.g. 30mm)")
            if v is not None:
                setattr(args, opt, float(v) / args.radius_m)
        args.radius = 1.0
    else:
        for opt in ("r3", "ring", "thickness"):
            if isinstance(getattr(args, opt, None), SILength):
                raise InputError(f"--{opt} with units needs --radius with units (e.g. "
                                 "--radius 25mm)")
    apply_bilayer(args)
    thickness = getattr(args, "thickness", None)
    if thickness is not None:
        if getattr(args, "mesh", None) is not None or getattr(args, "shape", None) == "meridian":
            raise InputError("--thickness needs the shape's radius: give --h-over-r for a "
                             "meridian table or a mesh")
        if args.radius_m is not None and not isinstance(thickness, SILength):
            raise InputError("--thickness needs units when --radius has them (e.g. 1mm)")
        scale = args.radius_m if isinstance(thickness, SILength) else args.radius
        args.h_over_r = float(thickness) / scale
    k = getattr(args, "kappa_max", None)
    if k is not None:
        from shells.units import curvature

        try:
            float(k)
            si = None  # a plain number: no units
        except ValueError:
            si = curvature(k, "--kappa-max")
        if si is None or args.radius_m is None:
            raise InputError("--kappa-max is a curvature with units (e.g. 40/m) for a "
                             "--radius with units; otherwise give --kappa-r-max")
        args.kappa_r_max = si * args.radius_m


def apply_bilayer(args: argparse.Namespace) -> None:
    """--bilayer H1,H2,E1,E2,EPS: the layers' thickness becomes --thickness, their natural
    curvature ``args.bilayer_kappa_R`` (κR) the end of the κ range where none is given (and
    its sign the direction); ``args.bilayer_record`` is what the output reports."""
    text = getattr(args, "bilayer", None)
    if text is None:
        return
    from shells.api.shell import bilayer

    parts = [p.strip() for p in text.split(",")]
    if len(parts) != 5 or not all(parts):
        raise InputError(f"--bilayer takes H1,H2,E1,E2,EPS (five values), got {text!r}")

    def value(p: str) -> Any:
        try:
            return float(p)
        except ValueError:
            return p  # a quantity with units, read by shells.bilayer

    try:
        eps = float(parts[4])
    except ValueError:
        raise InputError(f"--bilayer: the mismatch strain must be a number, got "
                         f"{parts[4]!r}") from None
    b = bilayer(h=(value(parts[0]), value(parts[1])), E=(value(parts[2]), value(parts[3])),
                mismatch=eps, nu=args.nu)
    with_units_h = not isinstance(value(parts[0]), float)
    if with_units_h and args.radius_m is None:
        raise InputError("--bilayer thicknesses with units need --radius with units (e.g. "
                         "--radius 25mm)")
    if not with_units_h and args.radius_m is not None:
        raise InputError("--bilayer thicknesses need units when --radius has them (e.g. 0.5mm)")
    scale = args.radius_m if with_units_h else args.radius
    args.h_over_r = b.thickness / scale
    args.bilayer_kappa_R = b.kappa * scale
    args.bilayer_record = {**b.describe(), "kappa_R": args.bilayer_kappa_R}
    if not math.isfinite(args.bilayer_kappa_R) or args.bilayer_kappa_R == 0:
        raise InputError("--bilayer: the layers give no natural curvature (a zero mismatch)")
    given = [getattr(args, k, None) for k in ("kappa_r_max", "kappa_h_max", "kappa_max")]
    if hasattr(args, "kappa_r_max") and all(v is None for v in given):
        if hasattr(args, "direction"):
            args.kappa_r_max = abs(args.bilayer_kappa_R)
            args.direction = "up" if args.bilayer_kappa_R > 0 else "down"
        else:
            args.kappa_r_max = args.bilayer_kappa_R


def with_bilayer(result: dict[str, Any], args: argparse.Namespace) -> dict[str, Any]:
    """The result with ``bilayer`` (the layers, their κ and κR) and, for a first critical
    point, the mismatch strain at which the bilayer reaches it (``mismatch_at_critical``: the
    natural curvature is linear in the mismatch) where --bilayer was given."""
    rec = getattr(args, "bilayer_record", None)
    if rec is None:
        return result
    rec = dict(rec)
    kr = result.get("kappa_R")
    if isinstance(kr, (int, float)):
        rec["mismatch_at_critical"] = rec["mismatch"] * kr / rec["kappa_R"]
    return {**result, "bilayer": rec}


def with_units(result: dict[str, Any], args: argparse.Namespace) -> dict[str, Any]:
    """The result with its lengths and curvatures in SI units added where the shell was given
    with units: ``R_m``, ``h_m``, and ``kappa_per_m`` beside every ``kappa_R``."""
    r = getattr(args, "radius_m", None)
    if r is None:
        return result

    def add(d: dict[str, Any]) -> dict[str, Any]:
        out = dict(d)
        if isinstance(d.get("kappa_R"), (int, float)):
            out["kappa_per_m"] = d["kappa_R"] / r
        for key in ("critical_points", "points"):
            if isinstance(d.get(key), list):
                out[key] = [add(x) if isinstance(x, dict) else x for x in d[key]]
        if isinstance(d.get("critical_point"), dict):
            out["critical_point"] = add(d["critical_point"])
        return out

    h = getattr(args, "h_over_r", None)
    return {**add(result), "R_m": r, **({"h_m": h * r} if isinstance(h, float) else {})}


def check_ranges(args: argparse.Namespace) -> None:
    """Ranges shared by several subcommands (nu, the kappa range, h/R; the phase diagram's
    smallest cap), before any work or any file is written."""
    from shells.geometry.shapes import THETA_MIN_DEG

    nu = getattr(args, "nu", None)
    if nu is not None:
        check_nu(nu, "--nu")
    apply_units(args)
    for opt in ("kappa_h_max", "kappa_r_max"):
        k = getattr(args, opt, None)
        if k is not None and not (math.isfinite(k) and k != 0):
            raise InputError(f"--{opt.replace('_', '-')} must be a finite nonzero number, "
                             f"got {k:g}")
    hs = getattr(args, "h_over_r", None)
    if hs is None:
        return
    for h in hs if isinstance(hs, list) else [hs]:
        check_h_over_r(h, "--h-over-r")
    rng = getattr(args, "thetabar_range", None)
    if args.command == "phase-diagram" and rng and all(math.isfinite(v) for v in rng):
        theta_deg = math.degrees(min(rng) * math.sqrt(min(hs)))
        if theta_deg < THETA_MIN_DEG:
            raise InputError(f"theta-bar {min(rng):g} at h/R = {min(hs):g} is a cap of theta = "
                             f"{theta_deg:.3g} deg, below the {THETA_MIN_DEG:g} deg minimum")


def hold_output(args: argparse.Namespace) -> AbstractContextManager[None]:
    """Hold the run's output folder, its "dir" entry in ``PATH_ARGS`` (collective).

    Returns:
        ``shells.files.hold_output_folder`` of that folder on all ranks, or a context that
        holds nothing if the subcommand has no output folder.
    """
    from mpi4py import MPI

    for attr, label, kind, default in PATH_ARGS.get(args.command, []):
        value = getattr(args, attr, None)
        value = default if value is None else value
        if kind == "dir" and value is not None:
            return hold_output_folder(value, MPI.COMM_WORLD, label)
    return nullcontext()


def check_paths(args: argparse.Namespace) -> None:
    """Every path argument of the subcommand (``PATH_ARGS``), checked on rank 0; the verdict is
    broadcast so that all ranks stop (or go on) together."""
    from mpi4py import MPI

    specs = PATH_ARGS.get(args.command, [("output", "-o", "shared", None)])

    def check() -> None:
        for attr, label, kind, default in specs:
            value = getattr(args, attr, None)
            value = default if value is None else value
            if value is None:
                continue
            if kind == "field":  # a table file, or an expression (nothing to check)
                from shells.geometry.stimulus import names_table

                if names_table(value):
                    paths.check_input_file(value.strip(), label)
            elif kind == "in":
                paths.check_input_file(value, label)
            elif kind == "shared":
                paths.check_shared(value, label)
            elif kind == "dir":
                paths.check_output_dir(value, label)
            else:
                paths.check_output_file(value, label, suffixes=(f".{kind}",))

    on_rank_zero(MPI.COMM_WORLD, check, "cannot check the paths")
