"""Factorisations per pseudo-arclength step of `shells critical` on the surface model (issue 14:
"report the cost per arclength step in LU factorisations, goal at most 3").

    scripts/in-env python3 benchmarks/lu_per_step.py [-o benchmarks/results/lu_per_step.json]

Cases (h/R = 0.04, ν = 1/2, default discretisation, ``--first-only``): the 30° cap going up (to
its fold) and the θ̄ = 5 cap (θ = 1 rad, to its first bifurcation). Counted by wrapping the
solver layer: the bordered corrector's LU factorisations within each step of
``continuation.arclength_steps`` (its corrector iterations and the tangent at the new point),
and over the whole run the LU factorisations of the locator's trials, SNES's, and the LDLᵀ
factorisations of the inertia (``stability.setup_factor``). Each case runs twice in one
process, alternating, on the same machine: with the corrector's factorisation reuse switched off
(``ContinuationSettings.factor_reuse = 0``: a factorisation per corrector iteration and one
for the tangent, as before issue 14) and with the driver's (``critical.REUSE_SURFACE``); the
located point of both is
compared. Factorisations are counted where they happen (``solvers.setup_factor``), not where
they are asked for. Prints a table, writes JSON.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from collections import Counter
from pathlib import Path

from shells.algorithms import continuation, settings, stability, switching
from shells.algorithms import newton as solvers
from shells.analyses.critical import run_surface
from shells.geometry.shapes import SphericalCap

CASES = {"cap30 up": (30.0, 3.0), "thetabar5 up": (math.degrees(1.0), 5.0)}


def count_run(theta_deg: float, kappa_r_end: float, factor_reuse: float | None) -> dict:
    count: Counter = Counter()
    per_step: list[int] = []
    real_lu, real_solve = solvers.setup_factor, solvers.NewtonSolver.solve
    real_setup, real_steps = stability.setup_factor, continuation.arclength_steps
    real_settings = settings.ContinuationSettings

    def lu(ksp, A, options):
        count["lu"] += 1
        return real_lu(ksp, A, options)

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


    solvers.setup_factor, solvers.NewtonSolver.solve = lu, solve
    stability.setup_factor, continuation.arclength_steps = setup, steps
    if factor_reuse is not None:
        def forced(**kw):  # noqa: ANN003, ANN202 - overrides the driver's own value
            return real_settings(**{**kw, "factor_reuse": factor_reuse})

        settings.ContinuationSettings = forced
    switching_steps = switching.arclength_steps
    switching.arclength_steps = steps
    try:
        t0 = time.perf_counter()
        r = run_surface(SphericalCap(1.0, math.radians(theta_deg)), 0.04, 0.5,
                             kappa_r_end, first_only=True)
        wall = time.perf_counter() - t0
    finally:
        solvers.setup_factor, solvers.NewtonSolver.solve = real_lu, real_solve
        stability.setup_factor, continuation.arclength_steps = real_setup, real_steps
        settings.ContinuationSettings = real_settings
        switching.arclength_steps = switching_steps
    in_steps = sum(per_step)
    return {"theta_deg": theta_deg, "dofs": r["dofs"], "kind": r["kind"],
            "kappa_R": r["kappa_R"], "steps": len(per_step), "lu_per_step": per_step,
            "mean_lu_per_step": in_steps / max(len(per_step), 1),
            "lu_locator_and_start": count["lu"] - in_steps, "snes_lu": count["snes_lu"],
            "ldlt": count["ldlt"], "wall_s": wall}


VERSIONS = {"before": 0.0, "after": None}  # factor_reuse (None: the driver's, REUSE_SURFACE)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("-o", default="benchmarks/results/lu_per_step.json")
    ap.add_argument("--cases", nargs="*", default=list(CASES), choices=list(CASES))
    a = ap.parse_args()
    rows: dict = {}
    for name in a.cases:
        th, kr = CASES[name]
        rows[name] = {v: count_run(th, kr, reuse) for v, reuse in VERSIONS.items()}
        b, f = rows[name]["before"], rows[name]["after"]
        rows[name]["kappa_rel_change"] = abs(f["kappa_R"] - b["kappa_R"]) / abs(b["kappa_R"])
        rows[name]["wall_ratio"] = f["wall_s"] / b["wall_s"]
        Path(a.o).write_text(json.dumps(rows, indent=1) + "\n")
    print(f"{'case':>14} {'version':>7} {'DOFs':>7} {'kind':>11} {'kappa R':>10} {'steps':>5} "
          f"{'LU/step':>7} {'LU other':>8} {'LDLT':>5} {'wall s':>7}")
    for name, rr in rows.items():
        for v in VERSIONS:
            r = rr[v]
            print(f"{name:>14} {v:>7} {r['dofs']:7d} {r['kind']:>11} {r['kappa_R']:10.6f} "
                  f"{r['steps']:5d} {r['mean_lu_per_step']:7.2f} "
                  f"{r['lu_locator_and_start']:8d} {r['ldlt']:5d} {r['wall_s']:7.1f}")
        print(f"{name:>14}   after/before wall {rr['wall_ratio']:.2f}, kappa changed by "
              f"{rr['kappa_rel_change']:.1e} (relative)")


if __name__ == "__main__":
    main()
