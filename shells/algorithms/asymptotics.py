"""Koiter's reduced equation at a simple bifurcation, and the imperfection-sensitivity law that
follows from it (algorithm layer, on ``shells.problem.interface.Problem``).

Near a simple bifurcation at κ_c of a perfect problem, with φ the null vector of the Jacobian J
there and w = w_f(κ) + ξ φ + (terms orthogonal to φ), the equilibria of the problem with an
imperfection of amplitude δ satisfy, at lowest order (Koiter 1945; Hutchinson & Koiter 1970),

    G(ξ, κ, δ) = c1 (κ - κ_c) ξ + c2 ξ² + c3 δ = 0,

    c1 = d(φᵀ J φ)/dκ along the fundamental branch   (how fast the critical stiffness drops),
    c2 = ½ D³E[φ, φ, φ]                               (the bifurcation's asymmetry),
    c3 = φᵀ ∂R/∂δ                                      (how the imperfection loads the mode).

The perfect bifurcated branch leaves with dκ/dξ = -c2/c1. If c2 ≠ 0 (asymmetric, transcritical)
and c2 c3 δ > 0, the imperfect branch from κ = 0 reaches a limit point (fold) at

    1 - κ_max/κ_c = C √δ,   C = 2 √(c2 c3) / (|c1| κ_c),

and for the other sign of δ it has none at this order. c2 = 0 is a symmetric bifurcation: the
law is then 1 - κ_max/κ_c ∝ δ^(2/3) with a coefficient from the next order (not computed here;
on a closed sphere c2 ∝ ∫ P_n³ vanishes for odd n: docs/imperfections.md, "Koiter's law").

Everything is computed from the problem interface at a located
``shells.algorithms.records.CriticalPoint`` by finite differences of residuals and Jacobians (no
model-specific code). The critical point is first refined (κ_c where the Rayleigh quotient of
the null vector vanishes, φ by inverse iteration), because the locator's bracket is too coarse
for the law's small-δ end. The imperfection enters only through a callable that returns ∂R/∂δ
at the problem's current state and κ (``shells.analyses.knockdown`` builds it from two
imperfect models on the same mesh). The amplitude ξ is the RMS of φ's DOFs in units of the
problem's ``state_scale()`` (thicknesses), the continuation norm; C does not depend on that
choice.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

from shells.errors import InputError

__all__ = ["ReducedEquation", "reduced_equation"]

#: a symmetric bifurcation: φᵀR(w_c ± ξφ) is odd in ξ, its even part below this fraction of
#: its size (an asymmetric one has an even part ~ c2 ξ² that dominates at the critical point,
#: where the odd part is ~ ξ³; the two kinds lie orders of magnitude apart on the 1D sphere:
#: docs/imperfections.md, "Koiter's law")
SYMMETRIC_BELOW = 0.1


@dataclass(frozen=True)
class ReducedEquation:
    """The coefficients of G = c1 (κ - κ_c) ξ + c2 ξ² + c3 δ at one bifurcation.

    Attributes:
        kappa_c: the refined critical κ.
        c1, c2, c3: the coefficients (c3 None without an imperfection).
        kappa_c_accuracy: the refinement's last correction of κ_c, relative.
        slope: the bifurcated branch's initial slope relative to κ_c, -c2/(c1 κ_c).
        asymmetry: the even part of φᵀR(w_c ± ξφ) over its size at the finite-difference
            amplitude.
        kind: "asymmetric" or "symmetric" (asymmetry below ``SYMMETRIC_BELOW``).
    """

    kappa_c: float
    c1: float
    c2: float
    c3: float | None
    #: the refinement's last correction of κ_c, relative (how well κ_c is known)
    kappa_c_accuracy: float
    #: the bifurcated branch's initial slope relative to κ_c: (dκ/dξ)/κ_c = -c2/(c1 κ_c)
    slope: float
    #: the even part of φᵀR(w_c ± ξφ) over its size at the finite-difference amplitude
    asymmetry: float
    kind: str  # "asymmetric" or "symmetric"

    @property
    def coefficient(self) -> float | None:
        """C of 1 - κ_max/κ_c = C √δ for δ > 0 (None: no fold at this order for δ > 0, or a
        symmetric bifurcation, or no imperfection given)."""
        if self.kind != "asymmetric" or self.c3 is None or self.c2 * self.c3 <= 0:
            return None
        return 2.0 * math.sqrt(self.c2 * self.c3) / (abs(self.c1) * abs(self.kappa_c))

    def knockdown(self, delta: float) -> float | None:
        """κ_max/κ_c predicted for amplitude δ > 0 (None where the law gives no fold)."""
        c = self.coefficient
        return None if c is None or delta <= 0 else 1.0 - c * math.sqrt(delta)

    def as_dict(self) -> dict[str, Any]:
        """The fields and ``coefficient`` (JSON-ready)."""
        d = asdict(self)
        d["coefficient"] = self.coefficient
        return d


def _rayleigh(A: Any, v: Any, tmp: Any) -> float:
    A.mult(v, tmp)
    return float(v.dot(tmp))


def reduced_equation(problem: Any, cp: Any, solver: Any,
                     imperfection: Callable[[], Any] | None = None, *,
                     refine: int = 4, rel_step: float = 2.0e-3,
                     amplitude: float = 0.01) -> ReducedEquation:
    """The reduced equation at a simple bifurcation.

    Args:
        problem: the problem.
        cp: the located bifurcation, carrying its state and mode.
        solver: the problem's ``shells.algorithms.newton.NewtonSolver``, whose Jacobian matrix
            is used.
        imperfection: returns ∂R/∂δ (a Vec) at the problem's current state and κ; None: c3
            is None.
        refine: iterations of the refinement of κ_c and φ.
        rel_step: the κ step (relative) of the fundamental branch's finite differences.
        amplitude: the finite-difference step of ξ (RMS thicknesses).

    Returns:
        The coefficients. The problem is left at the refined critical state.

    Raises:
        InputError: if ``cp`` carries no state or mode, or is not a bifurcation.
    """
    if cp.state is None or cp.mode is None:
        raise InputError("this critical point carries no state/mode")
    if cp.kind != "bifurcation":
        raise InputError(f"the reduced equation needs a bifurcation, got a {cp.kind}")
    red = _Reduction(problem, cp, solver)
    try:
        kappa = red.start_kappa(float(cp.kappa))
        correction, c1 = math.inf, math.nan
        for _ in range(max(1, refine)):
            kappa, c1, correction = red.refine(kappa, rel_step)
            if correction < 1e-10:
                break
        # c2 = ½ E'''(φ, φ, φ) from second differences of φᵀR along φ (ξ = ±amplitude)
        r0, rp, rm = red.phi_residuals(kappa, amplitude)
        c2 = (rp + rm - 2 * r0) / (2 * amplitude**2)
        c3 = None if imperfection is None else red.imperfection_load(kappa, imperfection)
        slope = -c2 / (c1 * kappa)
        asym = abs(rp + rm - 2 * r0) / max(abs(rp - r0), abs(rm - r0), 1e-300)
        red.set_point(red.w, kappa)
        return ReducedEquation(kappa_c=kappa, c1=float(c1), c2=float(c2), c3=c3,
                               kappa_c_accuracy=float(correction), slope=float(slope),
                               asymmetry=float(asym),
                               kind="symmetric" if asym < SYMMETRIC_BELOW else "asymmetric")
    finally:
        red.destroy()


class _Reduction:
    """The vectors and the LU solver of one ``reduced_equation``: the critical state w, the
    null vector φ (RMS ``unit``), the fundamental branch's tangent t and work vectors.

    Args:
        problem: the problem.
        cp: the bifurcation, with its state and mode.
        solver: the problem's Newton solver (its Jacobian matrix is used).
    """

    def __init__(self, problem: Any, cp: Any, solver: Any) -> None:
        from petsc4py import PETSc

        self.problem, self.solver = problem, solver
        self.A = solver.A
        n_loc = problem.state.getLocalSize()
        self.w = problem.state.duplicate()
        self.w.array_w[:] = cp.state[:n_loc]
        self.phi = self.w.duplicate()
        self.phi.array_w[:] = cp.mode[:n_loc]
        problem.zero_constrained(self.phi)
        # ξ: RMS amplitude in units of the state scale
        self.unit = math.sqrt(problem.num_dofs()) * problem.state_scale()
        self.phi.scale(self.unit / self.phi.norm())
        self.t, self.rk, self.tmp, self.y, self.wp, self.wm = (
            self.w.duplicate() for _ in range(6))
        self.g = None
        self.ksp = PETSc.KSP().create(problem.comm)
        self.ksp.setType("preonly")
        self.ksp.getPC().setType("lu")
        self.ksp.getPC().setFactorSolverType("mumps")

    def destroy(self) -> None:
        """Free the solver and the vectors."""
        self.ksp.destroy()
        for v in (self.w, self.phi, self.t, self.rk, self.tmp, self.y, self.wp, self.wm,
                  self.g):
            if v is not None:
                v.destroy()

    def set_point(self, state: Any, kappa: float) -> None:
        """Set the problem's state and κ."""
        problem = self.problem
        state.copy(problem.state)
        problem.sync()
        problem.set_kappa(kappa)

    def jacobian_at(self, state: Any, kappa: float) -> Any:
        """The Jacobian matrix assembled at (``state``, ``kappa``)."""
        self.set_point(state, kappa)
        self.problem.assemble_jacobian(self.A)
        return self.A

    def phi_residual(self, state: Any, kappa: float) -> float:
        """φᵀR at (``state``, ``kappa``)."""
        self.set_point(state, kappa)
        self.problem.assemble_residual(self.tmp)
        return float(self.phi.dot(self.tmp))

    def start_kappa(self, kappa: float) -> float:
        """The κ of the critical state: the least-squares one (the residual is affine in κ;
        the critical point's state is a trial solve next to the located κ)."""
        problem, tmp, rk = self.problem, self.tmp, self.rk
        self.set_point(self.w, kappa)
        problem.assemble_residual(tmp)
        problem.assemble_dkappa(rk)
        return kappa - float(tmp.dot(rk)) / float(rk.dot(rk))

    def refine(self, kappa: float, rel_step: float) -> tuple[float, float, float]:
        """One refinement of κ_c, φ and w: φ by inverse iteration, the fundamental branch at
        κ ± d (d = ``rel_step`` |κ|), and the zero of φ's Rayleigh quotient between them.

        Returns:
            (the new κ_c, c1, the correction's relative size).

        Raises:
            RuntimeError: if Newton fails on the fundamental branch.
        """
        self.null_vector(kappa)
        # the fundamental branch at κ ± d (Newton from the tangent's prediction: the
        # nearest equilibria, the bifurcated branch lies ~c1 d / c2 away along φ), the
        # Rayleigh quotient of φ there, and its zero by linear interpolation
        d = rel_step * abs(kappa)
        mus = [self.branch_rayleigh(v, kappa, sign * d)
               for v, sign in ((self.wp, 1.0), (self.wm, -1.0))]
        c1 = (mus[0] - mus[1]) / (2 * d)
        dk = -0.5 * (mus[0] + mus[1]) / c1
        w = self.w
        w.set(0.0)
        w.axpy(0.5 + dk / (2 * d), self.wp)
        w.axpy(0.5 - dk / (2 * d), self.wm)
        kappa += dk
        return kappa, c1, abs(dk / kappa)

    def null_vector(self, kappa: float) -> None:
        """φ by inverse iteration with J at (w, κ) (nearly singular along it), then the
        fundamental branch's tangent t = -J⁻¹ ∂R/∂κ with its φ-component removed (that
        component is the near-singular solve's, not the branch's: φᵀ ∂R/∂κ = 0 at a
        bifurcation)."""
        problem, ksp, phi, y, t = self.problem, self.ksp, self.phi, self.y, self.t
        J = self.jacobian_at(self.w, kappa)
        ksp.setOperators(J)
        ksp.setUp()
        for _ in range(3):
            ksp.solve(phi, y)
            problem.zero_constrained(y)
            y.scale(self.unit / y.norm())
            y.copy(phi)
        problem.assemble_dkappa(self.rk)  # at (w, κ), set by jacobian_at
        ksp.solve(self.rk, t)
        t.scale(-1.0)
        problem.zero_constrained(t)
        t.axpy(-t.dot(phi) / phi.dot(phi), phi)

    def branch_rayleigh(self, v: Any, kappa: float, dk: float) -> float:
        """The fundamental branch's state at κ + ``dk`` into ``v`` (Newton from w + dk t)
        and φ's Rayleigh quotient of the Jacobian there.

        Raises:
            RuntimeError: if Newton fails.
        """
        v.waxpy(dk, self.t, self.w)
        self.set_point(v, kappa + dk)
        ok, _ = self.solver.solve()
        if not ok:
            raise RuntimeError("reduced equation: Newton failed on the fundamental "
                               f"branch at kappa = {kappa + dk:.8g}")
        self.problem.state.copy(v)
        return _rayleigh(self.jacobian_at(v, kappa + dk), self.phi, self.tmp)

    def phi_residuals(self, kappa: float, amplitude: float) -> tuple[float, float, float]:
        """φᵀR at w and at w ± ``amplitude`` φ, all at ``kappa``."""
        w, y, phi = self.w, self.y, self.phi
        r0 = self.phi_residual(w, kappa)
        y.waxpy(amplitude, phi, w)
        rp = self.phi_residual(y, kappa)
        y.waxpy(-amplitude, phi, w)
        rm = self.phi_residual(y, kappa)
        return r0, rp, rm

    def imperfection_load(self, kappa: float, imperfection: Callable[[], Any]) -> float:
        """c3 = φᵀ ∂R/∂δ at (w, ``kappa``)."""
        self.set_point(self.w, kappa)
        self.g = imperfection()
        return float(self.phi.dot(self.g))

