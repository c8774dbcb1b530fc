"""Critical slowing down of a snap (issue 41): the snap time T against ε = κ/κ_fold - 1.

The saddle-node normal form predicts T ∝ ε^(-1/4) without dissipation (ẍ = ε + x²) and
T ∝ ε^(-1/2) when damping dominates (ẋ = ε + x²). The case: the θ̄ = 3 cap at h/R = 0.04
(θ̄_s ≈ 2 < θ̄ < θ̄_c ≈ 3.85: its snap is axisymmetric, so the 1D model's dynamics are exact),
the 1D model with its default discretisation, on one rank. The branch is followed to its fold
κ_f (``CriticalSettings(stop_at_fold=True)``, located to 1e-9 relative); from the fold's state
at κ = (1 + ε) κ_f, at rest, ``shells.algorithms.dynamics.integrate`` runs

* undamped: no damping, ρ∞ = 1 (the trapezoidal rule: no numerical dissipation), a fixed
  step ``DT_UNDAMPED``;
* overdamped: mass-proportional damping α = ``ALPHA`` (C = α M), twenty times the lowest
  axisymmetric natural frequency of the unloaded cap (ω₀ = 1.01), ρ∞ = 1, adaptive steps.

The snap time T is the time at which the pole's normal displacement Ψ3(pole) crosses halfway
between the fold state's and the landing state's (the overdamped run's rest state at ε = 1e-2),
linearly interpolated between steps; the time of the kinetic energy's peak is reported beside
it. The exponents are fitted (least squares in log T against log ε) on each decade, and
T = a ε^p + b (the escape from the fold region plus an ε-independent travel time) on the
smallest decade and on all points.

    scripts/in-env python3 benchmarks/critical_slowing.py [--eps E ...] [--dt DT]

Writes benchmarks/results/critical_slowing.json and prints a table.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

OUT = Path("benchmarks/results/critical_slowing.json")
H_OVER_R = 0.04
THETABAR = 3.0
#: the mass-proportional damping of the overdamped runs (units √(E/ρ)/R)
ALPHA = 20.0
#: the fixed step of the undamped runs (units R √(ρ/E))
DT_UNDAMPED = 0.05
EPS = [1e-5, 2e-5, 5e-5, 1e-4, 2e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2]


def setup() -> tuple:
    """The 1D model of the case, its fold (κ_f, state) and ω₀ (the lowest m = 0 frequency at
    κ = 0)."""
    from mpi4py import MPI

    from shells.algorithms.following import follow
    from shells.algorithms.frequencies import KineticStability
    from shells.algorithms.newton import NewtonSolver
    from shells.algorithms.settings import CriticalSettings
    from shells.analyses.axisym_runs import RunConfig, default_settings, resolve_penalty
    from shells.axisym.model import SNES_OPTIONS, AxisymModel
    from shells.geometry.shapes import SphericalCap

    cfg = RunConfig(shape=SphericalCap(1.0, THETABAR * math.sqrt(H_OVER_R)), h_over_r=H_OVER_R,
                    m_max=0, rel_tol=1e-9)
    model = AxisymModel(cfg.shape, cfg.params(), comm=MPI.COMM_SELF)
    model.modes = (0,)
    resolve_penalty(model, cfg)
    st = KineticStability(model)
    vals, _ = st.eigenpairs(1, modes=False, block=None)
    st.destroy()
    ns = NewtonSolver(model, options=SNES_OPTIONS)
    fold = None
    for _, _, cps in follow(model, default_settings(cfg.shape, H_OVER_R), cfg.kappa_end,
                            CriticalSettings(rel_tol=1e-9, stop_at_fold=True), solver=ns,
                            blocks=(0,)):
        fold = next((c for c in cps if c.kind == "fold"), fold)
    ns.destroy()
    return model, fold, math.sqrt(vals[0])


def snap_run(model, fold, eps: float, damped: bool, x_half: float | None, dt: float) -> dict:
    """One run from the fold's state at (1 + eps) κ_f; stops once the pole has passed
    ``x_half`` and the kinetic energy has fallen below half its peak (or at rest)."""
    from shells.algorithms.dynamics import integrate
    from shells.algorithms.settings import DynamicsSettings
    from shells.problem.interface import set_state

    set_state(model, fold.state)
    model.set_kappa((1.0 + eps) * fold.kappa)
    e = model.pole_functional()
    xs: list[float] = []
    ks: list[float] = []

    def monitor(t, p, kinetic):
        xs.append(float(p.state.dot(e)))
        ks.append(kinetic)
        if x_half is None:  # to rest, well away from the fold
            return abs(xs[-1] - xs[0]) > 1.0 and kinetic < 1e-10
        return xs[-1] < x_half and kinetic < 0.5 * max(ks)

    if damped:
        s = DynamicsSettings(t_end=1e7, dt=dt * 10, mass_damping=ALPHA, adaptive=True)
    else:
        s = DynamicsSettings(t_end=1e5, dt=dt)
    t0 = time.perf_counter()
    r = integrate(model, s, monitor=monitor)
    wall = time.perf_counter() - t0
    t = np.array(r.times)
    x = np.array(xs)
    k = np.array(r.kinetic)
    out = {"eps": eps, "steps": r.steps, "reason": r.reason, "wall_s": wall,
           "x_start": float(x[0]), "x_end": float(x[-1]), "t_end": float(t[-1])}
    if x_half is None:  # the rest state polished by Newton: the landing equilibrium
        from shells.algorithms.newton import NewtonSolver

        ns = NewtonSolver(model)
        ok, _ = ns.solve()
        ns.destroy()
        out["x_end"] = float(model.state.dot(e))
        out["newton_converged"] = bool(ok)
        out["energy"] = model.total_energy()
    if x_half is not None:
        i = int(np.argmax(x < x_half))
        out["T_half"] = float(t[i - 1] + (x_half - x[i - 1]) / (x[i] - x[i - 1])
                              * (t[i] - t[i - 1]))
        j = int(np.argmax(k))
        if 0 < j < len(k) - 1:  # parabola through the peak's three samples
            a, b, c = k[j - 1], k[j], k[j + 1]
            out["T_peak"] = float(t[j] + 0.5 * (a - c) / (a - 2 * b + c) * (t[j + 1] - t[j]))
        else:
            out["T_peak"] = float(t[j])
    return out


def fits(rows: list[dict], key: str) -> dict:
    """Exponents: per decade (log-log least squares) and T = a ε^p + b."""
    from scipy.optimize import curve_fit

    eps = np.array([r["eps"] for r in rows])
    T = np.array([r[key] for r in rows])
    out: dict = {"decades": []}
    lo = eps.min()
    while lo * 10 <= eps.max() * (1 + 1e-9):
        sel = (eps >= lo * (1 - 1e-9)) & (eps <= 10 * lo * (1 + 1e-9))
        p = np.polyfit(np.log(eps[sel]), np.log(T[sel]), 1)[0]
        out["decades"].append({"eps": [float(lo), float(10 * lo)], "exponent": float(p)})
        lo *= 10
    for name, sel in (("smallest_decade", eps <= 10 * eps.min() * (1 + 1e-9)),
                      ("all", np.ones_like(eps, dtype=bool))):
        if sel.sum() < 4:
            continue
        p0 = (T[sel][0] * eps[sel][0] ** 0.375, -0.375, 0.0)
        try:
            (a, p, b), cov = curve_fit(lambda e, a, p, b: a * e**p + b, eps[sel], T[sel],
                                       p0=p0, maxfev=20000)
            out[f"offset_fit_{name}"] = {"a": float(a), "exponent": float(p), "b": float(b),
                                         "exponent_sd": float(math.sqrt(cov[1, 1]))}
        except RuntimeError as err:
            out[f"offset_fit_{name}"] = {"failed": str(err)}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--eps", type=float, nargs="*", default=EPS)
    ap.add_argument("--dt", type=float, default=DT_UNDAMPED)
    ap.add_argument("-o", "--output", type=Path, default=OUT)
    a = ap.parse_args()
    t0 = time.perf_counter()
    model, fold, omega0 = setup()
    t_fold = time.perf_counter() - t0
    print(f"fold at kappa R = {fold.kappa:.10f} (accuracy {fold.accuracy:.2g}), omega0 = "
          f"{omega0:.4f}, {model.num_dofs()} DOFs ({t_fold:.1f} s)")
    # the landing state: the overdamped run at the largest ε, to rest
    land = snap_run(model, fold, max(a.eps), True, None, a.dt)
    x_fold, x_land = land["x_start"], land["x_end"]
    x_half = 0.5 * (x_fold + x_land)
    print(f"pole displacement / h: fold {x_fold:.5f}, landing {x_land:.5f} (rest after "
          f"{land['t_end']:.1f}), halfway {x_half:.5f}")
    result = {"case": {"thetabar": THETABAR, "h_over_R": H_OVER_R, "model": "axisym",
                       "dofs": model.num_dofs(), "kappa_fold_R": fold.kappa,
                       "fold_accuracy": fold.accuracy, "omega0": omega0, "ranks": 1},
              "definition": "T: the time at which the pole's normal displacement Psi3(pole) "
                            "crosses halfway between the fold state's and the landing "
                            "state's (linear interpolation between steps); T_peak: the "
                            "kinetic energy's peak (parabola through three samples)",
              "pole_over_h": {"fold": x_fold, "landing": x_land, "half": x_half},
              "undamped": {"damping": 0.0, "rho_inf": 1.0, "dt": a.dt, "adaptive": False,
                           "prediction": -0.25, "runs": []},
              "overdamped": {"mass_damping": ALPHA, "alpha_over_omega0": ALPHA / omega0,
                             "rho_inf": 1.0, "adaptive": True, "prediction": -0.5,
                             "runs": []},
              "wall_s": {"fold": t_fold, "landing": land["wall_s"]}}
    for regime, damped in (("undamped", False), ("overdamped", True)):
        rows = result[regime]["runs"]
        for eps in sorted(a.eps):
            r = snap_run(model, fold, eps, damped, x_half, a.dt)
            rows.append(r)
            print(f"{regime:10s} eps {eps:8.1e}  T {r['T_half']:12.5f}  T_peak "
                  f"{r['T_peak']:12.5f}  steps {r['steps']:6d}  {r['wall_s']:6.1f} s",
                  flush=True)
        for key in ("T_half", "T_peak"):
            result[regime][f"fit_{key}"] = fits(rows, key)
        result["wall_s"][regime] = sum(r["wall_s"] for r in rows)
    result["wall_s"]["total"] = time.perf_counter() - t0
    a.output.parent.mkdir(parents=True, exist_ok=True)
    a.output.write_text(json.dumps(result, indent=1))
    print()
    print(f"{'eps':>9s} {'T undamped':>12s} {'T overdamped':>14s}")
    for ru, rd in zip(result["undamped"]["runs"], result["overdamped"]["runs"], strict=True):
        print(f"{ru['eps']:9.1e} {ru['T_half']:12.4f} {rd['T_half']:14.2f}")
    for regime in ("undamped", "overdamped"):
        f = result[regime]["fit_T_half"]
        dec = ", ".join(f"[{d['eps'][0]:.0e}, {d['eps'][1]:.0e}]: {d['exponent']:.4f}"
                        for d in f["decades"])
        print(f"{regime}: exponent per decade {dec}; T = a eps^p + b on the smallest decade: "
              f"p = {f.get('offset_fit_smallest_decade', {}).get('exponent', float('nan')):.4f}"
              f", on all: p = {f.get('offset_fit_all', {}).get('exponent', float('nan')):.4f}"
              f" (prediction {result[regime]['prediction']})")
    print(f"wall time {result['wall_s']['total']:.1f} s; {a.output}")


if __name__ == "__main__":
    main()
