"""Cost of the surface model's building blocks, per mesh: Newton, continuation, LU, inertia, SLEPc.

    scripts/in-env mpirun -n 2 python3 benchmarks/solver_performance.py [--levels 1 2 3]
        [-o benchmarks/results/solver_performance.json]

Mesh level k: bulk size 0.2/k R and 4k elements across sqrt(R h) at the rim (the small cap is
mostly rim layer, so the bulk size alone barely changes it).

Problem: spherical cap θ = 30°, h/R = 0.04 (rim layer refined), ν = 1/2, at κR = 1 (a deformed
state). For each mesh: DOFs; one Hessian assembly; one MUMPS LU factorisation (the unit of cost);
one Newton solve from the κR = 0.9 state (time per iteration); one pseudo-arclength step; one
inertia evaluation (MUMPS LDLᵀ); one SLEPc solve for the 4 eigenvalues nearest 0. Times are the
maximum over ranks, best of ``--repeat``.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

from mpi4py import MPI

from shells.algorithms.continuation import continuation
from shells.algorithms.newton import NewtonSolver
from shells.algorithms.settings import ContinuationSettings
from shells.algorithms.stability import Stability
from shells.geometry.shapes import SphericalCap
from shells.surface.mesh import MeshSpec, generate
from shells.surface.model import ModelParameters, ShellModel


def timed(comm, fn, repeat: int = 1) -> tuple[float, object]:
    best, out = math.inf, None
    for _ in range(repeat):
        comm.barrier()
        t0 = time.perf_counter()
        out = fn()
        dt = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
        best = min(best, dt)
    return best, out


def measure(level: int, repeat: int) -> dict:
    comm = MPI.COMM_WORLD
    h = 0.04
    shape = SphericalCap(1.0, math.radians(30))
    size, layer = 0.2 / level, 4.0 * level
    sm = generate(MeshSpec(shape, h=h, size=size, layer_elements=layer), comm)
    model = ShellModel(sm, ModelParameters(h=h, nu=0.5))
    ns = NewtonSolver(model)
    out: dict = {"level": level, "size": size, "layer_elements": layer,
                 "dofs": model.num_dofs(), "ranks": comm.size}
    # natural continuation up to the state the timings start from
    pts = list(continuation(model, ContinuationSettings(method="natural", ds=0.1, ds_max=0.1),
                            kappa_end=0.9, solver=ns))
    assert abs(pts[-1].kappa - 0.9) < 1e-12
    w09 = model.w.x.array.copy()
    out["assemble_hessian_s"], _ = timed(comm, lambda: ns.assemble_jacobian(ns.A), repeat)
    out["lu_factorisation_s"], _ = timed(comm, ns.factor, repeat)

    def newton() -> int:
        model.w.x.array[:] = w09
        model.w.x.scatter_forward()
        model.kappa.value = 1.0
        ok, its = ns.solve()
        assert ok
        return its

    t, its = timed(comm, newton, repeat)
    out["newton_solve_s"], out["newton_its"] = t, its
    out["time_per_newton_it_s"] = t / its

    def step() -> float:
        model.w.x.array[:] = w09
        model.w.x.scatter_forward()
        st = ContinuationSettings(ds=0.1, ds_max=0.1)
        gen = continuation(model, st, kappa_start=0.9, kappa_end=2.0, solver=ns)
        next(gen)  # the start point
        t0 = time.perf_counter()
        p = next(gen)
        gen.close()
        return time.perf_counter() - t0 + 0 * p.kappa

    out["continuation_step_s"], _ = timed(comm, step, repeat)
    stab = Stability(model)
    newton()
    out["inertia_s"], inertia = timed(comm, stab.inertia, repeat)
    out["negative_count"] = inertia[0]
    out["slepc_4_eigenpairs_s"], vals = timed(
        comm, lambda: stab.eigenpairs(4, assemble=False), repeat)
    out["lowest_eigenvalues"] = vals[0] if isinstance(vals, tuple) else vals
    stab.destroy()
    ns.destroy()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("-o", default="benchmarks/results/solver_performance.json")
    a = ap.parse_args()
    comm = MPI.COMM_WORLD
    rows = []
    for lev in a.levels:
        rows.append(measure(lev, a.repeat))
        if comm.rank == 0:
            Path(a.o).parent.mkdir(parents=True, exist_ok=True)
            Path(a.o).write_text(json.dumps({"runs": rows}, indent=1))
    if comm.rank:
        return
    print(f"\ncap 30 deg, h/R = 0.04, kappa R = 1, {comm.size} rank(s); times in s "
          "(max over ranks)")
    cols = ["dofs", "assemble_hessian_s", "lu_factorisation_s", "time_per_newton_it_s",
            "newton_its", "continuation_step_s", "inertia_s", "slepc_4_eigenpairs_s"]
    print(" ".join(f"{c[:14]:>14}" for c in cols))
    for r in rows:
        print(" ".join(f"{r[c]:14.3f}" if isinstance(r[c], float) else f"{r[c]:14d}"
                       for c in cols))


if __name__ == "__main__":
    main()
