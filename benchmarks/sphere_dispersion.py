"""Closed sphere: critical κh of each spherical-harmonic degree n, against the dispersion relation.

    scripts/in-env mpirun -n 2 python3 benchmarks/sphere_dispersion.py [--h-over-r 0.05]
        [--nu 0.5] [--size 0.1] [--kappa-h 1.2 1.9 15] [-o benchmarks/results/sphere_dispersion]

The fundamental (uniformly shrunk) branch is followed in κ on the surface model; at each κ the
lowest ``--nev`` eigenpairs of the Hessian (SLEPc, shift-and-invert at 0) are computed and each
eigenvector is assigned its degree n from x = R²∫|∇w|²/∫w² = n(n+1) (w: its normal component).
For every n, the lowest eigenvalue μ_n(κ) is interpolated to its zero: the computed critical κh of
that degree. Written to DIR/sphere_dispersion.json and plotted (DIR/sphere_dispersion.png/.pdf)
with the supplement's relation κh(x) — exact 2×2 determinant and its x ≫ 1 form.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

from shells.critical import ModeAnalysis
from shells.geometry import Sphere
from shells.mesh import MeshSpec, generate
from shells.model import ModelParameters, ShellModel
from shells.solvers import NewtonSolver
from shells.stability import Stability
from shells.theory import dispersion_kappa_h, sphere_kappa_b_h


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--h-over-r", type=float, default=0.05)
    ap.add_argument("--nu", type=float, default=0.5)
    ap.add_argument("--size", type=float, default=0.1)
    ap.add_argument("--nev", type=int, default=60)
    ap.add_argument("--kappa-h", type=float, nargs=3, default=[1.2, 1.9, 15],
                    metavar=("FROM", "TO", "N"))
    ap.add_argument("-o", default="benchmarks/results/sphere_dispersion")
    a = ap.parse_args()
    comm = MPI.COMM_WORLD
    h = a.h_over_r
    t0 = time.perf_counter()
    sm = generate(MeshSpec(Sphere(1.0), h=h, size=a.size), comm)
    model = ShellModel(sm, ModelParameters(h=h, nu=a.nu))
    ns, stab, modes = NewtonSolver(model), Stability(model), ModeAnalysis(model)
    khs = np.linspace(a.kappa_h[0], a.kappa_h[1], int(a.kappa_h[2]))
    table: dict[int, list[tuple[float, float]]] = {}
    for kh in khs:
        model.kappa.value = kh / h
        ok, _ = ns.solve()
        assert ok, kh
        vals, vecs = stab.eigenpairs(a.nev, modes=True)
        for lam, v in zip(vals, vecs, strict=True):
            n = modes.classify(modes(v))[1]
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


if __name__ == "__main__":
    main()
