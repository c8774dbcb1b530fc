"""The closed sphere's dimple branch on both models: the surface model (2D, no symmetry imposed
on the mesh) against the 1D axisymmetric model, both through ``shells.analyses.postbuckle`` (the
dimple at the pole, its depth Ψ3(pole)/h the branch's parameter), h/R = 0.05, ν = ½, the inward
side.

Each model's κ is divided by its own κ_b (the 2D mesh's is 0.4 % above the 1D one at the
default discretisation, benchmarks/sphere_buckling.py); κ/κ_b is interpolated linearly at the
pole depths ``DEPTHS`` on each branch and compared. Also printed: the surface model's negative
count (all modes, the non-axisymmetric ones included) along its branch, and the 1D model's
total over its Fourier blocks (each m ≥ 1 counted twice, cos and sin), which it should equal,
with how many of them slide the dimple over the sphere (``orientation_modes``: the orbit of the
sphere's rotations, neutral in the continuum, of either sign on a mesh). A second surface-model
run on a finer mesh (``--finer`` size, 0.15 by default; 0: none) shows the 2D error shrinking.

    scripts/in-env mpirun -n 2 python3 benchmarks/dimple_2d.py [-o OUT.json] [--points N]
        [--finer SIZE]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

from shells.analyses.postbuckle import PostbuckleConfig, postbuckle
from shells.geometry.shapes import Sphere

REPO = Path(__file__).resolve().parent.parent
H = 0.05
DEPTHS = (0.5, 1.0, 2.0, 3.0, 4.0)


def branch(model: str, points: int, size: float | None = None) -> dict:
    t0 = time.perf_counter()
    recs = list(postbuckle(PostbuckleConfig(Sphere(1.0), H, model=model, max_points=points,
                                            sides=(-1,), size=size)))
    cp = next(r["critical_point"] for r in recs if "critical_point" in r)
    down = [r for r in recs if r.get("branch") == "bifurcated"
            and r.get("control_parameter", 1.0) == 1.0]
    depth = np.array([-r["psi3_pole_over_h"] for r in down])
    ratio = np.array([r["kappa"] / cp["kappa"] for r in down])
    at = {f"{d:g}": (float(np.interp(d, depth, ratio)) if depth[0] <= d <= depth[-1] else None)
          for d in DEPTHS}
    return {"model": model, "size": size, "kappa_b_h": cp["kappa_h"], "mode_n": cp["mode_n"],
            "multiplicity": cp["multiplicity"], "dofs": recs[-1]["summary"]["dofs"],
            "points": len(down), "wall_s": time.perf_counter() - t0,
            "depth": depth.tolist(), "kappa_over_kappa_b": ratio.tolist(),
            "negative_count": [r["negative_count"] for r in down],
            "orientation_modes": [r.get("orientation_modes", 0) for r in down],
            "kappa_over_kappa_b_at_depth": at}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", default=str(REPO / "benchmarks/results/dimple_2d.json"))
    ap.add_argument("--points", type=int, default=30)
    ap.add_argument("--finer", type=float, default=0.15,
                    help="mesh size of a second, finer surface-model run (0: none)")
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    one = branch("axisym", args.points)  # (COMM_SELF on every rank)
    two = branch("surface", args.points)
    fine = branch("surface", args.points + 6, args.finer) if args.finer > 0 else None
    if comm.rank != 0:
        return
    rows = []
    for d in DEPTHS:
        a, b = (one["kappa_over_kappa_b_at_depth"][f"{d:g}"],
                two["kappa_over_kappa_b_at_depth"][f"{d:g}"])
        c = fine["kappa_over_kappa_b_at_depth"][f"{d:g}"] if fine else None
        rows.append({"depth": d, "axisym": a, "surface": b,
                     "difference": None if a is None or b is None else b - a,
                     "surface_finer": c,
                     "difference_finer": None if a is None or c is None else c - a})
    Path(args.output).write_text(json.dumps({"h_over_R": H, "axisym": one, "surface": two,
                                             "surface_finer": fine, "rows": rows,
                                             "ranks": comm.size}, indent=1))
    print(f"kappa_b h: axisym {one['kappa_b_h']:.5f} (n = {one['mode_n']}, {one['dofs']} DOFs, "
          f"{one['wall_s']:.0f} s), surface {two['kappa_b_h']:.5f} (n = {two['mode_n']}, "
          f"multiplet {two['multiplicity']}, {two['dofs']} DOFs, {two['wall_s']:.0f} s on "
          f"{comm.size} ranks)")
    if fine:
        print(f"finer surface mesh (size {args.finer:g}): kappa_b h {fine['kappa_b_h']:.5f} "
              f"({fine['dofs']} DOFs, {fine['wall_s']:.0f} s)")
    print(f"{'depth/h':>8} {'1D k/kb':>9} {'2D k/kb':>9} {'2D - 1D':>9} {'finer':>9} "
          f"{'- 1D':>9}")
    for r in rows:
        f = (lambda v: f"{v:9.4f}" if v is not None else f"{'-':>9}")  # noqa: E731
        g = (lambda v: f"{v:9.1e}" if v is not None else f"{'-':>9}")  # noqa: E731
        print(f"{r['depth']:8g} {f(r['axisym'])} {f(r['surface'])} {g(r['difference'])} "
              f"{f(r['surface_finer'])} {g(r['difference_finer'])}")
    for name, run in (("surface", two), ("finer", fine), ("axisym", one)):
        if run:
            print(f"negative counts, {name:>7}:", run["negative_count"])
            print("  of which slide the dimple:", run["orientation_modes"])
    print("written:", args.output)


if __name__ == "__main__":
    main()
