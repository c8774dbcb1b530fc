"""``shells mesh``, ``shells info``, ``shells render`` (CLI layer; no library module imports it):
mesh a shape with gmsh, read a mesh and report it, render it to PNG.
"""

from __future__ import annotations

import argparse
import json
from typing import Any

from shells.cli import common
from shells.errors import InputError


def add_mesh(sub: Any) -> argparse.ArgumentParser:
    """Add ``shells mesh`` to ``sub`` (the CLI's subparsers); returns its parser."""
    m = sub.add_parser("mesh", help="mesh a sphere, cap, ellipsoidal cap, disk or torus with gmsh",
                       description="Mesh a shape with gmsh (second-order geometry, refined in the "
                       "rim boundary layer of width sqrt(R h)) and report area and rim errors.")
    m.add_argument("shape", metavar="SHAPE", nargs="?",
                   help="sphere, cap, ellipsoid, disk, torus or meridian")
    m.add_argument("--radius", type=common.length("radius", common.RADIUS_RANGE[0]), default=1.0,
                   help="R (sphere, cap), r1 = r2 (ellipsoid), disk radius (default 1)")
    m.add_argument("--theta-deg", type=float, default=None,
                   help="half opening angle, pole to rim, in degrees (0, 180]")
    m.add_argument("--r3", type=common.length("r3", None), default=None,
                   help="ellipsoid semi-axis along z (default 1.5 R)")
    common.add_ring_arg(m)
    m.add_argument("--meridian", default=None, metavar="FILE",
                   help="with SHAPE meridian: a shell of revolution, its meridian a table of "
                   "rows 'r z' from the pole to the rim (or the other pole)")
    m.add_argument("--h-over-r", type=common.positive_float("h/R"), default=None,
                   help="thickness h/R: refines the rim layer of width sqrt(R h)")
    common.add_mesh_size_args(m, 0.1, "bulk element size relative to R (default 0.1)")
    m.add_argument("--order", type=int, default=2, choices=(1, 2), help="geometric order")
    m.add_argument("--sectors", type=int, default=8,
                   help="mesh invariant under rotations by 360/K degrees about the axis: K "
                        "congruent sectors (a multiple of 4; 1: one piece; default 8)")
    m.add_argument("--spec", default=None, help="read the parameters from a JSON file (meshes/)")
    m.add_argument("-o", "--output", default=None, help="write a gmsh .msh file (+ .msh.json)")
    m.add_argument("--png", default=None, help="render the mesh to a PNG")
    common.add_json(m)
    m.set_defaults(func=_cmd_mesh)
    return m


def _add_reader(sub: Any, name: str, help_: str, func: Any, png: bool
                ) -> argparse.ArgumentParser:
    """A subcommand that reads one .msh file (``png``: and writes a PNG, ``-o``)."""
    p = sub.add_parser(name, help=help_)
    p.add_argument("mesh", help="gmsh .msh file")
    if png:
        p.add_argument("-o", "--output", required=True, help="PNG file")
    common.add_json(p)
    p.set_defaults(func=func)
    return p


def add_info(sub: Any) -> argparse.ArgumentParser:
    """Add ``shells info`` to ``sub`` (the CLI's subparsers); returns its parser."""
    return _add_reader(sub, "info", "read a .msh file and report its size, area, rim",
                       _cmd_info, png=False)


def add_render(sub: Any) -> argparse.ArgumentParser:
    """Add ``shells render`` to ``sub`` (the CLI's subparsers); returns its parser."""
    return _add_reader(sub, "render", "render a .msh surface to PNG (off-screen)", _cmd_render,
                       png=True)


def _cmd_mesh(args: argparse.Namespace) -> int:
    from mpi4py import MPI

    from shells.surface.mesh import MeshSpec, check_mesh_size, generate, load_mesh

    if args.spec is not None:
        spec = _load_spec(args.spec)
    else:
        if args.shape is None:
            raise InputError("shells mesh: give a SHAPE or --spec FILE")
        shape = common.shape_from_args(args)
        h = None if args.h_over_r is None else args.h_over_r * shape.characteristic_size()
        spec = MeshSpec(shape, h=h, size=args.size, layer_elements=args.layer_elements,
                        order=args.order, sectors=args.sectors)
    if args.output is not None and not str(args.output).endswith(".msh"):
        raise InputError(f"-o must name a gmsh .msh file, got {args.output!r}")
    check_mesh_size(spec)  # before the common.log line: a refused mesh is one line on stderr
    common.log.info("meshing %s ...", spec.shape.describe())
    sm = generate(spec, MPI.COMM_WORLD, msh_path=args.output)
    if args.output is not None:
        sm = load_mesh(args.output, MPI.COMM_WORLD)  # prove the file reads back
    summary = sm.summary()
    summary["file"] = args.output
    if args.png:
        from shells.analyses.render import render_mesh

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

    common.emit(summary, args, human)
    return 0


def _load_spec(path: str):
    from pathlib import Path

    from shells.surface.mesh import MeshSpec

    p = Path(path)
    if not p.is_file():
        raise InputError(f"mesh parameter file not found: {path!r}")
    try:
        d = json.loads(p.read_text())
        if not isinstance(d, dict) or not isinstance(d.get("spec", d), dict):
            raise TypeError("not a JSON object")
        spec = MeshSpec.from_description(d.get("spec", d))
        for name in ("radius", "r3", "ring"):  # the ranges of --radius, --r3 and --ring
            if hasattr(spec.shape, name):
                lo = common.RADIUS_RANGE[0] if name == "radius" else None
                try:
                    common.length(name, lo)(repr(getattr(spec.shape, name)))
                except argparse.ArgumentTypeError as e:
                    raise InputError(str(e)) from None
        return spec
    except InputError as e:
        raise InputError(f"{path!r}: {e}") from None
    except (ValueError, KeyError, TypeError, AttributeError, OSError) as e:
        # ValueError: bad JSON, not UTF-8, a value that is not a number
        raise InputError(f"{path!r} is not a valid mesh parameter file: {e}") from None


def _cmd_info(args: argparse.Namespace) -> int:
    from mpi4py import MPI

    from shells.surface.mesh import load_mesh

    sm = load_mesh(args.mesh, MPI.COMM_WORLD)
    summary = sm.summary()
    summary["file"] = args.mesh

    def human() -> None:
        for k, v in summary.items():
            print(f"{k:18s} {v}")

    common.emit(summary, args, human)
    return 0


def _cmd_render(args: argparse.Namespace) -> int:
    from mpi4py import MPI

    from shells.analyses.render import render_mesh
    from shells.surface.mesh import load_mesh

    sm = load_mesh(args.mesh, MPI.COMM_WORLD)
    render_mesh(sm, args.output)
    common.emit({"png": args.output}, args, lambda: print(f"wrote {args.output}"))
    return 0
