"""Linear-solver plumbing (shells.algorithms.newton): a failed factorisation must not poison later
ones."""

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from shells.algorithms.newton import DEFAULT_SNES_OPTIONS, configure_factor, setup_factor


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


def _thin_sphere_profile(steps: int) -> tuple[np.ndarray, list[int], list[bool]]:
    """Ψ3 of a thin (h/R = 0.001) 1D sphere with a polar patch of natural curvature at
    κh = 0.002, reached by Newton in ``steps`` equal load steps."""
    import math

    from shells.algorithms.newton import NewtonSolver
    from shells.axisym import SNES_OPTIONS
    from shells.axisym.model import AxisymModel, AxisymParameters
    from shells.geometry.shapes import Sphere
    from shells.geometry.stimulus import CurvatureField

    h = 0.001
    fld = CurvatureField(f"step(0.8 - theta, {0.25 * math.sqrt(h):.6g})")
    m = AxisymModel(Sphere(1.0), AxisymParameters(h=h, nu=0.5, cells=2500, penalty=1e6,
                                                  kappa_field=fld))
    ns = NewtonSolver(m, options=SNES_OPTIONS)
    its, noise = [], []
    for k in range(1, steps + 1):
        m.set_kappa(0.002 * k / steps / h)
        ok, n = ns.solve()
        assert ok
        its.append(n)
        noise.append(ns.noise_accepted)
    p = m.meridian_profile()
    ns.destroy()
    return p["ur"] * np.sin(p["t"]) + p["uz"] * np.cos(p["t"]), its, noise


def test_newton_converges_past_the_round_off_bound_of_a_thin_shell():
    """On a thin, penalty-stiff sphere a whole load step's first residual (4e-7) lies below the
    a-priori round-off bound 0.1 ε ||J||_F ||w|| (4e-6 to 2e-5), which once accepted the
    unchanged start: steps 2 to 4 took 0 iterations, and the profile ended 75 % from the
    one-step solution. Newton now goes
    on to the measured round-off (1e-8) and until its step settles: the two agree to 3.5e-8
    (the linear solves of this ill-conditioned Jacobian contract by only ~0.2 per iteration
    there, so the residual alone cannot tell)."""
    one, its1, noise1 = _thin_sphere_profile(1)
    four, its4, noise4 = _thin_sphere_profile(4)
    assert min(its1 + its4) >= 3
    assert all(noise1 + noise4)  # each ended at round-off (atol 1e-12 is below it)
    assert np.linalg.norm(four - one) <= 1e-6 * np.linalg.norm(one)


def _needs_pivoting(n: int) -> PETSc.Mat:
    """Nonsingular and symmetric with a zero diagonal (stored): [[0, 1], [1, 0]] blocks. An LU
    without pivoting (PETSc's own) meets a zero pivot at once in any symmetric ordering."""
    A = PETSc.Mat().createAIJ([n, n], nnz=2, comm=MPI.COMM_SELF)
    for i in range(0, n, 2):
        A[i, i] = A[i + 1, i + 1] = 0.0
        A[i, i + 1] = A[i + 1, i] = 1.0
    A.assemble()
    return A


def test_a_zero_pivot_of_the_native_lu_falls_back_to_mumps():
    """PETSc's own LU (the 1D model's on one process: ``factor_options``) stops at a zero pivot;
    ``setup_factor`` then factors with MUMPS, which the KSP keeps, and the solve is exact."""
    n = 6
    A = _needs_pivoting(n)
    opts = {"pc_factor_mat_solver_type": "petsc", "pc_factor_mat_ordering_type": "rcm",
            "mat_mumps_icntl_14": 200}
    ksp = PETSc.KSP().create(MPI.COMM_SELF)
    ksp.setType("preonly")
    ksp.getPC().setType("lu")
    ksp.getPC().setFactorSolverType("petsc")
    configure_factor(ksp, A, opts)
    ksp.setUp()
    assert int(ksp.getPC().getFailedReason()) != 0  # the premise: no pivoting, a zero pivot
    ksp.getPC().reset()
    ksp.getPC().setFactorSolverType("petsc")
    configure_factor(ksp, A, opts)
    assert setup_factor(ksp, A, opts)
    assert ksp.getPC().getFactorSolverType() == "mumps"
    assert opts["pc_factor_mat_solver_type"] == "mumps"
    b, x = A.createVecLeft(), A.createVecRight()
    b.array[:] = np.arange(1.0, n + 1.0)
    ksp.solve(b, x)
    assert np.allclose(x.array, b.array.reshape(-1, 2)[:, ::-1].ravel(), rtol=0, atol=1e-14)
    for o in (ksp, A, b, x):
        o.destroy()


def test_newton_with_the_native_lu_survives_a_zero_pivot():
    """A problem recommending PETSc's own LU whose Jacobian needs pivoting: E = x y - κ x
    (R = (y - κ, x), J = [[0, 1], [1, 0]]). Newton falls back to MUMPS and converges to
    (0, κ) in one step; a problem without the recommendation keeps MUMPS throughout."""
    from shells.algorithms.newton import NewtonSolver
    from shells.problem.algebraic import AlgebraicProblem

    class Saddle(AlgebraicProblem):
        factor_options = {"pc_factor_mat_solver_type": "petsc",
                          "pc_factor_mat_ordering_type": "rcm"}

        def energy(self, w, k):
            return w[0] * w[1] - k * w[0]

        def gradient(self, w, k):
            return np.array([w[1] - k, w[0]])

        def hessian(self, w, k):
            return np.array([[0.0, 1.0], [1.0, 0.0]])

        def dgradient_dkappa(self, w, k):
            return np.array([-1.0, 0.0])

    p = Saddle(2, np.array([1.0, 1.0]))
    p.set_kappa(0.5)
    ns = NewtonSolver(p)
    assert ns.ksp.getPC().getFactorSolverType() == "petsc"
    ok, its = ns.solve()
    assert ok and its == 1
    assert np.allclose(p.state.array, [0.0, 0.5], rtol=0, atol=1e-14)
    assert ns.ksp.getPC().getFactorSolverType() == "mumps"
    # the bordered solves' KSP falls back on its own, at its first factorisation
    assert ns.factor()
    assert ns.lin.getPC().getFactorSolverType() == "mumps"
    ns.destroy()
