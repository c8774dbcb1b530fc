"""Linear-solver plumbing (shells.solvers): a failed factorisation must not poison later ones."""

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from shells.solvers import DEFAULT_SNES_OPTIONS, configure_factor, setup_factor


def _tridiagonal(n: int, broken: bool) -> PETSc.Mat:
    """The 1D Laplacian (-1, 2, -1); ``broken``: row and column 5 zero (singular)."""
    A = PETSc.Mat().createAIJ([n, n], nnz=3, comm=MPI.COMM_WORLD)
    lo, hi = A.getOwnershipRange()
    for i in range(lo, hi):
        for j, v in ((i - 1, -1.0), (i, 2.0), (i + 1, -1.0)):
            if 0 <= j < n and not (broken and 5 in (i, j)):
                A[i, j] = v
    A.assemble()
    return A


def test_factorisation_recovers_after_a_failure():
    """MUMPS keeps its error after a failed numeric phase and PETSc then skips later numeric
    factorisations of that factor (every later solve failed: the sphere's locate crashed)."""
    n = 40
    good, bad = _tridiagonal(n, False), _tridiagonal(n, True)
    A = good.duplicate(copy=True)
    opts = {k: v for k, v in DEFAULT_SNES_OPTIONS.items() if k.startswith(("ksp_", "pc_", "mat_"))}
    ksp = PETSc.KSP().create(MPI.COMM_WORLD)
    ksp.setType("preonly")
    ksp.getPC().setType("lu")
    ksp.getPC().setFactorSolverType("mumps")
    configure_factor(ksp, A, opts)
    b, x = A.createVecLeft(), A.createVecRight()
    b.set(1.0)
    # exact solution of the Laplacian with unit load: x_i = (i + 1)(n - i) / 2
    lo, hi = x.getOwnershipRange()
    exact = np.array([(i + 1) * (n - i) / 2 for i in range(lo, hi)])
    outcomes = []
    for src in (good, bad, good, good):
        src.copy(A, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN
                 if src is good else PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        ksp.setOperators(A)
        ok = setup_factor(ksp, A, opts)
        if ok:
            ksp.solve(b, x)
            err = MPI.COMM_WORLD.allreduce(float(np.max(np.abs(x.array - exact), initial=0.0)),
                                           op=MPI.MAX)
            ok = err < 1e-9 * n * n
        outcomes.append(ok)
    assert outcomes == [True, False, True, True]
    for o in (ksp, A, good, bad, b, x):
        o.destroy()
