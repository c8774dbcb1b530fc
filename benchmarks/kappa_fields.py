"""Natural-curvature fields on both models (issue 17): the first critical point of a
ring-patterned and of an anisotropically stimulated 30° cap (h/R = 0.04, ν = 1/2), the 1D
model against the surface model on a mesh sequence (P2 and P3), both directions.

    scripts/in-env mpirun -n 2 python3 benchmarks/kappa_fields.py

Writes benchmarks/results/kappa_fields.json (after every case) and prints a table.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

from mpi4py import MPI

from shells.analyses import critical
from shells.geometry.shapes import SphericalCap
from shells.geometry.stimulus import CurvatureField

CAP = SphericalCap(1.0, math.radians(30))
H_OVER_R = 0.04
RING = "step(theta - 0.2, 0.05) * step(0.4 - theta, 0.05)"
#: (name, field, direction, [(degree, layer elements), ...] of the surface model)
CASES = [
    ("ring", CurvatureField(RING), "up", [(2, 4), (2, 6), (2, 8), (3, 3), (3, 4), (3, 6)]),
    ("ring", CurvatureField(RING), "down", [(3, 4)]),
    ("anisotropic 1 : 0.5", CurvatureField("1", (1.0, 0.5)), "up", [(3, 4)]),
    ("anisotropic 1 : 0.5", CurvatureField("1", (1.0, 0.5)), "down", [(3, 4)]),
]
OUT = Path(__file__).parent / "results" / "kappa_fields.json"


def first(result: dict) -> dict:
    return {k: result.get(k) for k in ("kind", "kappa_R", "kappa_h", "mode_m", "dofs")}


def main() -> None:
    comm = MPI.COMM_WORLD
    rows = []
    for name, fld, direction, meshes in CASES:
        t0 = time.perf_counter()
        one = first(critical.run(CAP, H_OVER_R, 0.5, direction=direction, model="axisym",
                                 kappa_field=fld))
        one.update(model="axisym", seconds=time.perf_counter() - t0)
        ref = one["kappa_R"]
        rows.append({"case": name, "field": fld.describe(), "direction": direction, **one})
        for degree, layer in meshes:
            t0 = time.perf_counter()
            s = first(critical.run(CAP, H_OVER_R, 0.5, direction=direction, model="surface",
                                   kappa_field=fld, first_only=True, degree=degree,
                                   layer_elements=float(layer)))
            s.update(model="surface", degree=degree, layer_elements=layer,
                     seconds=time.perf_counter() - t0,
                     relative_to_axisym=s["kappa_R"] / ref - 1 if s["kappa_R"] else None)
            rows.append({"case": name, "field": fld.describe(), "direction": direction, **s})
            if comm.rank == 0:
                OUT.write_text(json.dumps({"shape": CAP.describe(), "h_over_R": H_OVER_R,
                                           "nu": 0.5, "ranks": comm.size, "rows": rows},
                                          indent=1))
    if comm.rank == 0:
        print(f"{'case':>20} {'dir':>4} {'model':>7} {'P':>2} {'layer':>5} {'DOFs':>6} "
              f"{'kind':>12} {'m':>2} {'kappa R':>10} {'vs 1D':>9} {'time':>6}")
        for r in rows:
            rel = r.get("relative_to_axisym")
            print(f"{r['case']:>20} {r['direction']:>4} {r['model']:>7} "
                  f"{r.get('degree', ''):>2} {r.get('layer_elements', ''):>5} {r['dofs']:>6} "
                  f"{r['kind']:>12} {r['mode_m']:>2} {r['kappa_R']:10.6f} "
                  f"{'' if rel is None else f'{rel:+.1e}':>9} {r['seconds']:5.0f}s")


if __name__ == "__main__":
    main()
