"""Factorisations per pseudo-arclength step of `shells critical` on the surface model (issue 14:
"report the cost per arclength step in LU factorisations, goal at most 3").

    scripts/in-env python3 benchmarks/lu_per_step.py [-o benchmarks/results/lu_per_step.json]

Cases (h/R = 0.04, ν = 1/2, default discretisation, ``--first-only``): the 30° cap going up (to
its fold) and the θ̄ = 5 cap (θ = 1 rad, to its first bifurcation). Counted by wrapping the
solver layer: the bordered corrector's LU factorisations within each step of
``continuation.arclength_steps`` (its corrector iterations and the tangent at the new point),
and over the whole run the LU factorisations of the locator's trials, SNES's, and the LDLᵀ
factorisations of the inertia (``stability.setup_factor``). Prints a table, writes JSON.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from collections import Counter
from pathlib import Path

from shells import continuation, solvers, stability
from shells.drivers import critical_surface
from shells.geometry import SphericalCap

CASES = {"cap30 up": (30.0, 3.0), "thetabar5 up": (math.degrees(1.0), 5.0)}


def count_run(theta_deg: float, kappa_r_end: float) -> dict:
    count: Counter = Counter()
    per_step: list[int] = []
    real_factor, real_solve = solvers.NewtonSolver.factor, solvers.NewtonSolver.solve
    real_setup, real_steps = stability.setup_factor, continuation.arclength_steps

    def factor(self):
        count["lu"] += 1
        return real_factor(self)

    def solve(self, atol=None):
        ok, its = real_solve(self, atol)
        count["snes_lu"] += its
        return ok, its

    def setup(ksp, A, options):
        count["ldlt"] += 1
        return real_setup(ksp, A, options)

    def steps(*args, **kwargs):
        gen = real_steps(*args, **kwargs)
        while True:
            c0 = count["lu"]
            try:
                s = next(gen)
            except StopIteration:
                return
            per_step.append(count["lu"] - c0)
            yield s

    from shells import critical

    solvers.NewtonSolver.factor, solvers.NewtonSolver.solve = factor, solve
    stability.setup_factor, continuation.arclength_steps = setup, steps
    critical_steps = critical.arclength_steps
    critical.arclength_steps = steps
    try:
        t0 = time.perf_counter()
        r = critical_surface(SphericalCap(1.0, math.radians(theta_deg)), 0.04, 0.5,
                             kappa_r_end, first_only=True)
        wall = time.perf_counter() - t0
    finally:
        solvers.NewtonSolver.factor, solvers.NewtonSolver.solve = real_factor, real_solve
        stability.setup_factor, continuation.arclength_steps = real_setup, real_steps
        critical.arclength_steps = critical_steps
    in_steps = sum(per_step)
    return {"theta_deg": theta_deg, "dofs": r["dofs"], "kind": r["kind"],
            "kappa_R": r["kappa_R"], "steps": len(per_step), "lu_per_step": per_step,
            "mean_lu_per_step": in_steps / max(len(per_step), 1),
            "lu_locator_and_start": count["lu"] - in_steps, "snes_lu": count["snes_lu"],
            "ldlt": count["ldlt"], "wall_s": wall}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("-o", default="benchmarks/results/lu_per_step.json")
    a = ap.parse_args()
    rows = {}
    for name, (th, kr) in CASES.items():
        rows[name] = count_run(th, kr)
        Path(a.o).write_text(json.dumps(rows, indent=1) + "\n")
    print(f"{'case':>14} {'DOFs':>7} {'steps':>5} {'LU/step':>7} {'LU locator':>10} "
          f"{'LDLT':>5} {'wall s':>7}")
    for name, r in rows.items():
        print(f"{name:>14} {r['dofs']:7d} {r['steps']:5d} {r['mean_lu_per_step']:7.2f} "
              f"{r['lu_locator_and_start']:10d} {r['ldlt']:5d} {r['wall_s']:7.1f}")


if __name__ == "__main__":
    main()
