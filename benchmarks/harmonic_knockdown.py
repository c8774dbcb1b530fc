"""Knock-down of the closed sphere's curvature buckling by a non-axisymmetric imperfection on the
surface model (issue 15): the reference surface displaced along the radius by w0 = -δ h
P_n^m(cos θ) cos(mφ) / max|P_n^m| (``shells.geometry.imperfections.HarmonicImperfectSphere``), n the
perfect sphere's critical degree, against the axisymmetric m = 0 (the mode's shape P_n) at the
same amplitudes, on the same mesh and code path (``shells.analyses.knockdown.surface_first``: the
first critical point of any kind, with the full Hessian's inertia), and the 1D model's knock-down by
the axisymmetric mode (rotational symmetry enforced) beside them.

    OMP_NUM_THREADS=1 scripts/in-env python3 benchmarks/harmonic_knockdown.py
        [--h-over-r 0.05] [--nu 0.5] [--degree 9] [--orders 0 2]
        [--amplitudes 0.01 0.03 0.1] [--size 0.21]

Each surface-model point (perfect sphere, and every (m, δ/h)) is stored in
``benchmarks/results/harmonic_knockdown.json`` as it is computed and read back by a rerun of the
same configuration (h/R, ν, n, mesh size, element degree); prints the table.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time
from pathlib import Path

from mpi4py import MPI

from shells.analyses import knockdown
from shells.analyses.knockdown import KnockdownConfig, surface_first

JSON = Path(__file__).parent / "results" / "harmonic_knockdown.json"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--h-over-r", type=float, default=0.05)
    ap.add_argument("--nu", type=float, default=0.5)
    ap.add_argument("--degree", type=int, default=9, help="the harmonic's n (default 9: the "
                    "critical degree of h/R = 0.05, nu = 1/2)")
    ap.add_argument("--orders", type=int, nargs="+", default=[0, 2], help="the orders m")
    ap.add_argument("--amplitudes", type=float, nargs="+", default=[0.01, 0.03, 0.1])
    ap.add_argument("--size", type=float, default=0.21, help="bulk element size (default "
                    "0.21, the surface model's default for spheres)")
    a = ap.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    comm = MPI.COMM_WORLD
    n = a.degree
    base = KnockdownConfig(a.h_over_r, tuple(a.amplitudes), nu=a.nu, imperfection="harmonic",
                           model="surface", degree=n, size=a.size)
    key = f"h{a.h_over_r:g}_nu{a.nu:g}_n{n}_size{base.size:g}_P{base.element_degree}"
    runs = json.loads(JSON.read_text()) if JSON.exists() else {}
    run = runs.get(key) or {"h_over_r": a.h_over_r, "nu": a.nu, "degree": n,
                            "size": base.size, "element_degree": base.element_degree,
                            "ranks": comm.size, "points": {}}

    def save() -> None:
        runs[key] = run
        if comm.rank == 0:
            JSON.parent.mkdir(parents=True, exist_ok=True)
            JSON.write_text(json.dumps(runs, indent=1) + "\n")

    def point(name: str, cfg: KnockdownConfig, delta: float) -> dict:
        if name not in run["points"]:
            t0 = time.perf_counter()
            r = surface_first(cfg, delta, n)
            r["wall_s"] = time.perf_counter() - t0
            run["points"][name] = r
            save()
            if comm.rank == 0:
                print(f"  {name}: {r['kind']} at kappa h = {r['kappa_h']:.6f} "
                      f"({r['wall_s']:.0f} s)", flush=True)
        return run["points"][name]

    perfect = point("perfect", base, 0.0)
    kb = perfect["kappa_h"]
    for m in a.orders:
        cfg = KnockdownConfig(a.h_over_r, tuple(a.amplitudes), nu=a.nu, imperfection="harmonic",
                              model="surface", degree=n, order=m, size=a.size)
        for d in a.amplitudes:
            r = point(f"m{m}_delta{d:g}", cfg, d)
            r["knockdown"] = r["kappa_h"] / kb
    # the 1D model's axisymmetric mode P_n (its own κ_b), for reference (seconds)
    oned = knockdown.run(KnockdownConfig(a.h_over_r, tuple(a.amplitudes), nu=a.nu,
                                         imperfection="mode", degree=n), None, figure=False)
    run["axisym_mode"] = {"kappa_b_h": oned["kappa_b_h"],
                          "points": {f"{p['delta_over_h']:g}": p["knockdown"]
                                     for p in oned["points"]}}
    save()
    if comm.rank == 0:
        print(f"closed sphere h/R = {a.h_over_r:g}, nu = {a.nu:g}, harmonic n = {n}, surface "
              f"model P{base.element_degree} size {base.size:g} ({perfect.get('dofs')} DOFs): "
              f"perfect {perfect['kind']} at kappa_b h = {kb:.6f}")
        head = " ".join(f"{'m = ' + str(m):>22}" for m in a.orders)
        print(f"{'delta/h':>8} {head} {'1D mode (m = 0)':>16}")
        for d in a.amplitudes:
            cols = []
            for m in a.orders:
                r = run["points"][f"m{m}_delta{d:g}"]
                cols.append(f"{r['kind']:>11} {r['knockdown']:.5f}" + (
                    f" m{r['mode_m']}" if r.get("mode_m") is not None else "   "))
            print(f"{d:8g} {' '.join(f'{c:>22}' for c in cols)} "
                  f"{run['axisym_mode']['points'][f'{d:g}']:16.5f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
