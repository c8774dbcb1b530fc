"""A non-axisymmetric imperfection on the surface model, read from a mesh file (issue 15): a
closed sphere with a dimple w0 = -δ h exp(-(β/β0)²) centred on its equator (β the angle from
(R, 0, 0), β0 = width √(h/R)), meshed and dented with gmsh's own API as a user would (no
sidecar), run with `--mesh` (the surface known only by its mesh, ``shells.geometry.surface_fit``),
against the 1D model's sphere with the same dimple at its pole. A sphere has no preferred axis: the
two must give the same limit point.

    scripts/in-env mpirun -n 2 python3 benchmarks/dimple_off_pole.py [--h-over-r 0.05]
        [--delta 0.1] [--width 1]

Merges its configuration's entry into ``benchmarks/results/dimple_off_pole.json`` (rank 0) and
prints the comparison.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

from shells.analyses import critical, knockdown
from shells.analyses.knockdown import KnockdownConfig
from shells.surface.mesh import read_mesh_shape

HERE = Path(__file__).parent
JSON = HERE / "results" / "dimple_off_pole.json"
#: elements across β0 near the dimple (as shells.surface.mesh.DIMPLE_ELEMENTS) and the bulk size
FINE_PER_WIDTH, BULK = 4.0, 0.21


def write_dented_sphere(path: Path, h: float, delta: float, width: float) -> dict:
    """The unit sphere meshed by gmsh (second order, refined within 3 β0 of (1, 0, 0)), its
    nodes moved radially onto ρ = 1 - δ h exp(-(β/β0)²)."""
    import gmsh

    b0 = width * math.sqrt(h)
    fine = b0 / FINE_PER_WIDTH
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("dented")
    occ = gmsh.model.occ
    v = occ.addSphere(0, 0, 0, 1.0)
    occ.synchronize()
    faces = [t for _, t in gmsh.model.getBoundary([(3, v)], oriented=False)]
    occ.remove([(3, v)])
    occ.synchronize()
    fld = gmsh.model.mesh.field
    f = fld.add("MathEval")
    d = "Sqrt((x-1)^2+y^2+z^2)"
    fld.setString(f, "F", f"Min({BULK}, Max({fine}, {fine} + 0.2*({d} - {3 * b0})))")
    fld.setAsBackgroundMesh(f)
    for opt in ("MeshSizeFromPoints", "MeshSizeFromCurvature", "MeshSizeExtendFromBoundary"):
        gmsh.option.setNumber(f"Mesh.{opt}", 0)
    gmsh.model.addPhysicalGroup(2, faces, 7)
    gmsh.model.mesh.generate(2)
    gmsh.model.mesh.setOrder(2)
    tags, x, _ = gmsh.model.mesh.getNodes()
    x = np.asarray(x).reshape(-1, 3)
    r = np.linalg.norm(x, axis=1)
    beta = np.arccos(np.clip(x[:, 0] / r, -1, 1))
    rho = 1.0 - delta * h * np.exp(-((beta / b0) ** 2))
    for t, p in zip(tags, x / r[:, None] * rho[:, None], strict=True):
        gmsh.model.mesh.setNode(int(t), p.tolist(), [])
    ncells = sum(len(e) for e in gmsh.model.mesh.getElements(2)[1])
    gmsh.write(str(path))
    gmsh.finalize()
    return {"cells": int(ncells), "fine": fine, "bulk": BULK}


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--h-over-r", type=float, default=0.05)
    ap.add_argument("--delta", type=float, default=0.1, help="dimple depth / h")
    ap.add_argument("--width", type=float, default=1.0, help="β0 / sqrt(h/R)")
    a = ap.parse_args()
    comm = MPI.COMM_WORLD
    h = a.h_over_r
    out: dict = {"h_over_R": h, "nu": 0.5, "delta_over_h": a.delta, "width": a.width,
                 "ranks": comm.size}
    path = Path("/tmp") / f"shells_bench_dented_sphere_{h:g}_{a.delta:g}_{a.width:g}.msh"
    mesh_info = write_dented_sphere(path, h, a.delta, a.width) if comm.rank == 0 else None
    out["mesh"] = comm.bcast(mesh_info, root=0)
    t0 = time.perf_counter()
    shape = read_mesh_shape(path, comm)
    out["fitted_R"] = shape.R
    # h itself fixed (the fitted R of the dented sphere is not 1): κh is the comparison
    r = critical.run(shape, h / shape.R, 0.5, direction="up", model="surface",
                     first_only=True, mesh_file=str(path))
    out["surface"] = {"kind": r["kind"], "kappa_h": r["kappa_h"], "dofs": r["dofs"],
                      "wall_s": time.perf_counter() - t0}
    t1 = time.perf_counter()
    kd = knockdown.run(KnockdownConfig(h_over_r=h, nu=0.5, amplitudes=(a.delta,),
                                       imperfection="dimple", width=a.width), None,
                       figure=False)
    p = kd["points"][0]
    out["axisym_pole_dimple"] = {"kappa_b_h": kd["kappa_b_h"], "kappa_max_h": p["kappa_max_h"],
                                 "knockdown": p["knockdown"], "wall_s": time.perf_counter() - t1}
    out["surface"]["knockdown_vs_1d_kappa_b"] = r["kappa_h"] / kd["kappa_b_h"]
    out["rel_difference"] = r["kappa_h"] / p["kappa_max_h"] - 1
    if comm.rank == 0:
        JSON.parent.mkdir(parents=True, exist_ok=True)
        runs = json.loads(JSON.read_text()) if JSON.exists() else {}
        runs[f"h{h:g}_delta{a.delta:g}_width{a.width:g}"] = out  # one entry per configuration
        JSON.write_text(json.dumps(runs, indent=1, default=float) + "\n")
        print(f"dimple on the equator, surface model on the user's mesh ({out['mesh']['cells']} "
              f"cells, {r['dofs']} DOFs, fitted R = {shape.R:.6f}): {r['kind']} at kappa h = "
              f"{r['kappa_h']:.6f} ({out['surface']['wall_s']:.0f} s)")
        print(f"dimple at the pole, 1D model: kappa_max h = {p['kappa_max_h']:.6f}, kappa_b h = "
              f"{kd['kappa_b_h']:.6f}, knock-down {p['knockdown']:.5f}")
        print(f"difference: {out['rel_difference']:+.2e}; surface knock-down against the 1D "
              f"kappa_b: {out['surface']['knockdown_vs_1d_kappa_b']:.5f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
