"""Is the closed sphere's post-buckling branch one curve, whatever the numerics? (1D model,
``shells.analyses.postbuckle``, the inward side: the dimple at the pole followed with its depth as
the parameter.)

For h/R = 0.001 and 0.01 the branch is computed with first amplitudes 0.2, 0.25 and 0.35
thicknesses and penalties 1e5 (the driver's) and 1e4, and compared at common pole depths:
κ/κ_b interpolated linearly at 40 depths between the deepest first point and the shallowest
last point of the runs, the largest difference from the reference run (amplitude 0.25, penalty
1e5) printed and written to JSON. κ_b itself differs between penalties (the penalty
imperfection, docs/model.md), so each run's κ is divided by its own κ_b.

    scripts/in-env python3 benchmarks/postbuckle_robustness.py [-o OUT.json] [--points N]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from shells.analyses.postbuckle import CLOSED_PENALTY, PostbuckleConfig, postbuckle
from shells.geometry.shapes import Sphere

REPO = Path(__file__).resolve().parent.parent
VARIANTS = [(0.25, CLOSED_PENALTY), (0.2, CLOSED_PENALTY), (0.35, CLOSED_PENALTY), (0.25, 1.0e4)]


def run(h: float, amplitude: float, penalty: float, points: int) -> dict:
    t0 = time.perf_counter()
    recs = list(postbuckle(PostbuckleConfig(Sphere(1.0), h, max_points=points,
                                            amplitude=amplitude, penalty=penalty,
                                            sides=(-1,), kappa_min_ratio=0.3)))
    cp = next(r["critical_point"] for r in recs if "critical_point" in r)
    down = [r for r in recs if r.get("branch") == "bifurcated"
            and r.get("control_parameter", 1.0) == 1.0]
    return {"h_over_R": h, "amplitude": amplitude, "penalty": penalty,
            "kappa_b_h": cp["kappa_h"], "points": len(down), "wall_s": time.perf_counter() - t0,
            "depth": [-r["psi3_pole_over_h"] for r in down],
            "kappa_over_kappa_b": [r["kappa"] / cp["kappa"] for r in down],
            "negative_counts": sorted({r["negative_count_axisymmetric"] for r in down}),
            "newton_its_max": max(r["newton_its"] for r in down)}


def compare(ref: dict, other: dict) -> tuple[float, float, float]:
    """Largest |Δ κ/κ_b| over the common depths, and that depth range."""
    lo = max(ref["depth"][0], other["depth"][0])
    hi = min(ref["depth"][-1], other["depth"][-1])
    grid = np.linspace(lo, hi, 40)
    a = np.interp(grid, ref["depth"], ref["kappa_over_kappa_b"])
    b = np.interp(grid, other["depth"], other["kappa_over_kappa_b"])
    return float(np.max(np.abs(a - b))), float(lo), float(hi)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", default=str(REPO / "benchmarks/results/"
                                                  "postbuckle_robustness.json"))
    ap.add_argument("--points", type=int, default=40)
    args = ap.parse_args(argv)
    rows = []
    for h in (0.01, 0.001):
        runs = [run(h, a, p, args.points) for a, p in VARIANTS]
        for r in runs:
            diff, lo, hi = compare(runs[0], r)
            r.update(max_diff_from_reference=diff, common_depth=[lo, hi])
            rows.append(r)
            print(f"h/R {h:g} amplitude {r['amplitude']:.2f} penalty {r['penalty']:.0e}: "
                  f"{r['points']} points to {r['depth'][-1]:.1f} h, kappa_b h "
                  f"{r['kappa_b_h']:.5f}, negative counts {r['negative_counts']}, Newton <= "
                  f"{r['newton_its_max']}, max |d kappa/kappa_b| vs reference {diff:.1e} "
                  f"over depths {lo:.2f}..{hi:.1f} h ({r['wall_s']:.1f} s)", flush=True)
    Path(args.output).write_text(json.dumps({"runs": rows}, indent=1))
    print(f"{'h/R':>6} {'amp':>5} {'penalty':>8} {'points':>6} {'depth':>6} {'max diff':>9}")
    for r in rows:
        print(f"{r['h_over_R']:6g} {r['amplitude']:5.2f} {r['penalty']:8.0e} {r['points']:6d} "
              f"{r['depth'][-1]:6.1f} {r['max_diff_from_reference']:9.1e}")
    print("written:", args.output)


if __name__ == "__main__":
    main()
