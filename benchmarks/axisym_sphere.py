"""Closed-sphere buckling with the axisymmetric model: κ_b h and the mode degree n versus h/R.

Runs ``shells.axisym.critical`` on a closed sphere (κ > 0) for h/R = 0.05, 0.01, 0.002, 0.001
and ν = 1/2, 0.3 (h/R = 1e-3 only with ν = 1/2: the timed case, goal < 10 s on one core) and
compares with the paper's asymptotics κ_b h = 4 sqrt(3(1-ν)/((1+ν)(5+4ν))) and
n(n+1) = 2/(1+2ν) (R/h) sqrt(3(5+4ν)(1-ν²)). Writes JSON and prints a table.

    scripts/in-env python3 benchmarks/axisym_sphere.py [OUT.json]
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from shells.analyses.axisym_runs import critical
from shells.geometry.shapes import Sphere
from shells.theory import sphere_kappa_b_h, sphere_mode_n

CASES = [(0.05, 0.5), (0.05, 0.3), (0.01, 0.5), (0.01, 0.3), (0.002, 0.5), (0.002, 0.3),
         (0.001, 0.5)]


def main(out: str = "benchmarks/results/axisym_sphere.json") -> None:
    critical(Sphere(1.0), 0.05, 0.5)  # JIT warm-up, not timed
    rows = []
    for h_over_r, nu in CASES:
        t0, c0 = time.perf_counter(), time.process_time()
        r = critical(Sphere(1.0), h_over_r, nu, "up")
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        kb = sphere_kappa_b_h(nu)
        rows.append({**r, "wall_s": wall, "cpu_s": cpu, "kappa_b_h_asymptotic": kb,
                     "rel_error": r["kappa_h"] / kb - 1,
                     "n_asymptotic": sphere_mode_n(h_over_r, nu)})
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    Path(out).write_text(json.dumps(rows, indent=1))
    print(f"{'h/R':>7} {'nu':>4} {'kappa_b h':>10} {'asympt.':>8} {'rel.err':>9} {'n':>4} "
          f"{'n asym':>7} {'m first':>7} {'dofs':>5} {'wall s':>7} {'cpu s':>6}")
    for r in rows:
        print(f"{r['h_over_R']:7.3g} {r['nu']:4.2g} {r['kappa_h']:10.5f} "
              f"{r['kappa_b_h_asymptotic']:8.5f} {r['rel_error']:+9.2e} {r['mode_n']:4d} "
              f"{r['n_asymptotic']:7.2f} {r['mode_m']:7d} {r['dofs']:5d} {r['wall_s']:7.2f} "
              f"{r['cpu_s']:6.2f}")
    timed = [r for r in rows if r["h_over_R"] == 0.001][0]
    print(f"h/R = 1e-3: {timed['wall_s']:.1f} s wall, {timed['cpu_s']:.1f} s CPU (goal < 10 s on "
          "one core; wall time counts other processes on a shared machine)")


if __name__ == "__main__":
    main(*sys.argv[1:])
