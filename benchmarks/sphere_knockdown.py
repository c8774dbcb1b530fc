"""Knock-down of the closed sphere's curvature buckling by axisymmetric imperfections (1D model,
rotational symmetry enforced): κ_max/κ_b against δ/h for a pole dimple (width sqrt(Rh)) and the
buckling mode's shape, h/R = 0.05 and 0.01, ν = 1/2 and 0.3; the small-δ exponent of
1 - κ_max/κ_b (an asymmetric bifurcation's law is δ^½). Writes
benchmarks/results/sphere_knockdown.json and .png, prints a table.

    scripts/in-env python3 benchmarks/sphere_knockdown.py [--quick]
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from shells.knockdown import KnockdownConfig, run_knockdown

RESULTS = Path("benchmarks/results")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="h/R = 0.05 only")
    args = ap.parse_args()
    amps = (0.001, 0.003, 0.01, 0.03, 0.1, 0.3, 1.0)
    cases = [(0.05, 0.5), (0.05, 0.3)] + ([] if args.quick else [(0.01, 0.5), (0.01, 0.3)])
    out = {"amplitudes": amps, "curves": []}
    for h, nu in cases:
        for kind in ("dimple", "mode"):
            t0 = time.perf_counter()
            cfg = KnockdownConfig(h, (0.0, *amps), nu=nu, imperfection=kind, width=1.0)
            res = run_knockdown(cfg, Path("results/knockdown") / f"{kind}-{h}-{nu}",
                                figure=False)
            pts = res["points"]
            small = [p for p in pts if 0 < p["delta_over_h"] <= 0.01]
            x = np.log([p["delta_over_h"] for p in small])
            y = np.log([1 - p["knockdown"] for p in small])
            slope = float(np.polyfit(x, y, 1)[0]) if len(small) >= 2 else math.nan
            out["curves"].append({"h_over_R": h, "nu": nu, "imperfection": kind,
                                  "kappa_b_h": res["kappa_b_h"],
                                  "degree": res["degree"], "points": pts,
                                  "small_delta_exponent": slope,
                                  "wall_time": time.perf_counter() - t0})
            print(f"h/R = {h:5}  nu = {nu}  {kind:6}  kappa_b h = "
                  f"{res['kappa_b_h']:.5f}  n = {res['degree']:3d}  exponent "
                  f"{slope:.3f}  ({time.perf_counter() - t0:.0f} s)", flush=True)
            print("   delta/h: " + "  ".join(f"{p['delta_over_h']:7g}" for p in pts))
            print("   knock-down: " + "  ".join(f"{p['knockdown']:.4f}" for p in pts))
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "sphere_knockdown.json").write_text(json.dumps(out, indent=1))
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for c in out["curves"]:
        pts = [p for p in c["points"] if p["delta_over_h"] > 0]
        ax.semilogx([p["delta_over_h"] for p in pts], [p["knockdown"] for p in pts],
                    "o-" if c["imperfection"] == "dimple" else "s--", ms=3,
                    label=f"h/R = {c['h_over_R']}, ν = {c['nu']}, {c['imperfection']}")
    ax.set_xlabel("imperfection amplitude δ/h")
    ax.set_ylabel("κ_max / κ_b")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(RESULTS / "sphere_knockdown.png", dpi=150)
    print(f"wrote {RESULTS / 'sphere_knockdown.json'} and .png")


if __name__ == "__main__":
    main()
