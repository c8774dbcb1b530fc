"""Continuation in the natural curvature κ: natural-parameter (SNES) and pseudo-arclength
(algorithm layer, on ``shells.problem.interface.Problem``).

``continuation(problem, settings, ...)`` is a generator: it yields one ``Point`` per converged
step (scalar indicators only: κ, energy split, Ψ3, Newton iterations, the κ-component of the unit
tangent whose sign change marks a fold). The problem's state holds the current point, so a
consumer can write fields or check stability between two ``next()`` calls.

The parameter is λ = κ L (L: the problem's ``length_scale()``: R, the disk's radius).
Pseudo-arclength uses the norm ||(δw, δλ)||² = ξ² |δw|²/(N h²) + δλ² (N: number of DOFs, h: the
problem's ``state_scale()``, the thickness, so the state is measured in thicknesses;
ξ = ``state_weight``), a
predictor along the unit tangent and Keller's bordered Newton corrector on the hyperplane
orthogonal to it; two solves per iteration share one LU factorisation. The tangent orientation is
kept consistent (positive inner product with the previous one), which carries the branch around
folds (snap-through).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import asdict, dataclass, field, replace
from typing import Any, NamedTuple

import numpy as np

from shells.algorithms.newton import NewtonSolver
from shells.errors import InputError

log = logging.getLogger("shells")

__all__ = ["ContinuationSettings", "Point", "continuation", "in_arclength", "next_step"]


@dataclass(frozen=True)
class ContinuationSettings:
    """All continuation settings, validated on construction.

    Attributes:
        method: "arclength" (pseudo-arclength, passes folds) or "natural" (steps in κ, SNES).
        ds: initial step: in λ = κL for "natural", in arclength for "arclength".
        ds_min, ds_max: bounds of the adaptive step; below ds_min the run stops.
        target_newton_its: the step grows when Newton needs fewer, shrinks when more.
        max_newton_its: a corrector needing more counts as failed (step halved, retried).
        newton_tol: convergence: relative Newton increment (state RMS / L and |δλ|).
        residual_tol: an absolute bound on the residual norm that replaces the relative one
            below (None, the default: the relative bound; a value: the behaviour of versions
            that had only this absolute tolerance).
        residual_rtol: and (arclength corrector) the residual norm ||R|| at most
            ``residual_rtol`` ||∂R/∂κ|| max(|κ|, κ_ref) + ``residual_roundoff`` ε ||J||_F ||w||:
            relative to the κ-load, the force that κ imposes (κ_ref: 1 % of the run's largest
            |κ|, so the bound does not vanish where the branch crosses κ = 0), plus the
            round-off floor of a residual assembled with the Jacobian J at the state w (ε:
            machine epsilon). Both are model-independent: a stiff Jacobian (the axisymmetric
            model's C1 penalty) has a floor of up to 1e-2 ε ||J||_F ||w||, which exceeds 1e-5
            of the κ-load on thin bending-dominated shells (a disk: the load is O(h²)).
            Natural steps (SNES, no increment test) accept a residual below the same bound with
            10⁻³ ``residual_rtol``: its relative decrease of 1e-9 from the small start residual
            of a short step can lie below round-off (a P3 sphere stalled at κh ≈ 1.41).
        residual_roundoff: the factor of the round-off term (measured floors are 1e-3 to 1e-2).
        state_weight: ξ in the arclength norm.
        max_steps: safety limit on the number of points.
        kappa_stops: values of κL (natural method) the run lands on exactly.
        ds_unit: "arclength" (default) or "kappa": for the arclength method, ds, ds_min and
            ds_max are then given as steps in κL and converted with the first tangent
            (ds_arc = ds / |dλ/ds|), which makes them independent of how much the state moves
            per unit κ (a disk moves many thicknesses per unit κL, a sphere a fraction of one).
        factor_reuse: the corrector keeps the LU factorisation of an earlier iterate's
            Jacobian (a chord step: a solve instead of a factorisation) while the state has
            moved less than this since (RMS, in units of ``state_scale()``, and |δλ| in units of
            max(1, |λ|)) and the last step contracted by at least 10; the tangent at a
            converged point uses the corrector's factorisation under the same bound. Near the
            solution Newton's Jacobian changes by O(|δw|/h), so the chord steps converge as fast
            as Newton's there. 0 (the default): factor at every iteration and for the tangent.
            The surface model's ``critical`` uses 1e-5 (``REUSE_SURFACE`` in
            shells.analyses.drivers): 3 factorisations per step instead of 5, its critical points
            unchanged to 3e-11 (benchmarks/lu_per_step.py); the 1D model's ``critical`` 1e-4, with
            its default settings and the quadratic ``predictor`` (``REUSE_CRITICAL`` in
            shells.analyses.axisym_runs: 156 factorisations instead of 378 on the θ̄ = 8 cap, its
            points unchanged to 1e-8; before its eigenvalues were Rayleigh quotients the thin
            spheres' closely spaced bifurcations moved by up to 2e-5 with 1e-5, round-off).
            Not the default elsewhere: a branch's points are its result there.
        predictor: where the arclength corrector starts (the hyperplane is the tangent
            predictor's either way): "tangent" (default), the predictor itself, or
            "quadratic", the quadratic through the last two points with the tangent at the
            last (an error of O(s³) instead of O(s²): on the θ̄ = 8 cap at h/R = 0.01 a first
            Newton update of 1e-7 of the state instead of 1e-5, two iterations instead of
            three). Its converged points are the same to the Newton tolerance, but fewer
            iterations grow the adaptive step sooner, so where the step is below ``ds_max``
            the run takes other points. The 1D model's ``critical`` uses it with its default
            settings (``shells.analyses.axisym_runs``).
    """

    method: str = "arclength"
    ds: float = 0.1
    ds_min: float = 1.0e-6
    ds_max: float = 2.0
    target_newton_its: int = 4
    max_newton_its: int = 12
    newton_tol: float = 1.0e-10
    residual_tol: float | None = None
    residual_rtol: float = 1.0e-5
    residual_roundoff: float = 0.1
    state_weight: float = 1.0
    max_steps: int = 10000
    kappa_stops: tuple[float, ...] = ()
    ds_unit: str = "arclength"
    factor_reuse: float = 0.0
    predictor: str = "tangent"

    def __post_init__(self) -> None:
        if self.method not in ("arclength", "natural"):
            raise InputError(f"continuation method must be 'arclength' or 'natural', "
                             f"got {self.method!r}")
        if not (0 < self.ds_min <= self.ds <= self.ds_max):
            raise InputError(f"steps must satisfy 0 < ds_min <= ds <= ds_max, got "
                             f"{self.ds_min}, {self.ds}, {self.ds_max}")
        if self.target_newton_its < 1 or self.max_newton_its < self.target_newton_its:
            raise InputError("need 1 <= target_newton_its <= max_newton_its")
        if self.residual_tol is not None and not (isinstance(self.residual_tol, (int, float))
                                                  and math.isfinite(self.residual_tol)
                                                  and self.residual_tol > 0):
            raise InputError(f"residual_tol must be None or a positive number, got "
                             f"{self.residual_tol!r}")
        if not (isinstance(self.residual_rtol, (int, float)) and 0 < self.residual_rtol < 1):
            raise InputError(f"residual_rtol must lie in (0, 1), got {self.residual_rtol!r}")
        if not (isinstance(self.residual_roundoff, (int, float))
                and 0 <= self.residual_roundoff < math.inf):
            raise InputError(f"residual_roundoff must be a non-negative number, got "
                             f"{self.residual_roundoff!r}")
        if not self.state_weight > 0:
            raise InputError("state_weight must be positive")
        if self.ds_unit not in ("arclength", "kappa"):
            raise InputError(f"ds_unit must be 'arclength' or 'kappa', got {self.ds_unit!r}")
        if not (isinstance(self.factor_reuse, (int, float)) and 0 <= self.factor_reuse < 1):
            raise InputError(f"factor_reuse must lie in [0, 1), got {self.factor_reuse!r}")
        if self.predictor not in ("tangent", "quadratic"):
            raise InputError(f"predictor must be 'tangent' or 'quadratic', got "
                             f"{self.predictor!r}")

    def describe(self) -> dict[str, Any]:
        return asdict(self)


@dataclass
class Point:
    """One converged point of a branch (scalars only)."""

    index: int
    kappa: float
    kappa_L: float  # noqa: N815
    newton_its: int
    step: float
    dkappa_ds: float
    wall_time: float
    scalars: dict[str, float] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        d = {k: v for k, v in asdict(self).items() if k != "scalars"}
        d.update(self.scalars)
        return d


class _Arclength:
    """Vectors and norms for the bordered system."""

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
        self.problem.set_kappa(lam / self.L)

    def get_lambda(self) -> float:
        return self.problem.get_kappa() * self.L

    def sync(self) -> None:
        self.problem.sync()

    def restore(self, lam: float) -> None:
        """Back to the last converged point (after a failed step)."""
        self.w_old.copy(self.w)
        self.sync()
        self.set_lambda(lam)

    def dres_dlambda(self) -> None:
        self.ns.assemble_dkappa(self.Fl)
        self.Fl.scale(1.0 / self.L)
        self.fl_norm = float(self.Fl.norm())

    def residual_bound(self, st: ContinuationSettings, lam: float,
                       roundoff: bool = True) -> float:
        """The residual tolerance at the current state and λ (``ContinuationSettings``):
        ``residual_tol`` if given, else residual_rtol ||∂R/∂λ|| max(|λ|, λ_ref) +
        residual_roundoff ε ||J||_F ||w|| (J: the last factored Jacobian; without this term
        if not ``roundoff``: a Newton solve, which measures the round-off it stalls at)."""
        if st.residual_tol is not None:
            return st.residual_tol
        load = self.fl_norm * max(abs(lam), self.lam_ref)
        floor = self.ns.roundoff_floor(st.residual_roundoff) if roundoff else 0.0
        return st.residual_rtol * load + floor

    def tangent(self, sign_ref: tuple[Any, float] | None, direction: float,
                attempts: int = 1, reuse: bool = False) -> bool:
        """Unit tangent at the current (converged) point: J z = -R_λ, τ ∝ (z, 1). False, and
        the tangent left as it was, if the Jacobian could not be factored (in ``attempts``).
        ``reuse``: solve with the factorisation held (the corrector's, of a Jacobian within
        ``factor_reuse`` of this point) instead of factoring afresh."""
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
        """``tangent`` at a run's start, where there is no step to cut: one retry (the failed
        factor was reset), then an error."""
        if not self.tangent(sign_ref, direction, attempts=2):
            raise RuntimeError(f"the Jacobian at the start kappa L = {self.get_lambda():.6g} "
                               "could not be factored (twice)")


def continuation(problem: Any, settings: ContinuationSettings, *, kappa_start: float = 0.0,
                 kappa_end: float, solver: NewtonSolver | None = None, start_index: int = 0,
                 initial_tangent: tuple[np.ndarray, float] | None = None,
                 skip_first: bool = False, initial_ds: float | None = None,
                 tangent: tuple[np.ndarray, float] | None = None,
                 on_tangent: Callable[[np.ndarray, float], None] | None = None,
                 scalars: bool = True,
                 previous: tuple[np.ndarray, float, float] | None = None) -> Iterator[Point]:
    """Follow the branch from the problem's current state at ``kappa_start`` to ``kappa_end``.

    The first point is the (re-converged) start; the run ends on the point at ``kappa_end``
    exactly, or when the step falls below ``ds_min``, or after ``max_steps`` points.
    ``initial_tangent`` (local state array, λ part: the secant from the previous point)
    resumes a run as it was: an arclength run in its direction, a natural one with that secant
    predictor; ``initial_ds`` (None: ``settings.ds``) is the first step, the one the
    interrupted run would have taken next (``next_step``). Arclength runs: ``on_tangent(τ_w,
    τ_λ)``, if given, is called before each point is yielded with the unit tangent the next
    step's predictor follows (this rank's owned values, a copy); ``tangent`` = such a tangent
    at the start is used as it is, instead of the Jacobian's tangent there oriented by
    ``initial_tangent``: a resumed run then predicts its first step exactly as the interrupted
    one did (a tangent solved again at the restored state is the same only if the interrupted
    run solved it with that state's own factorisation, not, e.g., a corrector iterate's).
    ``scalars=False``: the points' ``scalars`` are left empty (``problem.scalars()`` is not
    called: a caller that wants critical points only). ``previous`` = (local state array, κ,
    step): the point before the start and the step that led from it to the start, for the
    quadratic predictor's first step (``ContinuationSettings.predictor``) of a resumed run.
    """
    ns = solver or NewtonSolver(problem)
    L = problem.length_scale()
    lam0, lam_end = kappa_start * L, kappa_end * L
    direction = 1.0 if lam_end >= lam0 else -1.0
    t_start = time.perf_counter()
    problem.set_kappa(kappa_start)
    ok, its = ns.solve()
    if not ok:  # once more: a failure may be transient (a failed factor is reset)
        ok, its = ns.solve()
    if not ok:
        raise RuntimeError(f"Newton did not converge at the start kappa = {kappa_start}")
    index = start_index

    def point(its: int, step: float, tl: float) -> Point:
        nonlocal index
        kappa = problem.get_kappa()
        p = Point(index=index, kappa=kappa, kappa_L=kappa * L, newton_its=its, step=step,
                  dkappa_ds=tl, wall_time=time.perf_counter() - t_start,
                  scalars=problem.scalars() if scalars else {})
        index += 1
        return p

    if initial_ds is not None:
        settings = replace(settings, ds=min(settings.ds_max, max(settings.ds_min, initial_ds)))
    if settings.method == "natural":
        yield from _natural(problem, ns, settings, lam0, lam_end, L, point, its, skip_first,
                            initial_tangent)
    else:
        yield from _arclength(ns, settings, lam0, lam_end, L, point, its, direction,
                              initial_tangent, skip_first, tangent, on_tangent, previous)


def next_step(st: ContinuationSettings, step: float, its: int) -> float:
    """The step the loop takes after a point reached with ``step`` in ``its`` iterations."""
    return min(st.ds_max, max(st.ds_min, step * _growth(its, st.target_newton_its)))


def in_arclength(st: ContinuationSettings, tl: float) -> ContinuationSettings:
    """The settings with steps in arclength: as given, or for ``ds_unit`` "kappa" converted with
    the κ-component ``tl`` of the run's first unit tangent (ds_arc = ds / |dλ/ds|), as the
    arclength loop does at a run's start (a resumed run passes the converted settings and the
    first point's ``dkappa_ds`` decides them)."""
    if st.ds_unit != "kappa":
        return st
    scale = 1.0 / max(abs(tl), 1e-6)
    return replace(st, ds_unit="arclength", ds=st.ds * scale, ds_min=st.ds_min * scale,
                   ds_max=st.ds_max * scale)


def _natural(problem, ns, st, lam0, lam_end, L, point, its0, skip_first,
             initial_tangent=None) -> Iterator[Point]:
    direction = 1.0 if lam_end >= lam0 else -1.0
    stops = sorted({s for s in st.kappa_stops if (s - lam0) * direction > 0
                    and (lam_end - s) * direction > 0} | {lam_end}, key=lambda s: s * direction)
    if not skip_first:
        yield point(its0, 0.0, direction)
    lam, ds = lam0, st.ds
    ar = _Arclength(ns, L, st.state_weight)  # for its residual bound only
    ar.lam_ref = 0.01 * max(abs(lam0), abs(lam_end))
    st_snes = replace(st, residual_rtol=1e-3 * st.residual_rtol)
    w = problem.state
    w_old, dw = w.duplicate(), w.duplicate()
    dw.set(0.0)
    if initial_tangent is not None and initial_tangent[1] != 0:
        # the secant of the two points before an interruption, as the loop would hold it
        dw.array_w[:] = initial_tangent[0][: dw.getLocalSize()]
        dw.scale(1.0 / abs(initial_tangent[1]))
    n = 0
    while stops and n < st.max_steps:
        target = stops[0]
        step = min(ds, abs(target - lam))
        new_lam = lam + direction * step
        if abs(new_lam - target) <= 1e-14 * max(1.0, abs(target)):
            new_lam = target  # a stop is landed on exactly, whatever the sum's rounding
        w.copy(w_old)
        w.axpy(step, dw)  # secant predictor (dw: the last step's dw per unit |dλ|)
        ar.sync()
        ar.set_lambda(new_lam)
        ar.dres_dlambda()
        ok, its = ns.solve(atol=ar.residual_bound(st_snes, new_lam, roundoff=False))
        # (not the first step: its zero predictor has no scale, and a start state of round-off
        # size, e.g. a meridian table's interpolated reference, none either)
        dw_norm = float(dw.norm())
        if ok and dw_norm > 0 and jumped(w, w_old, step * dw_norm):
            log.debug("continuation: a jump at kappa L = %.6g refused; step cut", new_lam)
            ok = False
        if not ok or its > st.max_newton_its:
            w_old.copy(w)
            ar.sync()
            ar.set_lambda(lam)
            ds *= 0.5
            if ds < st.ds_min:
                return
            continue
        # secant slope for the next predictor
        w.copy(dw)
        dw.axpy(-1.0, w_old)
        dw.scale(1.0 / step)
        lam = new_lam
        if abs(lam - target) <= 1e-14 * max(1.0, abs(target)):
            lam = target
            stops.pop(0)
        n += 1
        yield point(its, step, direction)
        ds = min(st.ds_max, max(st.ds_min, ds * _growth(its, st.target_newton_its)))


#: a converged step that moved the state by more than this multiple of (the state's norm +
#: the predictor's increment) landed on another solution, not the branch's next point: on a
#: 2-rank run Newton from a natural step just short of a cap's snap-through fold converged
#: in 20 iterations to a spurious root 1e4 thicknesses away (Psi3/h = 1.4e4 after -1.4)
JUMP_FACTOR = 10.0


def jumped(w: Any, w_old: Any, predicted: float) -> bool:
    """Whether the step from ``w_old`` to ``w`` (predictor increment of norm ``predicted``)
    is a jump to another solution (``JUMP_FACTOR``)."""
    scale = float(w_old.norm()) + predicted
    if scale == 0.0:
        return False  # no scale to compare with
    d = w.copy()
    d.axpy(-1.0, w_old)
    change = float(d.norm())
    d.destroy()
    return change > JUMP_FACTOR * scale


def _growth(its: int, target: int) -> float:
    return min(2.0, max(0.5, target / max(its, 1)))


def _arclength(ns, st, lam0, lam_end, L, point, its0, direction, initial_tangent,
               skip_first, tangent=None, on_tangent=None, previous=None) -> Iterator[Point]:
    ar = _Arclength(ns, L, st.state_weight)
    ar.lam_ref = 0.01 * max(abs(lam0), abs(lam_end))
    if tangent is not None:  # the interrupted run's own
        ar.tw.array_w[:] = tangent[0][: ar.tw.getLocalSize()]
        ar.tl = float(tangent[1])
    else:
        ar.start_tangent(None, direction)
    if initial_tangent is not None and tangent is None:
        tw_arr, tl = initial_tangent
        ref = ar.tw.duplicate()
        ref.array_w[:] = tw_arr[: ref.getLocalSize()]
        ar.start_tangent((ref, tl), direction)

    def told() -> None:
        if on_tangent is not None:
            on_tangent(ar.tw.array_r.copy(), ar.tl)

    if not skip_first:
        told()
        yield point(its0, 0.0, ar.tl)
    st = in_arclength(st, ar.tl)
    before = None if previous is None else (previous[0], previous[1] * L, previous[2])
    for its, step, tl, _ in arclength_steps(ar, st, lam0, lam_end, direction, previous=before):
        told()
        yield point(its, step, tl)


def arclength_steps(ar: _Arclength, st: ContinuationSettings, lam: float, lam_end: float,
                    direction: float, *, secant_from: tuple[Any, float] | None = None,
                    reject: Callable[[], bool] | None = None, control: Any = None,
                    previous: tuple[np.ndarray, float, float] | None = None,
                    **corrector: Any) -> Iterator[tuple[int, float, float, np.ndarray]]:
    """The pseudo-arclength loop, from the converged state in ``ar`` at λ = ``lam``.

    Predictor along the unit tangent (τ_w, τ_λ), the corrector (``_bordered_newton`` with
    ``corrector``'s keywords: pins, singular_ok, ...) on the hyperplane orthogonal to it, the
    step adapted to the corrector's iterations (halved after a failure, the run ends below
    ``ds_min``). With ``st.predictor`` "quadratic" (and the Jacobian's tangent, no
    ``control``) Newton starts a step's first attempt from the quadratic through the last two
    points with the tangent at the last, not from the predictor itself: the same point (the
    hyperplane is the predictor's), from an error of O(s³) instead of O(s²); ``previous`` =
    (local state array, λ, step) of the point before the start serves the first step. The
    tangent is the Jacobian's (J z = -R_λ, oriented like the previous one; ``ar.tangent`` must
    have been called at the start), or with ``secant_from`` = (w, λ) of the previous point the
    secant through the last two points (needed when the corrector carries constraints the
    Jacobian tangent does not know: the pins). The run lands exactly on λ_end when the
    predictor, or the corrector, crosses it while moving towards it (a
    corrector at fixed λ from the chord's interpolant). ``reject()``, asked after each
    converged corrector, may refuse the point (a jump to another branch): the step is halved,
    at most 3 times. Yields (iterations, step, τ_λ, the pins' multipliers) per point; the
    problem's state holds the point.

    ``control`` (a state-shaped vector e; secant tangents only): the branch is parametrised by
    c = e·w instead of its arclength. The secant is scaled to a unit change of c, the step is
    a change of c, and the corrector's hyperplane is e·(w - w_p) = 0 with λ free: natural
    continuation in c, through folds in λ, as long as c itself keeps moving along the branch
    (the run ends where it stops moving). A localised dimple is followed this way: measured
    by its depth it grows steadily, while its share of the whole state's norm, which the
    arclength measures, is small and the arclength steps let the corrector slide along the
    nearly neutral directions of a cluster of bifurcations onto other branches (a closed
    sphere's; ``shells.algorithms.critical.switch_branch``).
    """
    w = ar.w
    secant = secant_from is not None
    if control is not None and not secant:
        raise ValueError("a control parameter needs secant tangents (secant_from)")
    plane_c = scratch = None
    if control is not None:  # cw plane_c·x = e·x: the hyperplane e·(w - w_p) = 0
        plane_c = control.copy()
        plane_c.scale(1.0 / ar.cw)
        scratch = w.duplicate()
    # the previous point's state (secant tangent) or tangent (Jacobian tangent: its orientation)
    prev = w.duplicate()
    zero = w.duplicate()
    zero.set(0.0)
    if secant:
        secant_from[0].copy(prev)
        lam_prev = secant_from[1]
    # the Newton start: the predictor plus the quadratic term of the branch through the last
    # point (x(s) = x_0 + s τ_0 + s² c, x(-h) the point before: c = (x_-1 - x_0 + h τ_0)/h²),
    # an error of O(s³) instead of O(s²) (the hyperplane stays the predictor's: the same point)
    quadratic = st.predictor == "quadratic" and not secant and control is None
    last: tuple[Any, float, float] | None = None  # (w, λ, step) of the point before
    curve = w.duplicate() if quadratic else None
    if quadratic and previous is not None and previous[2] > 0:
        last = (w.duplicate(), float(previous[1]), float(previous[2]))
        last[0].array_w[:] = np.asarray(previous[0])[: w.getLocalSize()]
    ds = st.ds
    n = 0
    try:
        while n < st.max_steps:
            if secant:
                w.copy(ar.tw)
                ar.tw.axpy(-1.0, prev)
                tl = lam - lam_prev
                if control is None:
                    norm = math.sqrt(ar.cw * ar.tw.dot(ar.tw) + tl * tl)
                else:
                    norm = abs(control.dot(ar.tw))
                    if not norm > 0.0:
                        log.info("continuation: the control parameter stopped moving at "
                                 "kappa L = %.6g", lam)
                        return
                ar.tw.scale(1.0 / norm)
                ar.tl = tl / norm
            w.copy(ar.w_old)
            jumps = 0
            ds_first = ds  # the step's first attempt (a retry after a failure: the predictor)
            while True:
                lam_p = lam + ds * ar.tl
                landing = (lam_p - lam_end) * direction >= 0 and ar.tl * direction > 0
                step = ds * ((lam_end - lam) / (lam_p - lam) if landing else 1.0)
                ar.w_old.copy(w)
                w.axpy(step, ar.tw)
                w.copy(ar.wp)
                lam_start = None
                if last is not None and not landing and jumps == 0 and step == ds_first:
                    h = last[2]
                    last[0].copy(curve)  # c h² = x_-1 - x_0 + h τ_0
                    curve.axpy(-1.0, ar.w_old)
                    curve.axpy(h, ar.tw)
                    w.axpy((step / h) ** 2, curve)
                    lam_start = lam_p + (step / h) ** 2 * (last[1] - lam + h * ar.tl)
                ar.sync()
                if landing:  # λ = λ_end: the hyperplane τ = (0, 1)
                    c = _bordered_newton(ar, st, lam_end, plane=(zero, 1.0, zero), **corrector)
                else:
                    c = _bordered_newton(ar, st, lam_p, lam_start, plane=None if plane_c is None
                                         else (plane_c, 0.0, ar.wp), **corrector)
                if c.ok and not landing and (c.lam - lam_end) * direction > 0:
                    # the corrector crossed λ_end: land on it from the chord's interpolant
                    f = (lam_end - lam) / (c.lam - lam)
                    w.copy(ar.wp)
                    ar.wp.axpy(-1.0, ar.w_old)
                    ar.w_old.copy(w)
                    w.axpy(f, ar.wp)
                    ar.sync()
                    landing = True
                    step *= f
                    c = _bordered_newton(ar, st, lam_end, plane=(zero, 1.0, zero), **corrector)
                if c.ok and jumped(w, ar.w_old, step * float(ar.tw.norm())):
                    log.debug("continuation: a jump at kappa L = %.6g refused; step cut", c.lam)
                    c = c._replace(ok=False)
                if c.ok and control is not None and not landing and _turned(
                        ar, scratch, c.lam - lam, step):
                    # past a fold of the control there is no solution at the predictor's c
                    # nearby: Newton lands on another part of the branch with that c
                    log.debug("continuation: a turn at kappa L = %.6g refused; step cut", c.lam)
                    c = c._replace(ok=False)
                if c.ok and (reject is None or jumps >= 3 or not reject()):
                    if secant:
                        break
                    ar.tw.copy(prev)
                    if ar.tangent((prev, ar.tl), direction,
                                  reuse=ar.drift <= st.factor_reuse):
                        break
                    # no tangent at the new point (its Jacobian not factored): cut the step
                    log.debug("continuation: no tangent at kappa L = %.6g; step cut", c.lam)
                elif c.ok:
                    jumps += 1
                ar.restore(lam)
                ds *= 0.5
                if ds < st.ds_min:
                    log.info("continuation: step below ds_min at kappa L = %.6g", lam)
                    return
            if secant:
                ar.w_old.copy(prev)
                lam_prev = lam
            elif quadratic:
                if last is None:
                    last = (w.duplicate(), 0.0, 0.0)
                ar.w_old.copy(last[0])
                last = (last[0], lam, step)
            lam = c.lam
            n += 1
            yield c.its, step, ar.tl, c.multipliers
            if landing:
                return
            ds = min(st.ds_max, max(st.ds_min, ds * _growth(c.its, st.target_newton_its)))
    finally:
        prev.destroy()
        zero.destroy()
        for v in (plane_c, scratch, curve, None if last is None else last[0]):
            if v is not None:
                v.destroy()


#: with a ``control``, a step is refused whose secant turns from the predictor's direction by
#: more than MAX_TURN (radians) or is longer than MAX_STRETCH times the predictor's step, both
#: in the continuation norm: past a fold of the control its corrector, at a value of c the
#: branch no longer takes nearby, lands on a farther part of the branch (measured on
#: ``SubcriticalPitchforkProblem`` with c = 0.3 x + y: 27 times the predictor's step, turned by
#: 20 degrees only)
MAX_TURN = math.pi / 3
MAX_STRETCH = 3.0


def _turned(ar: _Arclength, scratch: Any, dlam: float, step: float) -> bool:
    """Whether the step from ``ar.w_old`` to the state (λ by ``dlam``) turns by more than
    ``MAX_TURN`` from the predictor's direction (τ_w, τ_λ) or stretches beyond ``MAX_STRETCH``
    times ``step`` along it."""
    ar.w.copy(scratch)
    scratch.axpy(-1.0, ar.w_old)
    dot = ar.cw * ar.tw.dot(scratch) + ar.tl * dlam
    nd = math.sqrt(max(ar.cw * scratch.dot(scratch), 0.0) + dlam * dlam)
    nt = math.sqrt(max(ar.cw * ar.tw.dot(ar.tw), 0.0) + ar.tl * ar.tl)
    return (not (nd > 0 and nt > 0) or dot < math.cos(MAX_TURN) * nd * nt
            or nd > MAX_STRETCH * step * nt)


class Correction(NamedTuple):
    """The outcome of a corrector: converged, iterations, λ, and the pins' multipliers s_j."""

    ok: bool
    its: int
    lam: float
    multipliers: np.ndarray


def _bordered_newton(ar: _Arclength, st: ContinuationSettings, lam_p: float,
                     lam_start: float | None = None, singular_ok: bool = False,
                     deflate: Any = None, *, plane: tuple[Any, float, Any] | None = None,
                     pins: Sequence[Any] = (), wc: Any = None,
                     max_dlam: float | None = None, keep_best: bool | None = None
                     ) -> Correction:
    """The corrector: Newton on R(w, λ) + Σ_j s_j ψ_j = 0 with the step's hyperplane
    cw τ_w·(w - w_p) + τ_λ (λ - λ_p) = 0 and, for each pin ψ_j, cw ψ_j·(w - w_c) = 0; unknowns
    w, λ and the multipliers s_j. Without pins this is Keller's bordered Newton.

    ``plane`` = (τ_w, τ_λ, w_p): the hyperplane (default: the ``_Arclength``'s tangent and
    predictor). (0, 1, ·) fixes λ = λ_p (landing on a given κ); (φ, 0, w_c + a φ) fixes the
    amplitude a along φ and leaves λ free, which parametrises a pitchfork regularly (branch
    switching). The pins ψ_j hold the other directions of a (nearly) multiple critical
    eigenspace at their value in w_c: a phase condition, the orientation of a buckling pattern
    on a shape of revolution (``shells.algorithms.critical.switch_branch``); s_j ψ_j is the force
    that holds it. One LU factorisation and 2 + len(pins) solves per iteration; the constraints are
    linear, so every iterate after the first satisfies them. Within ``factor_reuse`` of the
    last factored iterate the factorisation is kept (chord steps), except with
    ``singular_ok``.

    Starts from the problem's current state and ``lam_start`` (default: λ_p). ``singular_ok``:
    next to a singular point the Jacobian is nearly singular and round-off is amplified along
    the critical mode, so the increment stalls above ``newton_tol`` although the residual is
    converged; then a residual below the residual bound after 3 iterations is accepted, and if
    Newton diverges (next to a cluster of singular modes, a closed sphere's) the iterate of
    smallest residual is kept when that residual is below the bound. The residual bound is
    ``_Arclength.residual_bound`` (relative to the κ-load and the round-off floor, or
    ``residual_tol``). An iterate with |λ - λ_p| > ``max_dlam`` (default 10 max(1, |λ_p|))
    counts as divergence. ``deflate(a, b, ...)``, when given, may remove components from the
    solves of each iteration (the locator's safeguard against Newton steps that switch to a
    branch bifurcating close by).
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
        # iterate is within the bound of the branch but not on it (a trial at a fold, its
        # third iterate lost to a failed assembly, was kept 1.3e-7 off, past the fold)
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
            # depends on it; measured: reordering moved the h/R = 0.01 sphere's critical
            # state's eigenvalue from 6.2e-7 to 4.5e-7 and sent its switch onto another branch)
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
