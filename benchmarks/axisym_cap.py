"""Cap snap-through with the axisymmetric model: from κ = 0 to the fold, m = 0..12 checked at
every branch point (goal < 30 s on one core), and the critical points of θ = 30°, 45° caps at
h/R = 0.04 in both directions, against the paper's fits (snap: κ_s R = β θ̄ - α, α = 0.67,
β = 0.85; buckling: κ_b R = -a/θ̄² + 1 + b/(θ̄ - π sqrt(R/h)) + c, b = 3.6, c = -0.98,
a = sqrt(10 + 7 sqrt 2)). Writes JSON and prints a table.

    scripts/in-env python3 benchmarks/axisym_cap.py [OUT.json]
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

from shells.analyses.axisym_runs import branch, critical
from shells.geometry.shapes import SphericalCap


def paper_line(theta_deg: float, h_over_r: float, direction: str) -> float:
    tb = math.radians(theta_deg) / math.sqrt(h_over_r)
    if direction == "up":
        return 0.85 * tb - 0.67
    a = math.sqrt(10 + 7 * math.sqrt(2))
    return -a / tb**2 + 1 + 3.6 / (tb - math.pi / math.sqrt(h_over_r)) - 0.98


def timed_branch(theta_deg: float = 30.0, h_over_r: float = 0.04) -> dict:
    """The branch from κ = 0 past its first fold, m = 0..12 at every point."""
    cap = SphericalCap(1.0, math.radians(theta_deg))
    t0, c0 = time.perf_counter(), time.process_time()
    pts, fold = [], None
    for rec in branch(cap, h_over_r, 0.5, "up", m_max=12, kappa_max=4.0):
        pts.append(rec)
        if len(pts) > 1 and pts[-2]["dkappa_ds"] > 0 >= rec["dkappa_ds"]:
            fold = max(pts[-2]["kappa_R"], rec["kappa_R"])
            break
    return {"theta_deg": theta_deg, "h_over_R": h_over_r, "points": len(pts),
            "fold_kappa_R_from_points": fold, "wall_s": time.perf_counter() - t0,
            "cpu_s": time.process_time() - c0,
            "unstable_before_fold": sorted({m for p in pts[:-1] for m in p["unstable_modes"]})}


def main(out: str = "benchmarks/results/axisym_cap.json") -> None:
    critical(SphericalCap(1.0, math.radians(30)), 0.04, 0.5, m_max=0, kappa_max=0.1)  # JIT
    run = timed_branch()
    rows = []
    for theta in (30.0, 45.0):
        for direction in ("up", "down"):
            t0 = time.perf_counter()
            r = critical(SphericalCap(1.0, math.radians(theta)), 0.04, 0.5, direction,
                         m_max=12, kappa_max=4.0)
            line = paper_line(theta, 0.04, direction)
            rows.append({**r, "direction": direction, "wall_s": time.perf_counter() - t0,
                         "paper_line_kappa_R": line,
                         "rel_to_paper_line": r["kappa_R"] / line - 1 if r["kappa_R"] else None})
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    Path(out).write_text(json.dumps({"branch_to_fold": run, "critical": rows}, indent=1))
    print(f"branch to the fold (theta = 30 deg, h/R = 0.04, m = 0..12 at each of "
          f"{run['points']} points): {run['wall_s']:.1f} s wall, {run['cpu_s']:.1f} s CPU "
          f"(goal < 30 s); fold near kappa R = "
          f"{run['fold_kappa_R_from_points']:.4f}; unstable m before it: "
          f"{run['unstable_before_fold']}")
    print(f"{'theta':>5} {'dir':>4} {'kind':>11} {'kappa R':>9} {'m':>3} {'paper':>7} "
          f"{'rel':>7} {'#crit':>5} {'wall s':>6}")
    for r in rows:
        rel = f"{r['rel_to_paper_line']:+7.3f}" if r["rel_to_paper_line"] is not None else "    -"
        print(f"{r['theta_deg']:5.0f} {r['direction']:>4} {r['kind']:>11} {r['kappa_R']:9.4f} "
              f"{r['mode_m']:3d} {r['paper_line_kappa_R']:7.3f} {rel} "
              f"{len(r['critical_points']):5d} {r['wall_s']:6.1f}")


if __name__ == "__main__":
    main(*sys.argv[1:])
