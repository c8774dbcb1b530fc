"""Main env, serial: a short real branch run with fields, and the expected content of its fields.

    python3 tests/paraview/make_fields.py DIR

runs ``shells branch`` (the CLI, ``--fields last``) into DIR/run, then rebuilds the model from the
run's header and checkpoint (the state at the last point), interpolates the fields with the same
``FieldWriter`` and writes DIR/expected.json: the file to open, its time value, point and cell
counts, and for each array its component count and per-component and magnitude ranges — what
tests/paraview/pv_check.py, in ParaView, must find in the file. Likewise (``"shape"``) for a
1D post-buckled sphere written as a 3D surface (.vts) by ``shells postbuckle --fields last``, and
(``"postbuckled_cap"``) for the surface model's post-buckled 30° cap (the m = 2 branch, fields
written as ``shells postbuckle --model surface --fields last`` does).
"""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import numpy as np

RUN = ["branch", "--shape", "sphere", "--h-over-r", "0.05", "--nu", "0.5", "--kappa-h-max", "0.5",
       "--size", "0.2", "--degree", "2",
       "--fields", "last", "--restart"]
#: a closed sphere's axisymmetric post-buckling on the 1D model, the last state of each side
PB_RUN = ["postbuckle", "--shape", "sphere", "--h-over-r", "0.05", "--max-points", "4",
          "--fields", "last"]
ARRAYS = ("displacement", "director", "mean_curvature_change", "natural_curvature_mismatch",
          "bending_energy_density", "stretching_energy_density")


def main(out: Path) -> None:
    from mpi4py import MPI

    from shells.analyses.branch import BranchConfig, load_branch_checkpoint, read_branch
    from shells.surface.fields import FieldWriter
    from shells.surface.mesh import generate
    from shells.surface.model import ModelParameters, ShellModel

    comm = MPI.COMM_WORLD
    assert comm.size == 1, "run serially: the expected point count is that of one rank"
    run = out / "run"
    _shells(*RUN, "-o", str(run))

    header, points = read_branch(run / "branch.jsonl")
    last = points[-1]
    cfg = BranchConfig.from_description(header)
    model = ShellModel(generate(cfg.mesh_spec(), comm),
                       ModelParameters(h=cfg.h, nu=cfg.nu, shear_penalty=cfg.shear_penalty,
                                       degree=cfg.degree, quadrature_degree=2 * cfg.degree))
    # the run's last state, read back through the branch module's own checkpoint reader
    ck = load_branch_checkpoint(run, model)
    assert ck is not None, "no usable checkpoint"
    assert ck[1] == last["index"], "checkpoint is not the last point"
    model.kappa.value = ck[0]

    funcs = FieldWriter(model, None).update()  # the same interpolation, no file
    expected = {"file": str((run / "fields.bp").resolve()), "time": float(last["index"]),
                "kappa_h": last["kappa_h"], **_field_ranges(model, funcs)}
    expected["shape"] = postbuckled_shape(out)
    expected["postbuckled_cap"] = postbuckled_cap(out)
    (out / "expected.json").write_text(json.dumps(expected, indent=1) + "\n")
    print(f"make_fields: {expected['file']}: {expected['points']} points, {expected['cells']} "
          f"cells, kappa h = {last['kappa_h']:.3g}; expected ranges in {out / 'expected.json'}")


def _shells(*argv: str) -> None:
    """``shells ARGV`` run in this process (``shells.cli.main``: the command line's own code,
    without a second interpreter's start-up)."""
    from shells.cli import main

    rc = main(list(argv))
    if rc != 0:
        raise SystemExit(f"make_fields: shells {' '.join(argv)} exited with {rc}")


def _field_ranges(model, funcs) -> dict:
    """Point and cell counts of the fields' space and mesh, and each array's component count,
    per-component and magnitude ranges (this rank's owned values: run serially)."""
    mesh = model.shell.mesh
    arrays = {}
    for name in ARRAYS:
        f = funcs[name]
        bs = f.function_space.dofmap.index_map_bs
        n = f.function_space.dofmap.index_map.size_local
        a = f.x.array[: n * bs].reshape(n, bs)
        arrays[name] = {
            "components": bs,
            "ranges": [[float(a[:, i].min()), float(a[:, i].max())] for i in range(bs)],
            "magnitude": [float(np.linalg.norm(a, axis=1).min()),
                          float(np.linalg.norm(a, axis=1).max())],
        }
    V = funcs["displacement"].function_space
    return {"points": V.dofmap.index_map.size_local,
            "cells": mesh.topology.index_map(mesh.topology.dim).size_local, "arrays": arrays}


def postbuckled_cap(out: Path) -> dict:
    """The surface model's 30° cap (h/R = 0.04) past its m = 2 bifurcation, on the buckled
    branch (one side, two points, a coarse mesh): its fields written by the driver's own
    ``ShapeWriter`` (as ``shells postbuckle --model surface --fields last``), and what they
    must hold, interpolated again from the same state."""
    import math

    from shells.analyses.postbuckle import PostbuckleConfig, run_postbuckle
    from shells.analyses.writers import ShapeWriter
    from shells.geometry.shapes import SphericalCap
    from shells.problem.interface import set_state
    from shells.surface.fields import FieldWriter

    run = out / "postbuckle_surface"
    shutil.rmtree(run, ignore_errors=True)  # a finished run would be reused, not recomputed
    cfg = PostbuckleConfig(SphericalCap(1.0, math.radians(30)), 0.04, model="surface",
                           direction="down", kappa_end=-0.72, size=0.35, layer_elements=3.0,
                           degree=2, sides=(1,), max_points=2)
    shapes = ShapeWriter(run, "last", "surface", 0.04)
    try:
        run_postbuckle(cfg, run, on_point=shapes)
    finally:
        shapes.close()
    model, state, rec = shapes.last[1]
    set_state(model, state)
    funcs = FieldWriter(model, None).update()
    return {"file": str((run / "fields_side+1.bp").resolve()), "time": float(rec["index"]),
            "kappa_R": rec["kappa_R"], **_field_ranges(model, funcs)}


def postbuckled_shape(out: Path) -> dict:
    """A 1D post-buckled sphere written as a 3D surface by ``shells postbuckle --fields last``,
    and what its arrays must hold: rebuilt here from the run's meridian CSV
    (``shells.axisym.revolve`` on the CSV's values, not by reading the .vts back)."""
    import csv

    from shells.axisym.revolve import revolve

    run = out / "postbuckle"
    _shells(*PB_RUN, "-o", str(run))
    vts = sorted((run / "shapes").glob("*.vts"))[-1]
    rows = list(csv.DictReader(open(vts.with_suffix(".csv"))))
    h = 0.05
    prof = {k: np.array([float(r[k]) for r in rows]) for k in ("t", "r0", "z0")}
    prof["ur"] = np.array([float(r["ur_over_h"]) * h for r in rows])
    prof["uz"] = np.array([float(r["uz_over_h"]) * h for r in rows])
    grid = revolve(prof)
    arrays = {}
    for name in ("displacement", "normal_displacement"):
        a = np.asarray(grid.point_data[name]).reshape(grid.n_points, -1)
        arrays[name] = {"components": a.shape[1],
                        "ranges": [[float(a[:, i].min()), float(a[:, i].max())]
                                   for i in range(a.shape[1])],
                        "magnitude": [float(np.linalg.norm(a, axis=1).min()),
                                      float(np.linalg.norm(a, axis=1).max())]}
    return {"file": str(vts.resolve()), "points": int(grid.n_points),
            "cells": int(grid.n_cells), "arrays": arrays}


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: make_fields.py DIR")
    main(Path(sys.argv[1]))
