"""The snap by dynamics with fixed and adaptive time steps: steps, snap time, rest state.

``shells snap --method dynamics`` adapts its steps at a tolerance of ``snap.STEP_TOL`` on
TSALPHA2's local error. This compares it with fixed steps of ``snap.DT_STEP`` and a tighter
tolerance on one shallow cap (θ̄ = 3, h/R = 0.04, P3, 2 % past the fold, damping 1), where
the snap is axisymmetric and quick. Writes ``benchmarks/results/snap_dynamics_steps.json``
and prints a table.

    scripts/in-env python3 benchmarks/snap_dynamics_steps.py [--size 0.5]
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

from shells.analyses import snap
from shells.geometry.shapes import SphericalCap

RESULTS = Path(__file__).parent / "results" / "snap_dynamics_steps.json"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=float, default=0.5, help="mesh size over R")
    a = ap.parse_args()
    h = 0.04
    cfg = snap.SnapConfig(shape=SphericalCap(1.0, 3.0 * math.sqrt(h)), h_over_r=h, past=0.02,
                          size=a.size, degree=3, layer_elements=1.0, method="dynamics",
                          damping=1.0)
    rows = []
    for label, tol in (("fixed 0.05", None), ("adaptive 1e-4", 1e-4), ("adaptive 1e-3", 1e-3)):
        snap.STEP_TOL = tol
        t0 = time.perf_counter()
        r = snap.run(cfg, None, render=False)
        d = r["dynamics"]
        rows.append({"steps": label, "step_tol": tol, "count": d["steps"],
                     "reason": d["reason"], "snap_time": d["snap_time"],
                     "rest_energy": r["landing"]["rest_energy"],
                     "energy": r["landing"]["energy"], "dofs": r["dofs"],
                     "wall_time": time.perf_counter() - t0})
        print(f"{label:>14}  {d['steps']:6d} steps  snap time {d['snap_time']:.5f}  rest "
              f"{r['landing']['rest_energy']:.12g}  polished {r['landing']['energy']:.12g}  "
              f"{rows[-1]['wall_time']:.0f} s", flush=True)
    RESULTS.parent.mkdir(exist_ok=True)
    RESULTS.write_text(json.dumps({"case": "cap thetabar 3, h/R 0.04, P3, past 0.02, "
                                   "damping 1", "size": a.size, "runs": rows}, indent=1))


if __name__ == "__main__":
    main()
