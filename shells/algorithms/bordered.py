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
    ns, w = ar.ns, ar.w
    tw, tl, wp = plane if plane is not None else (ar.tw, ar.tl, ar.wp)
    k = len(pins)
    s = np.zeros(k)
    lam = lam_p if lam_start is None else lam_start
    ar.set_lambda(lam)
    dlam_max = 10.0 * max(1.0, abs(lam_p)) if max_dlam is None else max_dlam
    F = ns.b
    xs = [ar.b, *(w.duplicate() for _ in range(k))]  # the solves J x = -R_λ, -ψ_j
    keep = singular_ok if keep_best is None else keep_best
    best_w = w.duplicate() if keep else None
    best = (math.inf, lam, s)  # (residual, λ, s) of the best iterate, its state in best_w
    best_updates = 0  # the Newton updates that led to it
    # the state's movement since the factorisation held (inf: factor at the next iteration),
    # and the last increment, whose contraction decides whether a chord step may follow
    # (not with ``singular_ok``: its acceptance after 3 iterations takes the residual bound
    # alone, which a chord iterate meets farther from the solution than Newton's third)
    reuse = 0.0 if singular_ok else st.factor_reuse
    drift, last_dw = math.inf, math.inf
    ar.drift = math.inf
    n_sqrt = math.sqrt(w.getSize())

    def residual() -> float:
        ns.assemble_residual(F)
        for j in range(k):
            F.axpy(s[j], pins[j])
        return F.norm()

    def fail(it: int) -> Correction:
        # kept only if it is what singular_ok would accept (3 updates at least): an earlier
        # iterate can be within the bound of the branch but not on it (docs/design-notes.md,
        # "Corrector: the kept iterate")
        if best_w is None or best_updates < 3 or not best[0] <= ar.residual_bound(st, best[1]):
            return Correction(False, it, lam, s)
        best_w.copy(w)
        ar.sync()
        ar.set_lambda(best[1])
        log.debug("corrector: diverged; kept the iterate of residual %.3e", best[0])
        return Correction(True, it, best[1], best[2])

    try:
        for it in range(1, st.max_newton_its + 1):
            fn = residual()
            if not np.isfinite(fn):
                return fail(it)
            if not drift <= reuse:
                if not ns.factor():
                    return fail(it)
                drift = 0.0
            if best_w is not None and fn < best[0]:
                w.copy(best_w)
                best, best_updates = (fn, lam, s.copy()), it - 1
            elif best_w is not None and it > 3 and fn > 1e3 * best[0]:
                return fail(it)  # diverging from a good iterate: more steps only go further
            F.scale(-1.0)
            ns.lin_solve(F, ar.a)
            ar.dres_dlambda()
            ar.Fl.scale(-1.0)
            ns.lin_solve(ar.Fl, ar.b)
            for j in range(k):
                pins[j].copy(ar.Fl)
                ar.Fl.scale(-1.0)
                ns.lin_solve(ar.Fl, xs[j + 1])
            if deflate is not None:
                deflate(ar.a, *xs)
            # the constraints' rows in (δλ, δs_1, ...): the hyperplane, then the pins
            w.copy(ar.Fl)
            ar.Fl.axpy(-1.0, wp)
            A = np.empty((k + 1, k + 1))
            r = np.empty(k + 1)
            A[0] = [ar.cw * tw.dot(x) for x in xs]
            A[0, 0] += tl
            # (k = 0 keeps the bordered formula's order of operations, k > 0 the pinned one's:
            # next to a closed sphere's cluster of singular modes the state along the nearly
            # singular directions is set by round-off, and the branch switched onto from it
            # depends on it; docs/design-notes.md, "Corrector: order of operations")
            r[0] = -(ar.cw * (tw.dot(ar.Fl) + tw.dot(ar.a)) + tl * (lam - lam_p)) if k else \
                -((ar.cw * tw.dot(ar.Fl) + tl * (lam - lam_p)) + ar.cw * tw.dot(ar.a))
            if k:
                w.copy(ar.Fl)
                ar.Fl.axpy(-1.0, wc)
            for j in range(k):
                A[j + 1] = [ar.cw * pins[j].dot(x) for x in xs]
                r[j + 1] = -ar.cw * (pins[j].dot(ar.Fl) + pins[j].dot(ar.a))
            if k == 0:
                c = np.array([r[0] / A[0, 0]]) if A[0, 0] != 0 else np.array([math.nan])
            else:
                try:
                    c = np.linalg.solve(A, r)
                except np.linalg.LinAlgError:
                    return fail(it)
            if not np.all(np.isfinite(c)):
                return fail(it)
            if k == 0:
                w.axpy(1.0, ar.a)
                w.axpy(c[0], ar.b)
                ar.a.axpy(c[0], ar.b)
            else:
                for j in range(k + 1):
                    ar.a.axpy(c[j], xs[j])  # the full state increment
                w.axpy(1.0, ar.a)
            lam += c[0]
            s = s + c[1:]
            ar.sync()
            ar.set_lambda(lam)
            a_norm = ar.a.norm()
            rms = a_norm / n_sqrt / ar.L
            if not (math.isfinite(rms) and math.isfinite(lam)):
                return fail(it)
            dw = max(a_norm / n_sqrt / ar.h, abs(c[0]) / max(1.0, abs(lam)))
            drift = drift + dw if dw <= 0.1 * last_dw else math.inf
            last_dw = dw
            if abs(lam - lam_p) > dlam_max:
                return fail(it)  # diverging: its iterates would only poison the factor
            small = rms < st.newton_tol and abs(c[0]) < st.newton_tol * max(1.0, abs(lam))
            if (small or (singular_ok and it >= 3)) and residual() <= ar.residual_bound(st, lam):
                ar.drift = drift
                return Correction(True, it, lam, s)
        return fail(st.max_newton_its)
    finally:
        for v in xs[1:]:
            v.destroy()
        if best_w is not None:
            best_w.destroy()
