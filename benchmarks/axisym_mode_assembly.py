"""Assembly of the 1D model's mode Hessians H_m: direct (the one mode form per m) against the
polynomial H_m = Σ m^k C_k (the five C_k assembled once per state, then MatAXPY and the
conditions), at a closed sphere's state near buckling, h/R = 0.002, ν = 1/2, with the run's
default discretisation and modes (309 cells, m = 0..62). On one process "polynomial" is now
the element-matrix path (``shells.axisym.chain``: H_m summed from tabulated element matrices,
definiteness and exact counts from their condensation); "direct" assembles every block.

Measures (median and minimum over repetitions, the two methods interleaved; wall time, so
other processes on a shared machine count: the minimum is the robust figure): the assembly of
every block m ≥ 1 per block, the C_k's assembly per state, a stability check over all blocks
(``Stability.negative_counts``: assembly + LDLᵀ inertia) at a new state each time, the largest
relative Frobenius difference polynomial vs direct over all m, whether the negative counts
agree, and ``shells.axisym.critical`` on that sphere (the run behind ``shells critical --shape
sphere --h-over-r 0.002 --model axisym --first-only``) with either assembly.
Writes JSON and prints a table.

    scripts/in-env python3 benchmarks/axisym_mode_assembly.py [OUT.json] [--repeats N]
"""

from __future__ import annotations

import json
import statistics
import sys
import time
from pathlib import Path
from typing import Any

from shells.algorithms.newton import NewtonSolver
from shells.algorithms.stability import Stability
from shells.analyses.axisym_runs import RunConfig, critical
from shells.axisym import SNES_OPTIONS, AxisymModel
from shells.geometry.shapes import Sphere
from shells.problem.forms import assemble_symmetric
from shells.theory import sphere_kappa_b_h

H_OVER_R, NU = 0.002, 0.5


def _direct(self: AxisymModel, block: Any, H: Any) -> None:
    """``AxisymModel.assemble_hessian`` as before: every block from its form."""
    if block is None:
        assemble_symmetric(H, self.hessian, self.bcs)
    else:
        self.mode_forms.assemble_hessian(block, H, direct=True)


def _stats(xs: list[float]) -> dict[str, float]:
    return {"median": statistics.median(xs), "min": min(xs)}


def _timed(f: Any) -> float:
    t0 = time.perf_counter()
    f()
    return time.perf_counter() - t0


def main(out: str = "benchmarks/results/axisym_mode_assembly.json", repeats: int = 5) -> None:
    cfg = RunConfig(Sphere(1.0), H_OVER_R, NU)
    model = AxisymModel(cfg.shape, cfg.params())
    model.modes = tuple(cfg.modes)
    blocks = model.stability_blocks()
    fourier = [m for m in blocks if m >= 1]
    ns = NewtonSolver(model, options=SNES_OPTIONS)
    kb = sphere_kappa_b_h(NU) / cfg.h
    for f in (0.3, 0.6, 0.9):  # a few load steps to 0.9 κ_b
        model.set_kappa(f * kb)
        assert ns.solve()[0]
    ns.destroy()
    mf = model.mode_forms
    t_compile = _timed(lambda: mf.coefficient_forms)  # JIT (cached after the first run)
    H, D = model.create_hessian(1), model.create_hessian(1)

    def new_state() -> None:  # what a new continuation point does to the C_k's caches
        mf.coefficient_inputs = None
        mf.element_inputs = None  # the element matrices (one process, ``shells.axisym.chain``)

    def poly_all() -> None:
        new_state()
        for m in fourier:
            model.assemble_hessian(m, H)

    def direct_all() -> None:
        for m in fourier:
            mf.assemble_hessian(m, D, direct=True)

    poly_all(), direct_all()  # warm-up
    t_poly, t_direct = [], []
    for _ in range(repeats):  # interleaved: a shared machine's load hits both alike
        t_poly.append(_timed(poly_all))
        t_direct.append(_timed(direct_all))
    t_coeff = []
    for _ in range(repeats):
        new_state()
        t_coeff.append(_timed(mf.coefficient_matrices))

    # largest difference over all m ≥ 1 (relative Frobenius norm)
    rel = 0.0
    for m in fourier:
        model.assemble_hessian(m, H)
        mf.assemble_hessian(m, D, direct=True)
        E = H.copy()
        E.axpy(-1.0, D)
        rel = max(rel, E.norm() / D.norm())
        E.destroy()

    # a stability check over all blocks, at a new state each time
    stab = Stability(model)
    stab.negative_counts(blocks)  # warm-up: matrices, symbolic factorisation

    direct = _direct.__get__(model)
    t_check_poly, t_check_direct = [], []
    counts: dict[str, Any] = {}
    for _ in range(repeats):
        for name, times in (("polynomial", t_check_poly), ("direct", t_check_direct)):
            if name == "direct":
                model.assemble_hessian = direct  # this instance only: the direct path,
                model.definite_blocks = lambda blocks, margin: None  # every block assembled
                model.condensed_hessian = lambda block: None
            else:
                for k in ("assemble_hessian", "definite_blocks", "condensed_hessian"):
                    vars(model).pop(k, None)
            new_state()
            t0 = time.perf_counter()
            counts[name] = stab.negative_counts(blocks)
            times.append(time.perf_counter() - t0)
    for k in ("assemble_hessian", "definite_blocks", "condensed_hessian"):
        vars(model).pop(k, None)
    counts_poly, counts_direct = counts["polynomial"], counts["direct"]
    stab.destroy()
    H.destroy()
    D.destroy()

    # the whole first-critical-point run, polynomial then direct (class-level switch)
    crit_times: dict[str, list[float]] = {"polynomial": [], "direct": []}
    crit_res: dict[str, Any] = {}
    names = ("assemble_hessian", "definite_blocks", "condensed_hessian")
    saved = {k: getattr(AxisymModel, k) for k in names}
    direct_methods = {"assemble_hessian": _direct,
                      "definite_blocks": lambda self, blocks, margin: None,
                      "condensed_hessian": lambda self, block: None}
    try:
        for _ in range(max(1, repeats // 2)):
            for name, times in crit_times.items():
                for k in names:
                    setattr(AxisymModel, k, direct_methods[k] if name == "direct" else saved[k])
                t0 = time.perf_counter()
                crit_res[name] = critical(Sphere(1.0), H_OVER_R, NU, "up", max_critical=1)
                times.append(time.perf_counter() - t0)
    finally:
        for k in names:
            setattr(AxisymModel, k, saved[k])
    crit = {name: {"wall_s": _stats(crit_times[name]), "kappa_h": r["kappa_h"],
                   "mode_n": r["mode_n"], "kind": r["kind"]} for name, r in crit_res.items()}

    n = len(fourier)
    res = {
        "case": {"shape": "sphere", "h_over_R": H_OVER_R, "nu": NU, "cells": cfg.n_cells,
                 "dofs_mode": int(mf.V.dofmap.index_map.size_global), "modes": len(blocks),
                 "m_max": max(blocks), "kappa_over_kappa_b": 0.9, "repeats": repeats},
        "coefficient_forms_compile_s": t_compile,
        "per_block_assembly_ms": {
            "direct": {k: 1e3 * v / n for k, v in _stats(t_direct).items()},
            "polynomial": {k: 1e3 * v / n for k, v in _stats(t_poly).items()}},
        "coefficients_per_state_ms": {k: 1e3 * v for k, v in _stats(t_coeff).items()},
        "all_blocks_assembly_s": {"direct": _stats(t_direct), "polynomial": _stats(t_poly)},
        "stability_check_s": {"direct": _stats(t_check_direct),
                              "polynomial": _stats(t_check_poly)},
        "max_rel_frobenius_difference": rel,
        "negative_counts_agree": counts_poly == counts_direct,
        "negative_count": sum(counts_poly.values()),
        "critical": crit,
    }
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    Path(out).write_text(json.dumps(res, indent=1))

    c = res["case"]
    print(f"sphere h/R = {H_OVER_R}, nu = {NU}: {c['cells']} cells, {c['dofs_mode']} DOFs per "
          f"mode, m = 0..{c['m_max']} ({c['modes']} blocks), state at 0.9 kappa_b; "
          f"medians (min) of {repeats}")
    pb, ck = res["per_block_assembly_ms"], res["stability_check_s"]
    rows = [("assembly per block m >= 1, ms", pb["direct"], pb["polynomial"]),
            (f"assembly of all {n} blocks m >= 1, s", res["all_blocks_assembly_s"]["direct"],
             res["all_blocks_assembly_s"]["polynomial"]),
            (f"stability check, all {c['modes']} blocks, s", ck["direct"], ck["polynomial"]),
            ("critical(sphere, 0.002), first point, s", crit["direct"]["wall_s"],
             crit["polynomial"]["wall_s"])]
    print(f"{'':42} {'direct':>17} {'polynomial':>17} {'ratio':>6}")
    for label, d, p in rows:
        print(f"{label:42} {d['median']:9.4g} ({d['min']:.4g}) {p['median']:9.4g} "
              f"({p['min']:.4g}) {d['median'] / p['median']:6.2f}")
    cs = res["coefficients_per_state_ms"]
    print(f"C_0..C_4 per state: {cs['median']:.3g} ms ({cs['min']:.3g}); their JIT (cached "
          f"or not): {t_compile:.2f} s")
    print(f"max relative Frobenius difference polynomial vs direct (m = 1..{c['m_max']}): "
          f"{rel:.2e}; negative counts agree: {res['negative_counts_agree']}; first critical "
          f"point: {crit['polynomial']['kappa_h']:.6f} (polynomial), "
          f"{crit['direct']['kappa_h']:.6f} (direct)")


if __name__ == "__main__":
    args = sys.argv[1:]
    reps = 5
    if "--repeats" in args:
        i = args.index("--repeats")
        reps = int(args[i + 1])
        del args[i:i + 2]
    main(*args, repeats=reps)
