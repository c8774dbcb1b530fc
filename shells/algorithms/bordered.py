"""The one corrector of the path-following algorithms (algorithm layer): Keller's bordered
Newton on R(w, λ) = 0 with a hyperplane and optional pins, and ``Arclength``, the vectors and
norms it works with.

Continuation (``shells.algorithms.continuation``), the locator (``shells.algorithms.locate``),
branch switching (``shells.algorithms.switching``) and the knock-down's limit points all
correct with ``bordered_newton``.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from shells.algorithms.newton import NewtonSolver
from shells.algorithms.settings import ContinuationSettings

__all__ = ["Arclength", "Correction", "bordered_newton"]

log = logging.getLogger("shells")


class Arclength:
    """Vectors and norms of the bordered system.

    Args:
        ns: the Newton solver of the problem (its factorisations are the corrector's).
        L: the length scale: the algorithms continue in λ = κ L.
        xi: the state's weight ξ in the arclength norm ξ² |δw|²/(N h²) + δλ².
    """

    def __init__(self, ns: NewtonSolver, L: float, xi: float) -> None:
        self.ns = ns
        self.problem = ns.problem
        self.L = L
        self.w = self.problem.state
        N = self.w.getSize()
        h = self.problem.state_scale()
        self.cw = xi**2 / (N * h**2)
        self.h = h
        self.Fl = self.w.duplicate()  # dR/dλ
        self.a = self.w.duplicate()
        self.b = self.w.duplicate()
        self.tw = self.w.duplicate()  # tangent, state part
        self.tl = 0.0                 # tangent, λ part
        self.wp = self.w.duplicate()  # predictor
        self.w_old = self.w.duplicate()
        self.lam_ref = 0.0            # κ_ref L of the relative residual bound
        self.fl_norm = 0.0            # ||∂R/∂λ|| at the last ``dres_dlambda``
        # how far (``ContinuationSettings.factor_reuse``'s measure) the state has moved since
        # the factorisation the solver holds, as the last corrector left it (inf: unknown)
        self.drift = math.inf

    def destroy(self) -> None:
        """Free the work vectors (the state is the problem's, kept)."""
        for v in (self.Fl, self.a, self.b, self.tw, self.wp, self.w_old):
            v.destroy()

    def set_lambda(self, lam: float) -> None:
        """Set the problem's κ to λ / L."""
        self.problem.set_kappa(lam / self.L)

    def get_lambda(self) -> float:
        """The problem's λ = κ L."""
        return self.problem.get_kappa() * self.L

    def sync(self) -> None:
        """Propagate the state's owned values to its ghosts (``Problem.sync``)."""
        self.problem.sync()

    def restore(self, lam: float) -> None:
        """Back to the last converged point (after a failed step)."""
        self.w_old.copy(self.w)
        self.sync()
        self.set_lambda(lam)

    def dres_dlambda(self) -> None:
        """Assemble ∂R/∂λ at the current state into ``Fl`` and record its norm."""
        self.ns.assemble_dkappa(self.Fl)
        self.Fl.scale(1.0 / self.L)
        self.fl_norm = float(self.Fl.norm())

    def residual_bound(self, st: ContinuationSettings, lam: float,
                       roundoff: bool = True) -> float:
        """The residual tolerance at the current state and λ (``ContinuationSettings``).

        Args:
            st: the settings whose ``residual_tol``, ``residual_rtol`` and
                ``residual_roundoff`` apply.
            lam: the λ at which the κ-load is taken.
            roundoff: include the round-off term (False for a Newton solve, which measures
                the round-off it stalls at itself).

        Returns:
            ``residual_tol`` if given, else residual_rtol ||∂R/∂λ|| max(|λ|, λ_ref) +
            residual_roundoff ε ||J||_F ||w|| (J: the last factored Jacobian; ∂R/∂λ from the
            last ``dres_dlambda``).
        """
        if st.residual_tol is not None:
            return st.residual_tol
        load = self.fl_norm * max(abs(lam), self.lam_ref)
        floor = self.ns.roundoff_floor(st.residual_roundoff) if roundoff else 0.0
        return st.residual_rtol * load + floor

    def tangent(self, sign_ref: tuple[Any, float] | None, direction: float,
                attempts: int = 1, reuse: bool = False) -> bool:
        """Compute the unit tangent (``tw``, ``tl``) at the current (converged) point.

        J z = -R_λ, τ ∝ (z, 1), oriented like ``sign_ref`` (positive inner product in the
        continuation norm), which carries a branch around folds.

        Args:
            sign_ref: the previous tangent (τ_w, τ_λ); None: orient by ``direction``.
            direction: the sign of τ_λ wanted when there is no ``sign_ref``.
            attempts: factorisations to try (a failed factor is reset between them).
            reuse: solve with the factorisation held (the corrector's, of a Jacobian within
                ``factor_reuse`` of this point) instead of factoring afresh.

        Returns:
            True; False, with the tangent left as it was, if the Jacobian could not be
            factored or the tangent is not finite.
        """
        if not reuse and not self.ns.factor(attempts):
            return False
        self.dres_dlambda()
        self.Fl.scale(-1.0)
        self.ns.lin_solve(self.Fl, self.b)
        nz2 = self.cw * self.b.dot(self.b)
        norm = math.sqrt(nz2 + 1.0)
        if not math.isfinite(norm):
            return False
        self.b.copy(self.tw)
        self.tw.scale(1.0 / norm)
        tl = 1.0 / norm
        if sign_ref is None:
            s = 1.0 if direction >= 0 else -1.0
        else:
            tw_old, tl_old = sign_ref
            s = 1.0 if self.cw * self.tw.dot(tw_old) + tl * tl_old >= 0 else -1.0
        self.tw.scale(s)
        self.tl = s * tl
        return True

    def start_tangent(self, sign_ref: tuple[Any, float] | None, direction: float) -> None:
        """``tangent`` at a run's start, where there is no step to cut.

        Args:
            sign_ref: as for ``tangent``.
            direction: as for ``tangent``.

        Raises:
            RuntimeError: if the Jacobian cannot be factored in two attempts (the failed
                factor is reset between them).
        """
        if not self.tangent(sign_ref, direction, attempts=2):
            raise RuntimeError(f"the Jacobian at the start kappa L = {self.get_lambda():.6g} "
                               "could not be factored (twice)")


class Correction(NamedTuple):
    """The outcome of a corrector: converged, iterations, λ, and the pins' multipliers s_j."""

    ok: bool
    its: int
    lam: float
    multipliers: np.ndarray


def bordered_newton(ar: Arclength, st: ContinuationSettings, lam_p: float,
                     lam_start: float | None = None, singular_ok: bool = False,
                     deflate: Any = None, *, plane: tuple[Any, float, Any] | None = None,
                     pins: Sequence[Any] = (), wc: Any = None,
                     max_dlam: float | None = None, keep_best: bool | None = None
                     ) -> Correction:
    """Correct the problem's state onto the branch: Keller's bordered Newton, with pins.

    Newton on R(w, λ) + Σ_j s_j ψ_j = 0 with the step's hyperplane
    cw τ_w·(w - w_p) + τ_λ (λ - λ_p) = 0 and, for each pin ψ_j, cw ψ_j·(w - w_c) = 0; unknowns
    w, λ and the multipliers s_j. One LU factorisation and 2 + len(pins) solves per
    iteration; the constraints are linear, so every iterate after the first satisfies them.
    Within ``factor_reuse`` of the last factored iterate the factorisation is kept (chord
    steps), except with ``singular_ok``, whose acceptance after 3 iterations takes the
    residual bound alone, which a chord iterate meets farther from the solution.

    Args:
        ar: the vectors and norms; the corrector starts from the problem's current state.
        st: the settings (tolerances, ``max_newton_its``, ``factor_reuse``).
        lam_p: the predictor's λ.
        lam_start: the λ Newton starts from (default: ``lam_p``).
        singular_ok: next to a singular point, where round-off amplified along the critical
            mode stalls the increment above ``newton_tol`` although the residual is
            converged: accept a residual below the residual bound after 3 iterations, and if
            Newton diverges (next to a cluster of singular modes, a closed sphere's) keep the
            iterate of smallest residual when it is below the bound.
        deflate: a callable ``deflate(a, b, ...)`` that may remove components from each
            iteration's solves (the locator's safeguard against Newton steps that switch to
            a branch bifurcating close by).
        plane: (τ_w, τ_λ, w_p), the hyperplane (default: the ``Arclength``'s tangent and
            predictor). (0, 1, ·) fixes λ = λ_p (landing on a given κ); (φ, 0, w_c + a φ)
            fixes the amplitude a along φ with λ free, which parametrises a pitchfork
            regularly (branch switching).
        pins: the ψ_j, held at their value in ``wc``: a phase condition, e.g. the orientation
            of a buckling pattern on a shape of revolution
            (``shells.algorithms.switching.switch_branch``); s_j ψ_j is the force that holds it.
        wc: the state the pins refer to (needed with pins).
        max_dlam: an iterate with |λ - λ_p| above it counts as divergence (default
            10 max(1, |λ_p|)).
        keep_best: keep the iterate of smallest residual on divergence (default:
            ``singular_ok``).

    Returns:
        The ``Correction``; on success the problem holds the converged state and λ, and
        ``ar.drift`` how far it moved since the factorisation the solver holds. The residual
        bound is ``Arclength.residual_bound``.
    """
    corrector = _Corrector(ar, st, lam_p, lam_start, singular_ok, deflate, plane, pins, wc,
                           max_dlam, keep_best)
    try:
        return corrector.run()
    finally:
        corrector.destroy()


class _Corrector:
    """One call of ``bordered_newton``: its unknowns (w in ``ar``, λ, s), the solves' vectors
    and the iterate of smallest residual. The arguments are ``bordered_newton``'s."""

    def __init__(self, ar: Arclength, st: ContinuationSettings, lam_p: float,
                 lam_start: float | None, singular_ok: bool, deflate: Any,
                 plane: tuple[Any, float, Any] | None, pins: Sequence[Any], wc: Any,
                 max_dlam: float | None, keep_best: bool | None) -> None:
        self.ar, self.st, self.ns, self.w = ar, st, ar.ns, ar.w
        self.tw, self.tl, self.wp = plane if plane is not None else (ar.tw, ar.tl, ar.wp)
        self.pins, self.wc, self.k = pins, wc, len(pins)
        self.singular_ok, self.deflate, self.lam_p = singular_ok, deflate, lam_p
        self.s = np.zeros(self.k)
        self.lam = lam_p if lam_start is None else lam_start
        ar.set_lambda(self.lam)
        self.dlam_max = 10.0 * max(1.0, abs(lam_p)) if max_dlam is None else max_dlam
        self.F = self.ns.b
        # the solves J x = -R_λ, -ψ_j
        self.xs = [ar.b, *(self.w.duplicate() for _ in range(self.k))]
        keep = singular_ok if keep_best is None else keep_best
        self.best_w = self.w.duplicate() if keep else None
        # (residual, λ, s) of the best iterate, its state in best_w
        self.best = (math.inf, self.lam, self.s)
        self.best_updates = 0  # the Newton updates that led to it
        # the state's movement since the factorisation held (inf: factor at the next
        # iteration), and the last increment, whose contraction decides whether a chord step
        # may follow (not with ``singular_ok``: its acceptance after 3 iterations takes the
        # residual bound alone, which a chord iterate meets farther from the solution than
        # Newton's third)
        self.reuse = 0.0 if singular_ok else st.factor_reuse
        self.drift, self.last_dw = math.inf, math.inf
        ar.drift = math.inf
        self.n_sqrt = math.sqrt(self.w.getSize())
        self.rms = math.inf  # the last increment's RMS over L

    def destroy(self) -> None:
        """Free the pins' solve vectors and the best iterate's state."""
        for v in self.xs[1:]:
            v.destroy()
        if self.best_w is not None:
            self.best_w.destroy()

    def run(self) -> Correction:
        """Newton iterations up to ``max_newton_its``.

        Returns:
            The converged ``Correction``, or ``fail``'s.
        """
        for it in range(1, self.st.max_newton_its + 1):
            done = self.iterate(it)
            if done is not None:
                return done
        return self.fail(self.st.max_newton_its)

    def residual(self) -> float:
        """||R(w, λ) + Σ s_j ψ_j||, the residual left in ``F``."""
        self.ns.assemble_residual(self.F)
        for j in range(self.k):
            self.F.axpy(self.s[j], self.pins[j])
        return self.F.norm()

    def fail(self, it: int) -> Correction:
        """The outcome of a corrector that did not converge by iteration ``it``.

        Returns:
            The best iterate as converged (the problem set to it) if it is what
            ``singular_ok`` would accept (3 updates at least: an earlier iterate can be within
            the bound of the branch but not on it; docs/design-notes.md, "Corrector: the kept
            iterate"); else a failed ``Correction`` at the current λ and s.
        """
        ar, best = self.ar, self.best
        if self.best_w is None or self.best_updates < 3 \
                or not best[0] <= ar.residual_bound(self.st, best[1]):
            return Correction(False, it, self.lam, self.s)
        self.best_w.copy(self.w)
        ar.sync()
        ar.set_lambda(best[1])
        log.debug("corrector: diverged; kept the iterate of residual %.3e", best[0])
        return Correction(True, it, best[1], best[2])

    def iterate(self, it: int) -> Correction | None:
        """Newton iteration ``it``: factor if needed, solve, update, test convergence.

        Returns:
            The outcome if the corrector ends at this iteration, else None.
        """
        fn = self.residual()
        if not np.isfinite(fn):
            return self.fail(it)
        if not self.drift <= self.reuse:
            if not self.ns.factor():
                return self.fail(it)
            self.drift = 0.0
        if self.best_w is not None and fn < self.best[0]:
            self.w.copy(self.best_w)
            self.best, self.best_updates = (fn, self.lam, self.s.copy()), it - 1
        elif self.best_w is not None and it > 3 and fn > 1e3 * self.best[0]:
            return self.fail(it)  # diverging from a good iterate: more steps only go further
        self.solve_directions()
        c = self.constraint_solution()
        if c is None or not np.all(np.isfinite(c)):
            return self.fail(it)
        if not self.update(c):
            return self.fail(it)
        if abs(self.lam - self.lam_p) > self.dlam_max:
            return self.fail(it)  # diverging: its iterates would only poison the factor
        st = self.st
        small = (self.rms < st.newton_tol
                 and abs(c[0]) < st.newton_tol * max(1.0, abs(self.lam)))
        if (small or (self.singular_ok and it >= 3)) \
                and self.residual() <= self.ar.residual_bound(st, self.lam):
            self.ar.drift = self.drift
            return Correction(True, it, self.lam, self.s)
        return None

    def solve_directions(self) -> None:
        """The solves with the factored J: a = -J⁻¹ F (F holding the residual), b = -J⁻¹ R_λ,
        x_j = -J⁻¹ ψ_j, then the optional ``deflate`` of them."""
        ar, ns = self.ar, self.ns
        self.F.scale(-1.0)
        ns.lin_solve(self.F, ar.a)
        ar.dres_dlambda()
        ar.Fl.scale(-1.0)
        ns.lin_solve(ar.Fl, ar.b)
        for j in range(self.k):
            self.pins[j].copy(ar.Fl)
            ar.Fl.scale(-1.0)
            ns.lin_solve(ar.Fl, self.xs[j + 1])
        if self.deflate is not None:
            self.deflate(ar.a, *self.xs)

    def constraint_solution(self) -> np.ndarray | None:
        """(δλ, δs_1, ...) from the constraints' rows: the hyperplane, then the pins.

        Returns:
            The coefficients, or None if the pinned system is singular.
        """
        ar, w, k, xs, tw, tl = self.ar, self.w, self.k, self.xs, self.tw, self.tl
        w.copy(ar.Fl)
        ar.Fl.axpy(-1.0, self.wp)
        A = np.empty((k + 1, k + 1))
        r = np.empty(k + 1)
        A[0] = [ar.cw * tw.dot(x) for x in xs]
        A[0, 0] += tl
        # (k = 0 keeps the bordered formula's order of operations, k > 0 the pinned one's:
        # next to a closed sphere's cluster of singular modes the state along the nearly
        # singular directions is set by round-off, and the branch switched onto from it
        # depends on it; docs/design-notes.md, "Corrector: order of operations")
        dlam = self.lam - self.lam_p
        r[0] = -(ar.cw * (tw.dot(ar.Fl) + tw.dot(ar.a)) + tl * dlam) if k else \
            -((ar.cw * tw.dot(ar.Fl) + tl * dlam) + ar.cw * tw.dot(ar.a))
        if k:
            w.copy(ar.Fl)
            ar.Fl.axpy(-1.0, self.wc)
        for j in range(k):
            A[j + 1] = [ar.cw * self.pins[j].dot(x) for x in xs]
            r[j + 1] = -ar.cw * (self.pins[j].dot(ar.Fl) + self.pins[j].dot(ar.a))
        if k == 0:
            return np.array([r[0] / A[0, 0]]) if A[0, 0] != 0 else np.array([math.nan])
        try:
            return np.linalg.solve(A, r)
        except np.linalg.LinAlgError:
            return None

    def update(self, c: np.ndarray) -> bool:
        """Apply the increments (δλ, δs) = ``c`` and the state's; record the drift.

        Returns:
            False if the increment or λ is not finite.
        """
        ar, w, k = self.ar, self.w, self.k
        if k == 0:
            w.axpy(1.0, ar.a)
            w.axpy(c[0], ar.b)
            ar.a.axpy(c[0], ar.b)
        else:
            for j in range(k + 1):
                ar.a.axpy(c[j], self.xs[j])  # the full state increment
            w.axpy(1.0, ar.a)
        self.lam += c[0]
        self.s = self.s + c[1:]
        ar.sync()
        ar.set_lambda(self.lam)
        a_norm = ar.a.norm()
        self.rms = a_norm / self.n_sqrt / ar.L
        if not (math.isfinite(self.rms) and math.isfinite(self.lam)):
            return False
        dw = max(a_norm / self.n_sqrt / ar.h, abs(c[0]) / max(1.0, abs(self.lam)))
        self.drift = self.drift + dw if dw <= 0.1 * self.last_dw else math.inf
        self.last_dw = dw
        return True
