"""Closed sphere: critical κh of each spherical-harmonic degree n, against the dispersion relation.

    scripts/in-env python3 benchmarks/sphere_dispersion.py [--model axisym] [--h-over-r 0.05 0.002]
        [--nu 0.5] [--spread 0.2] [--refine 2] [-o benchmarks/results/sphere_dispersion]
    scripts/in-env mpirun -n 2 python3 benchmarks/sphere_dispersion.py --model surface
        [--h-over-r 0.05] [--size 0.1] [--kappa-h 1.2 1.9 15]

The supplement's stability analysis of the uniformly shrunk sphere gives, per degree n
(x = n(n+1)), the κh at which the degree-n perturbation is neutral: the smallest positive root of a
2×2 determinant (``shells.theory.dispersion_kappa_h``). Both routes compute that κh per degree.

``--model axisym`` (default; 1D shell-of-revolution model, ``shells.axisym``). The state is the
exact homogeneous one, the uniformly shrunk sphere of radius λR with λ(λ² - 1) = (h²/6R)((1-λ)/R
- κ) (``shells.theory.sphere_radius_ratio``; the Kirchhoff-Love state, u interpolated in P3 and
the slope field p = ∂_t u in P2), and H_0, the Hessian of the axisymmetric Fourier block m = 0, is
assembled there. The block m holds the degrees n ≥ m, each once (P_n^m(cos t)), so in the m = 0
block every degree has its own, simple eigenvalue: the number of negative eigenvalues N_0(κ)
(MUMPS LDLᵀ inertia, exact) counts the degrees with κ_c(n) < κ. The k-th crossing (N_0 reaches k)
is bracketed on a κ grid and bisected to 1e-9 relative; its degree is read off the eigenvector of
the eigenvalue nearest 0 there (shift-invert at 0): the Legendre content of its normal component
w(t) = U sin t + W cos t, c_n ∝ ∫ w P_n(cos t) sin t dt; the degree holding most of ∫ w² sin t dt
(its share is reported as ``purity``), P_1 left out: the gauge W = 0 at the top pole adds a rigid
z-translation, w = c cos t, to every mode. Each crossing must carry a different degree (checked).
The range is κh up to (1 + ``--spread``) times the determinant's minimum; ``--refine F`` repeats
the run with F times the cells and reports the change per degree (the discretisation error).
The state is not the discrete model's equilibrium (that differs by O(1/penalty) in the slope
field, and near an even-n crossing is slightly perturbed by the discretisation, which breaks the
sphere's symmetry): H_0 at the exact state is the discretised stability operator of exactly the
state that the dispersion relation is about. ``shells.axisym.critical`` (the branch followed
from κ = 0 with every block's inertia) is run alongside as a check of the first crossing.

``--model surface`` (2D mesh, 2 ranks): the fundamental branch on a κ grid; the lowest ``--nev``
eigenpairs of the Hessian (SLEPc, shift-and-invert at 0), each eigenvector assigned its degree
from x = R²∫|∇w|²/∫w² = n(n+1) (w: its normal component); for every n the lowest eigenvalue is
interpolated to its zero. Coarse: it finds only a few degrees, with errors of several %.

Written to DIR/sphere_dispersion_axisym.json (or DIR/sphere_dispersion.json for the surface
model) and plotted (.png/.pdf) with the supplement's relation κh(x): exact 2×2 determinant and
its x ≫ 1 form.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path
from typing import Any

import numpy as np
from mpi4py import MPI

from shells.geometry.shapes import Sphere
from shells.theory import dispersion_kappa_h, sphere_kappa_b_h, sphere_radius_ratio


# ------------------------------------------------------------------------------------------------
# the 1D (axisymmetric) route
# ------------------------------------------------------------------------------------------------
class HomogeneousSphere:
    """The m = 0 Hessian of the axisymmetric model at the exact uniformly shrunk sphere."""

    def __init__(self, h: float, nu: float, cells: int, penalty: float = 1.0e4) -> None:
        from shells.algorithms.stability import Stability
        from shells.axisym import AxisymModel, AxisymParameters

        self.h, self.nu = h, nu
        self.model = AxisymModel(Sphere(1.0), AxisymParameters(h=h, nu=nu, cells=cells,
                                                               penalty=penalty),
                                 comm=MPI.COMM_SELF)
        self.model.modes = (0,)
        self.stab = Stability(self.model)
        self.forms = self.model.mode_forms
        V = self.forms.V
        self._comp = {}
        for name, i in (("U", 0), ("W", 2)):
            sub, dofs = V.sub(0).sub(i).collapse()
            t = sub.tabulate_dof_coordinates()[:, 0]
            order = np.argsort(t)
            self._comp[name] = (t[order], np.asarray(dofs)[order])
        self.evaluations = 0

    def set_state(self, kappa_h: float) -> None:
        """u = (λ - 1) R (sin t, cos t - 1) (the gauge u_z = 0 at the top pole), p = ∂_t u."""
        m = self.model
        d = sphere_radius_ratio(kappa_h / self.h, self.h) - 1.0
        m.w.sub(0).interpolate(lambda x: np.vstack([d * np.sin(x[0]), d * (np.cos(x[0]) - 1)]))
        m.w.sub(1).interpolate(lambda x: np.vstack([d * np.cos(x[0]), -d * np.sin(x[0])]))
        m.w.x.scatter_forward()
        m.kappa.value = kappa_h / self.h

    def count(self, kappa_h: float) -> int:
        """N_0(κ): negative eigenvalues of H_0 at the homogeneous state."""
        self.set_state(kappa_h)
        self.evaluations += 1
        return self.stab.negative_count(0)

    def mode(self, kappa_h: float) -> tuple[float, np.ndarray]:
        """(μ, v): the eigenpair of H_0 v = μ M v nearest 0 (M: the L² mass on dω)."""
        import scipy.sparse as sp
        from dolfinx.fem.petsc import assemble_matrix
        from scipy.sparse.linalg import eigsh

        self.set_state(kappa_h)
        bcs = self.forms.conditions(0)
        H = self.stab.assemble(0)
        M = assemble_matrix(self.forms.mass, bcs=bcs, diagonal=1.0)
        M.assemble()

        def csr(A: Any) -> Any:
            ai, aj, av = A.getValuesCSR()
            return sp.csr_matrix((av, aj, ai), shape=A.getSize())

        Hs, Ms = csr(H), csr(M)
        M.destroy()
        fixed = np.unique(np.concatenate([bc.dof_indices()[0] for bc in bcs]))
        keep = np.setdiff1d(np.arange(Hs.shape[0]), fixed)
        Hk, Mk = Hs[keep][:, keep].tocsc(), Ms[keep][:, keep].tocsc()
        mu, vec = eigsh(Hk, k=1, M=Mk, sigma=0.0, which="LM")
        v = np.zeros(Hs.shape[0])
        v[keep] = vec[:, 0]
        return float(mu[0]), v

    def legendre_content(self, v: np.ndarray, n_max: int) -> np.ndarray:
        """Shares of P_0..P_{n_max} in ∫ w² sin t dt, w = U sin t + W cos t (m = 0: U = S)."""
        tU, dU = self._comp["U"]
        tW, dW = self._comp["W"]
        t = np.linspace(0.0, math.pi, 40001)
        w = np.interp(t, tU, v[dU]) * np.sin(t) + np.interp(t, tW, v[dW]) * np.cos(t)
        wt = np.sin(t) * np.gradient(t)  # trapezoid-like weights of ∫ . sin t dt
        total = float(np.sum(w * w * wt))
        c = np.cos(t)
        shares = np.empty(n_max + 1)
        p_prev, p = np.zeros_like(c), np.ones_like(c)  # P_{-1}, P_0; Bonnet's recursion
        for n in range(n_max + 1):
            cn = (2 * n + 1) / 2 * float(np.sum(w * p * wt))
            shares[n] = cn * cn * 2 / (2 * n + 1) / total
            p_prev, p = p, ((2 * n + 1) * c * p - n * p_prev) / (n + 1)
        return shares

    def destroy(self) -> None:
        self.stab.destroy()


def crossings(hs: HomogeneousSphere, kh_lo: float, kh_hi: float, grid: int,
              rel_tol: float = 1e-9) -> dict[str, Any]:
    """Every crossing of H_0 in (kh_lo, kh_hi]: location, eigenvalue nearest 0, degree."""
    ks = np.linspace(kh_lo, kh_hi, grid)
    counts = [hs.count(k) for k in ks]
    if counts[0] != 0:
        raise RuntimeError(f"H_0 has {counts[0]} negative eigenvalues at kappa h = {kh_lo}")
    monotone = all(b >= a for a, b in zip(counts, counts[1:], strict=False))
    n_max = int(4 * math.sqrt(kh_hi / hs.h * 3)) + 20  # well beyond the unstable degrees
    rows = []
    for k in range(1, counts[-1] + 1):
        i = next(j for j, c in enumerate(counts) if c >= k)
        lo, hi = float(ks[i - 1]), float(ks[i])
        while hi - lo > rel_tol * hi:
            mid = 0.5 * (lo + hi)
            if hs.count(mid) >= k:
                hi = mid
            else:
                lo = mid
        mu, v = hs.mode(hi)
        shares = hs.legendre_content(v, n_max)
        # the gauge W = 0 at the top pole adds a z-translation, w = c cos t = c P_1: not a mode
        rigid = float(shares[1])
        shares[1] = 0.0
        shares /= shares.sum()
        n = int(np.argmax(shares))
        second = float(np.sort(shares)[-2])
        rows.append({"crossing": k, "n": n, "kappa_h": 0.5 * (lo + hi), "bracket": [lo, hi],
                     "mu_at_hi": mu, "purity": float(shares[n]), "next_share": second,
                     "translation_share": rigid})
    return {"grid_counts": counts, "grid_kappa_h": ks.tolist(), "monotone": monotone,
            "rows": rows}


def axisym_case(h: float, nu: float, spread: float, grid: int, refine: int,
                cells: int | None) -> dict[str, Any]:
    from shells.analyses.axisym_runs import critical, default_cells

    t0 = time.perf_counter()
    ns_det = np.arange(2, int(8 / math.sqrt(h)) + 10)
    det = dispersion_kappa_h(ns_det * (ns_det + 1.0), h, nu)
    kh_min = float(np.nanmin(det))
    kh_lo, kh_hi = 0.8 * kh_min, (1.0 + spread) * kh_min
    n_cells = cells or default_cells(Sphere(1.0), h)
    runs = {}
    for c in sorted({n_cells, refine * n_cells} if refine > 1 else {n_cells}):
        t1 = time.perf_counter()
        hs = HomogeneousSphere(h, nu, c)
        res = crossings(hs, kh_lo, kh_hi, grid)
        if MPI.COMM_WORLD.rank == 0:
            print(f"h/R = {h}, {c} cells: {len(res['rows'])} crossings, "
                  f"{time.perf_counter() - t1:.0f} s", flush=True)
        res["cells"], res["evaluations"] = c, hs.evaluations
        res["wall_time"] = time.perf_counter() - t1
        hs.destroy()
        degrees = [r["n"] for r in res["rows"]]
        if len(set(degrees)) != len(degrees):
            raise RuntimeError(f"h/R = {h}, {c} cells: a degree crossed twice: {degrees}")
        runs[c] = res
    base, fine = runs[n_cells], runs[max(runs)]
    fine_by_n = {r["n"]: r["kappa_h"] for r in fine["rows"]}
    rows = []
    for r in sorted(base["rows"], key=lambda r: r["n"]):
        n = r["n"]
        d = float(dispersion_kappa_h(n * (n + 1.0), h, nu))
        rows.append({**r, "x": n * (n + 1), "det_exact": d,
                     "det_paper": float(dispersion_kappa_h(n * (n + 1.0), h, nu, exact=False)),
                     "diff": r["kappa_h"] - d, "rel_diff": r["kappa_h"] / d - 1,
                     "refined": fine_by_n.get(n) if max(runs) != n_cells else None})
    first = critical(Sphere(1.0), h, nu, "up")
    n_min = int(ns_det[int(np.nanargmin(det))])
    return {"h_over_R": h, "nu": nu, "model": "axisym", "cells": n_cells,
            "kappa_h_range": [kh_lo, kh_hi], "rows": rows,
            "runs": {str(c): r for c, r in runs.items()},
            "det_minimum": {"n": n_min, "kappa_h": kh_min},
            "computed_minimum": min(({"n": r["n"], "kappa_h": r["kappa_h"]} for r in rows),
                                    key=lambda r: r["kappa_h"]),
            "critical_on_branch": {"kappa_h": first["kappa_h"], "mode_n": first["mode_n"],
                                   "mode_m": first["mode_m"], "dofs": first["dofs"]},
            "thin_limit": sphere_kappa_b_h(nu), "wall_time": time.perf_counter() - t0}


def axisym_route(a: argparse.Namespace) -> None:
    hs_ = a.h_over_r or [0.05, 0.002]
    out = Path(a.o)
    cases = [axisym_case(h, a.nu, a.spread, a.grid, a.refine, a.cells) for h in hs_]
    if MPI.COMM_WORLD.rank != 0:
        return
    out.mkdir(parents=True, exist_ok=True)
    (out / "sphere_dispersion_axisym.json").write_text(json.dumps(cases, indent=1))
    for c in cases:
        fine = max(int(k) for k in c["runs"])
        print(f"\nsphere h/R = {c['h_over_R']}, nu = {c['nu']}, axisym model, {c['cells']} cells"
              f" (refined: {fine}); H_0 at the exact shrunk sphere, {c['wall_time']:.0f} s")
        print(f"{'n':>3} {'x':>5} {'computed':>9} {'exact det':>9} {'diff':>8} {'rel':>8} "
              f"{'refined':>9} {'purity':>6} {'x>>1':>8}")
        for r in c["rows"]:
            ref = f"{r['refined']:9.5f}" if r["refined"] is not None else f"{'-':>9}"
            print(f"{r['n']:3d} {r['x']:5d} {r['kappa_h']:9.5f} {r['det_exact']:9.5f} "
                  f"{r['diff']:+8.5f} {r['rel_diff']:+8.2%} {ref} {r['purity']:6.3f} "
                  f"{r['det_paper']:8.5f}")
        cm, dm, cb = c["computed_minimum"], c["det_minimum"], c["critical_on_branch"]
        print(f"minimum: computed {cm['kappa_h']:.5f} (n = {cm['n']}), determinant "
              f"{dm['kappa_h']:.5f} (n = {dm['n']}), thin limit {c['thin_limit']:.5f}; "
              f"axisym_runs.critical on the branch: {cb['kappa_h']:.5f} (n = {cb['mode_n']})")
    plot_axisym(cases, out)


def plot_axisym(cases: list[dict[str, Any]], out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, len(cases), figsize=(5.5 * len(cases), 6.5), squeeze=False,
                             gridspec_kw={"height_ratios": [3, 1.4]})
    for j, c in enumerate(cases):
        h, nu, rows = c["h_over_R"], c["nu"], c["rows"]
        ax, bx = axes[0, j], axes[1, j]
        xs = np.array([r["x"] for r in rows], dtype=float)
        x = np.linspace(0.6 * xs.min(), 1.4 * xs.max(), 800)
        ax.plot(x, dispersion_kappa_h(x, h, nu), "k-", lw=1, label="2×2 determinant (supplement)")
        ax.plot(x, dispersion_kappa_h(x, h, nu, exact=False), "k--", lw=0.8, label="x ≫ 1 form")
        ax.plot(xs, [r["det_exact"] for r in rows], "k+", ms=6, label="determinant at integer n")
        ax.axhline(c["thin_limit"], color="gray", lw=0.8, ls=":", label="thin limit κ_b h")
        ax.plot(xs, [r["kappa_h"] for r in rows], "o", color="C3", ms=4,
                label=f"1D model, H_0 crossings ({c['cells']} cells)")
        for r in rows:
            if len(rows) <= 14 or r["n"] % 2 == 0:
                ax.annotate(str(r["n"]), (r["x"], r["kappa_h"]), textcoords="offset points",
                            xytext=(2, -9), fontsize=7, color="C3")
        lo = min(r["kappa_h"] for r in rows)
        hi = max(r["kappa_h"] for r in rows)
        ax.set_ylim(lo - 0.12 * (hi - lo), hi + 0.08 * (hi - lo))
        ax.set_xlim(x[0], x[-1])
        ax.set_xlabel("x = n(n+1)")
        ax.set_ylabel("critical κh")
        ax.set_title(f"closed sphere, h/R = {h}, ν = {nu}")
        ax.legend(fontsize=7, loc="lower right")
        bx.plot([r["n"] for r in rows], [100 * r["rel_diff"] for r in rows], "o-", color="C3",
                ms=3, lw=0.8)
        bx.axhline(0, color="k", lw=0.6)
        bx.set_xlabel("degree n")
        bx.set_ylabel("1D / det − 1 (%)")
    fig.tight_layout()
    fig.savefig(out / "sphere_dispersion_axisym.png", dpi=150)
    fig.savefig(out / "sphere_dispersion_axisym.pdf")


# ------------------------------------------------------------------------------------------------
# the surface route
# ------------------------------------------------------------------------------------------------
def surface_route(a: argparse.Namespace) -> None:
    """The surface model: SLEPc eigenpairs along the branch, degrees by Rayleigh quotient."""
    from shells.algorithms.newton import NewtonSolver
    from shells.algorithms.stability import Stability
    from shells.surface.mesh import MeshSpec, generate
    from shells.surface.model import ModelParameters, ShellModel

    comm = MPI.COMM_WORLD
    h = a.h_over_r[0] if a.h_over_r else 0.05
    kappa_h = a.kappa_h or [1.2, 1.9, 15]
    t0 = time.perf_counter()
    sm = generate(MeshSpec(Sphere(1.0), h=h, size=a.size), comm)
    model = ShellModel(sm, ModelParameters(h=h, nu=a.nu))
    ns, stab = NewtonSolver(model), Stability(model)
    khs = np.linspace(kappa_h[0], kappa_h[1], int(kappa_h[2]))
    table: dict[int, list[tuple[float, float]]] = {}
    for kh in khs:
        model.kappa.value = kh / h
        ok, _ = ns.solve()
        assert ok, kh
        vals, vecs = stab.eigenpairs(a.nev, modes=True)
        for lam, v in zip(vals, vecs, strict=True):
            n = model.classify_mode(v).n
            cur = table.setdefault(n, [])
            # keep the lowest eigenvalue of each degree at this κ
            if cur and cur[-1][0] == kh:
                cur[-1] = (kh, min(cur[-1][1], lam))
            else:
                cur.append((kh, lam))
        if comm.rank == 0:
            print(f"kappa h = {kh:.4f}: lowest {vals[0]:+.3e}  ({time.perf_counter() - t0:.0f} s)",
                  flush=True)
    crit = {}
    for n, rows in sorted(table.items()):
        k = np.array([r[0] for r in rows])
        mu = np.array([r[1] for r in rows])
        idx = np.where((mu[:-1] > 0) & (mu[1:] <= 0))[0]
        if idx.size and len(k) == len(khs):
            i = idx[0]
            crit[n] = float(k[i] + mu[i] * (k[i + 1] - k[i]) / (mu[i] - mu[i + 1]))
    if comm.rank != 0:
        return
    out = Path(a.o)
    out.mkdir(parents=True, exist_ok=True)
    res = {"h_over_R": h, "nu": a.nu, "size": a.size, "dofs": model.num_dofs(),
           "critical_kappa_h_by_n": {str(n): v for n, v in crit.items()},
           "theory_exact": {str(n): float(dispersion_kappa_h(n * (n + 1), h, a.nu))
                            for n in crit},
           "theory_paper": {str(n): float(dispersion_kappa_h(n * (n + 1), h, a.nu, exact=False))
                            for n in crit},
           "thin_limit": sphere_kappa_b_h(a.nu), "wall_time": time.perf_counter() - t0}
    (out / "sphere_dispersion.json").write_text(json.dumps(res, indent=1))
    print(f"\nsphere h/R = {h}, nu = {a.nu}, mesh size {a.size} ({model.num_dofs()} DOFs)")
    print(f"{'n':>3} {'x':>6} {'computed':>10} {'exact det':>10} {'paper':>10}")
    for n, v in crit.items():
        print(f"{n:3d} {n * (n + 1):6d} {v:10.4f} {res['theory_exact'][str(n)]:10.4f} "
              f"{res['theory_paper'][str(n)]:10.4f}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = np.linspace(6, 300, 600)
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(x, dispersion_kappa_h(x, h, a.nu), "k-", label="2×2 determinant (supplement)")
    ax.plot(x, dispersion_kappa_h(x, h, a.nu, exact=False), "k--", label="x ≫ 1 form")
    ax.axhline(sphere_kappa_b_h(a.nu), color="gray", lw=0.8, ls=":", label="thin limit κ_b h")
    ns_ = sorted(crit)
    ax.plot([n * (n + 1) for n in ns_], [crit[n] for n in ns_], "o", color="C3",
            label=f"surface model, size {a.size}")
    for n in ns_:
        ax.annotate(str(n), (n * (n + 1), crit[n]), textcoords="offset points", xytext=(3, 4),
                    fontsize=7)
    ax.set_xlabel("x = n(n+1)")
    ax.set_ylabel("critical κh")
    ax.set_title(f"closed sphere, h/R = {h}, ν = {a.nu}")
    ax.set_ylim(1.3, 2.2)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "sphere_dispersion.png", dpi=150)
    fig.savefig(out / "sphere_dispersion.pdf")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", choices=("axisym", "surface"), default="axisym",
                    help="axisym (1D model, default) or surface (2D mesh, coarse)")
    ap.add_argument("--h-over-r", type=float, nargs="+", default=None,
                    help="axisym: one or more (default 0.05 0.002); surface: one (0.05)")
    ap.add_argument("--nu", type=float, default=0.5)
    ap.add_argument("--spread", type=float, default=0.2,
                    help="axisym: degrees up to (1 + spread) x the determinant's minimum")
    ap.add_argument("--grid", type=int, default=60, help="axisym: κ grid of the bracketing scan")
    ap.add_argument("--refine", type=int, default=2,
                    help="axisym: also run with this many times the cells (1: no)")
    ap.add_argument("--cells", type=int, default=None,
                    help="axisym: cells (default: shells.axisym.default_cells)")
    ap.add_argument("--size", type=float, default=0.1, help="surface: mesh size")
    ap.add_argument("--nev", type=int, default=60, help="surface: eigenpairs per point")
    ap.add_argument("--kappa-h", type=float, nargs=3, default=None,
                    metavar=("FROM", "TO", "N"), help="surface: κh grid (1.2 1.9 15)")
    ap.add_argument("-o", default="benchmarks/results/sphere_dispersion")
    a = ap.parse_args()
    if a.model == "axisym":
        axisym_route(a)
    else:
        surface_route(a)


if __name__ == "__main__":
    main()
