"""The deep cap's loss of symmetry on the surface model (issue 14): h/R = 0.01, θ = 46.2°
(θ̄ ≈ 8), going up, on three meshes (P3), against the 1D model at 200, 400 and 800 cells. The
1D model finds an m = 5 bifurcation before its fold; the surface model must find the same kind
and m, converging to the same κ.

    scripts/in-env mpirun -n 2 python3 benchmarks/deep_cap_2d.py

Writes benchmarks/results/deep_cap_2d.json (after every level) and prints a table (about 9
minutes on 2 cores).
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

from mpi4py import MPI

from shells.analyses import axisym_runs
from shells.analyses.critical import run_surface
from shells.geometry.shapes import SphericalCap

CAP = SphericalCap(1.0, math.radians(46.2))
H_OVER_R = 0.01
#: (bulk size / R, elements across sqrt(R h)): the default (0.2, 4) in the middle
MESHES = [(0.25, 3.0), (0.2, 4.0), (0.16, 5.0)]
OUT = Path(__file__).parent / "results" / "deep_cap_2d.json"


def main() -> None:
    comm = MPI.COMM_WORLD
    one = []
    for cells in (200, 400, 800):
        d = axisym_runs.critical(CAP, H_OVER_R, 0.5, direction="up", cells=cells, max_critical=1)
        one.append({"cells": cells, "kind": d["kind"], "kappa_R": d["kappa_R"],
                    "mode_m": d["mode_m"]})
    ref = one[-1]["kappa_R"]
    rows = []
    for size, layer in MESHES:
        t0 = time.perf_counter()
        d = run_surface(CAP, H_OVER_R, 0.5, 10.0 / CAP.R, first_only=True, size=size,
                             layer_elements=layer)
        first = d["critical_points"][0]
        rows.append({"size": size, "layer_elements": layer, "degree": 3, "dofs": d["dofs"],
                     "kind": first["kind"], "kappa_R": first["kappa_R"],
                     "mode_m": first["mode_m"], "relative_to_axisym": first["kappa_R"] / ref - 1,
                     "seconds": time.perf_counter() - t0})
        if comm.rank == 0:
            OUT.write_text(json.dumps({"shape": CAP.describe(), "h_over_R": H_OVER_R,
                                       "nu": 0.5, "ranks": comm.size, "axisym": one,
                                       "surface": rows}, indent=1))
    if comm.rank == 0:
        for r in one:
            print(f"1D {r['cells']:4d} cells: {r['kind']} m = {r['mode_m']} at kappa R = "
                  f"{r['kappa_R']:.6f}")
        print(f"{'size':>5} {'layer':>5} {'DOFs':>7} {'kind':>12} {'m':>2} {'kappa R':>10} "
              f"{'vs 1D':>9} {'time':>6}")
        for r in rows:
            print(f"{r['size']:5.2f} {r['layer_elements']:5.1f} {r['dofs']:7d} {r['kind']:>12} "
                  f"{r['mode_m']:2d} {r['kappa_R']:10.6f} {r['relative_to_axisym']:+9.1e} "
                  f"{r['seconds']:5.0f}s")


if __name__ == "__main__":
    main()
