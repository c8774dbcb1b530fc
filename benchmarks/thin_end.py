"""The 1D model at the thin end (issue 42): the first critical point of spherical caps of
h/R = 1e-4 and 3e-4 (θ̄ = 10, 20, 40, going down) and of the closed sphere of h/R = 1e-4
(going up) on 200 to 3200 cells with the default C1 penalty (``axisym.run.resolve_penalty``),
located to 1e-8; and the caps' convergence rate under uniform refinement (25 to 400 cells, the
rim layer refined with the bulk) at a fixed penalty, fitted against the finest mesh. Writes
JSON and prints a table.

    scripts/in-env python3 benchmarks/thin_end.py [OUT.json]
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from shells.analyses.axisym_runs import critical
from shells.geometry import Sphere, SphericalCap

CELLS = (200, 400, 800, 1600, 3200)
UNIFORM_CELLS = (25, 50, 100, 200, 400)
CAPS = [(h, tb) for h in (1e-4, 3e-4) for tb in (10.0, 20.0, 40.0)]


def run(shape, h: float, direction: str, **numerics) -> dict:
    t0 = time.perf_counter()
    try:
        r = critical(shape, h, 0.5, direction, rel_tol=1e-8, max_critical=1, **numerics)
    except Exception as e:  # a refusal is a result here
        return {"error": f"{type(e).__name__}: {e}", "wall_s": time.perf_counter() - t0}
    return {"kappa_R": r["kappa_R"], "kappa_h": r["kappa_h"], "mode_m": r["mode_m"],
            "mode_n": r["mode_n"], "penalty": r["penalty"], "dofs": r["dofs"],
            "wall_s": time.perf_counter() - t0}


def rate(rows: list[dict]) -> float | None:
    """Least-squares slope of log|κ - κ_finest| against log(1/cells) over the coarser meshes."""
    ok = [r for r in rows if "kappa_R" in r]
    if len(ok) < 4:
        return None
    ref = ok[-1]["kappa_R"]
    n = np.array([r["cells"] for r in ok[:-1]], dtype=float)
    e = np.array([abs(r["kappa_R"] - ref) for r in ok[:-1]])
    keep = e > 0
    if keep.sum() < 3:
        return None
    return float(-np.polyfit(np.log(n[keep]), np.log(e[keep]), 1)[0])


def main(out: str = "benchmarks/results/thin_end.json") -> None:
    cases = []
    for h, tb in CAPS:
        shape = SphericalCap(1.0, tb * math.sqrt(h))
        default = [{"cells": n, **run(shape, h, "down", cells=n)} for n in CELLS]
        uniform = [{"cells": n, **run(shape, h, "down", cells=n, layer_cells=8.0 * n / 200,
                                      penalty=1e4 * h)} for n in UNIFORM_CELLS]
        cases.append({"shape": "cap", "h_over_R": h, "thetabar": tb, "direction": "down",
                      "default": default, "uniform": uniform, "uniform_penalty": 1e4 * h,
                      "uniform_rate": rate(uniform)})
        print(json.dumps(cases[-1]), flush=True)
    h = 1e-4
    sphere = [{"cells": n, **run(Sphere(1.0), h, "up", cells=n)} for n in CELLS[1:]]
    cases.append({"shape": "sphere", "h_over_R": h, "direction": "up", "default": sphere,
                  "uniform": [], "uniform_rate": rate(sphere)})
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    Path(out).write_text(json.dumps(cases, indent=1))
    print(f"{'case':>22} {'cells':>5} {'penalty':>8} {'m':>3} {'kappa R':>14} "
          f"{'rel to finest':>13} {'wall s':>7}")
    for c in cases:
        name = (f"cap h/R={c['h_over_R']:g} tb={c['thetabar']:g}" if c["shape"] == "cap"
                else f"sphere h/R={c['h_over_R']:g}")
        for kind in ("default", "uniform"):
            rows = [r for r in c[kind] if "kappa_R" in r]
            ref = rows[-1]["kappa_R"] if rows else math.nan
            for r in c[kind]:
                if "kappa_R" not in r:
                    print(f"{name:>22} {r['cells']:5d} refused: {r['error']}")
                    continue
                m = r["mode_n"] if c["shape"] == "sphere" else r["mode_m"]
                print(f"{name:>22} {r['cells']:5d} {r['penalty']:8.0e} {m:3d} "
                      f"{r['kappa_R']:14.9f} {r['kappa_R'] / ref - 1:+13.2e} {r['wall_s']:7.1f}"
                      + ("  uniform" if kind == "uniform" else ""))
        if c["uniform_rate"] is not None:
            print(f"{name:>22} fitted rate {c['uniform_rate']:.2f}")


if __name__ == "__main__":
    main(*sys.argv[1:])
