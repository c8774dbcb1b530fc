"""Continuation in the natural curvature κ: natural-parameter (SNES) and pseudo-arclength
(algorithm layer, on ``shells.problem.interface.Problem``).

``continuation(problem, settings, ...)`` is a generator: it yields one ``Point`` per converged
step (scalar indicators only: κ, energy split, Ψ3, Newton iterations, the κ-component of the unit
tangent whose sign change marks a fold). The problem's state holds the current point, so a
consumer can write fields or check stability between two ``next()`` calls.

The parameter is λ = κ L (L: the problem's ``length_scale()``: R, the disk's radius).
Pseudo-arclength uses the norm ||(δw, δλ)||² = ξ² |δw|²/(N h²) + δλ² (N: number of DOFs, h: the
problem's ``state_scale()``, the thickness, so the state counts in thicknesses;
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
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np

from shells.algorithms.bordered import Arclength, bordered_newton
from shells.algorithms.newton import NewtonSolver
from shells.algorithms.settings import ContinuationSettings, in_arclength

log = logging.getLogger("shells")

__all__ = ["Point", "arclength_steps", "continuation", "jumped", "next_step"]


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
        """The point as one flat dict: its fields, then its scalars."""
        d = {k: v for k, v in asdict(self).items() if k != "scalars"}
        d.update(self.scalars)
        return d


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
    exactly, or when the step falls below ``ds_min``, or after ``max_steps`` points. The
    problem's state holds each point while it is yielded.

    Args:
        problem: the problem, its state the start.
        settings: the method, steps and tolerances.
        kappa_start: the start's κ.
        kappa_end: the κ the run lands on.
        solver: the Newton solver to use (default: a new one).
        start_index: the first point's ``index``.
        initial_tangent: (local state array, λ part), the secant from the previous point:
            resumes a run as it was, an arclength run in its direction, a natural one with
            that secant predictor.
        skip_first: do not yield the start (a resumed run has it already).
        initial_ds: the first step (None: ``settings.ds``), e.g. the one an interrupted run
            would have taken next (``next_step``).
        tangent: (τ_w, τ_λ), a unit tangent at the start (as ``on_tangent`` gave it), used as
            it is instead of the Jacobian's tangent there: a resumed run then predicts its
            first step exactly as the interrupted one did (a tangent solved again at the
            restored state is the same only if the interrupted run solved it with that
            state's own factorisation, not, e.g., a corrector iterate's). Arclength only.
        on_tangent: called as ``on_tangent(τ_w, τ_λ)`` before each point is yielded, with the
            unit tangent the next step's predictor follows (this rank's owned values, a
            copy). Arclength only.
        scalars: False: the points' ``scalars`` are left empty (``problem.scalars()`` is not
            called: a caller that wants critical points only).
        previous: (local state array, κ, step): the point before the start and the step that
            led from it to the start, for the quadratic predictor's first step
            (``ContinuationSettings.predictor``) of a resumed run.

    Yields:
        One ``Point`` per converged step.

    Raises:
        RuntimeError: if Newton does not converge at the start (two attempts).
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
    """The step the loop takes after a point reached with ``step`` in ``its`` iterations.

    Args:
        st: the settings (``ds_min``, ``ds_max``, ``target_newton_its``).
        step: the step that reached the point.
        its: the corrector's iterations there.

    Returns:
        ``step`` scaled by target / its (within a factor 2 either way), clipped to
        [``ds_min``, ``ds_max``].
    """
    return min(st.ds_max, max(st.ds_min, step * _growth(its, st.target_newton_its)))


def _natural(problem, ns, st, lam0, lam_end, L, point, its0, skip_first,
             initial_tangent=None) -> Iterator[Point]:
    direction = 1.0 if lam_end >= lam0 else -1.0
    stops = sorted({s for s in st.kappa_stops if (s - lam0) * direction > 0
                    and (lam_end - s) * direction > 0} | {lam_end}, key=lambda s: s * direction)
    if not skip_first:
        yield point(its0, 0.0, direction)
    lam, ds = lam0, st.ds
    ar = Arclength(ns, L, st.state_weight)  # for its residual bound only
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
#: the predictor's increment) landed on another solution, not the branch's next point (Newton
#: from a step just short of a fold can converge to a distant spurious root:
#: docs/design-notes.md, "Jumps of the corrector")
JUMP_FACTOR = 10.0


def jumped(w: Any, w_old: Any, predicted: float) -> bool:
    """Whether a converged step jumped to another solution (``JUMP_FACTOR``).

    Args:
        w: the converged state.
        w_old: the state before the step.
        predicted: the norm of the predictor's increment.

    Returns:
        True if ||w - w_old|| exceeds ``JUMP_FACTOR`` (||w_old|| + ``predicted``); False when
        that scale is 0.
    """
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
    ar = Arclength(ns, L, st.state_weight)
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


def arclength_steps(ar: Arclength, st: ContinuationSettings, lam: float, lam_end: float,
                    direction: float, *, secant_from: tuple[Any, float] | None = None,
                    reject: Callable[[], bool] | None = None, control: Any = None,
                    previous: tuple[np.ndarray, float, float] | None = None,
                    **corrector: Any) -> Iterator[tuple[int, float, float, np.ndarray]]:
    """The pseudo-arclength loop, from the converged state in ``ar`` at λ = ``lam``.

    Predictor along the unit tangent (τ_w, τ_λ), the corrector (``bordered_newton``) on the
    hyperplane orthogonal to it, the step adapted to the corrector's iterations (halved after
    a failure; the run ends below ``ds_min``). With ``st.predictor`` "quadratic" (and the
    Jacobian's tangent, no ``control``) Newton starts a step's first attempt from the
    quadratic through the last two points with the tangent at the last: the same point (the
    hyperplane is the predictor's), from an error of O(s³) instead of O(s²). The run lands
    exactly on λ_end when the predictor, or the corrector, crosses it while moving towards it
    (a corrector at fixed λ from the chord's interpolant). The problem's state holds each
    point while it is yielded.

    Args:
        ar: the vectors and norms, holding the converged start; with the Jacobian's tangent
            ``ar.tangent`` must have been called at the start.
        st: the settings, steps in arclength (``in_arclength``).
        lam: the start's λ.
        lam_end: the λ the run lands on.
        direction: the sign of the run's direction in λ.
        secant_from: (w, λ) of the point before the start: secant tangents through the last
            two points instead of the Jacobian's (J z = -R_λ, oriented like the previous
            one). Needed when the corrector carries constraints the Jacobian tangent does not
            know: the pins.
        reject: asked after each converged corrector; True refuses the point (a jump to
            another branch) and halves the step, at most 3 times a step.
        control: a state-shaped vector e (secant tangents only): the branch is parametrised
            by c = e·w instead of its arclength. The secant is scaled to a unit change of c,
            the step is a change of c, and the corrector's hyperplane is e·(w - w_p) = 0 with
            λ free: natural continuation in c, through folds in λ, as long as c keeps moving
            (the run ends where it stops). A localised dimple is followed this way: its depth
            grows steadily, while its share of the whole state's norm, which the arclength
            weighs, is small, and arclength steps let the corrector slide along the nearly
            neutral directions of a cluster of bifurcations onto other branches (a closed
            sphere's; ``shells.algorithms.switching.switch_branch``).
        previous: (local state array, λ, step) of the point before the start, for the
            quadratic predictor's first step.
        **corrector: keywords of ``bordered_newton`` (pins, singular_ok, deflate, ...).

    Yields:
        (iterations, step, τ_λ, the pins' multipliers) per point.

    Raises:
        ValueError: if ``control`` is given without ``secant_from``.
    """
    if control is not None and secant_from is None:
        raise ValueError("a control parameter needs secant tangents (secant_from)")
    loop = _ArclengthLoop(ar, st, lam, lam_end, direction, secant_from, reject, control,
                          previous, corrector)
    try:
        yield from loop.points()
    finally:
        loop.destroy()


class _ArclengthLoop:
    """One run of ``arclength_steps``: its position (λ, the step ``ds``), the previous
    point's state and work vectors. The arguments are ``arclength_steps``'s."""

    def __init__(self, ar: Arclength, st: ContinuationSettings, lam: float, lam_end: float,
                 direction: float, secant_from: tuple[Any, float] | None,
                 reject: Callable[[], bool] | None, control: Any,
                 previous: tuple[np.ndarray, float, float] | None,
                 corrector: dict[str, Any]) -> None:
        self.ar, self.st, self.lam, self.lam_end, self.direction = ar, st, lam, lam_end, direction
        self.reject, self.control, self.corrector = reject, control, corrector
        w = ar.w
        self.secant = secant_from is not None
        self.plane_c = self.scratch = None
        if control is not None:  # cw plane_c·x = e·x: the hyperplane e·(w - w_p) = 0
            self.plane_c = control.copy()
            self.plane_c.scale(1.0 / ar.cw)
            self.scratch = w.duplicate()
        # the previous point's state (secant tangent) or tangent (Jacobian tangent: its
        # orientation)
        self.prev = w.duplicate()
        self.zero = w.duplicate()
        self.zero.set(0.0)
        self.lam_prev = math.nan
        if secant_from is not None:
            secant_from[0].copy(self.prev)
            self.lam_prev = secant_from[1]
        # the Newton start: the predictor plus the quadratic term of the branch through the
        # last point (x(s) = x_0 + s τ_0 + s² c, x(-h) the point before: c = (x_-1 - x_0 +
        # h τ_0)/h²), an error of O(s³) instead of O(s²) (the hyperplane stays the
        # predictor's: the same point)
        self.quadratic = st.predictor == "quadratic" and not self.secant and control is None
        self.last: tuple[Any, float, float] | None = None  # (w, λ, step) of the point before
        self.curve = w.duplicate() if self.quadratic else None
        if self.quadratic and previous is not None and previous[2] > 0:
            self.last = (w.duplicate(), float(previous[1]), float(previous[2]))
            self.last[0].array_w[:] = np.asarray(previous[0])[: w.getLocalSize()]
        self.ds = st.ds

    def destroy(self) -> None:
        """Free the work vectors."""
        self.prev.destroy()
        self.zero.destroy()
        for v in (self.plane_c, self.scratch, self.curve,
                  None if self.last is None else self.last[0]):
            if v is not None:
                v.destroy()

    def points(self) -> Iterator[tuple[int, float, float, np.ndarray]]:
        """The loop: a tangent, a converged step, the bookkeeping, per point.

        Yields:
            (iterations, step, τ_λ, the pins' multipliers) per point.
        """
        ar, st = self.ar, self.st
        n = 0
        while n < st.max_steps:
            if self.secant and not self.secant_tangent():
                return
            got = self.next_point()
            if got is None:
                return
            c, step, landing = got
            if self.secant:
                ar.w_old.copy(self.prev)
                self.lam_prev = self.lam
            elif self.quadratic:
                if self.last is None:
                    self.last = (ar.w.duplicate(), 0.0, 0.0)
                ar.w_old.copy(self.last[0])
                self.last = (self.last[0], self.lam, step)
            self.lam = c.lam
            n += 1
            yield c.its, step, ar.tl, c.multipliers
            if landing:
                return
            self.ds = min(st.ds_max, max(st.ds_min,
                                         self.ds * _growth(c.its, st.target_newton_its)))

    def secant_tangent(self) -> bool:
        """The unit secant tangent through the last two points into (``tw``, ``tl``), or with
        a control its scaling to a unit change of c.

        Returns:
            False if the control parameter stopped moving (the run ends).
        """
        ar, control = self.ar, self.control
        ar.w.copy(ar.tw)
        ar.tw.axpy(-1.0, self.prev)
        tl = self.lam - self.lam_prev
        if control is None:
            norm = math.sqrt(ar.cw * ar.tw.dot(ar.tw) + tl * tl)
        else:
            norm = abs(control.dot(ar.tw))
            if not norm > 0.0:
                log.info("continuation: the control parameter stopped moving at "
                         "kappa L = %.6g", self.lam)
                return False
        ar.tw.scale(1.0 / norm)
        ar.tl = tl / norm
        return True

    def next_point(self) -> tuple[Any, float, bool] | None:
        """The next point: steps tried, halved after each failure or refusal, until one is
        accepted (with the Jacobian's tangent: its tangent computed too).

        Returns:
            (the ``Correction``, the step, whether it landed on λ_end); None when the step
            fell below ``ds_min`` (the problem back at the last point).
        """
        ar, st, reject = self.ar, self.st, self.reject
        ar.w.copy(ar.w_old)
        jumps = 0
        ds_first = self.ds  # the step's first attempt (a retry after a failure: the predictor)
        while True:
            c, step, landing = self.correct(self.ds, ds_first, jumps)
            if c.ok and (reject is None or jumps >= 3 or not reject()):
                if self.secant:
                    return c, step, landing
                ar.tw.copy(self.prev)
                if ar.tangent((self.prev, ar.tl), self.direction,
                              reuse=ar.drift <= st.factor_reuse):
                    return c, step, landing
                # no tangent at the new point (its Jacobian not factored): cut the step
                log.debug("continuation: no tangent at kappa L = %.6g; step cut", c.lam)
            elif c.ok:
                jumps += 1
            ar.restore(self.lam)
            self.ds *= 0.5
            if self.ds < st.ds_min:
                log.info("continuation: step below ds_min at kappa L = %.6g", self.lam)
                return None

    def correct(self, ds: float, ds_first: float, jumps: int) -> tuple[Any, float, bool]:
        """One attempt of step ``ds`` from the last point (``ar.w_old``): predictor,
        corrector, a landing on λ_end if the step crosses it, and the refusal of a jump (or,
        with a control, of a turn).

        Args:
            ds: the step tried.
            ds_first: the step's first attempt (only it starts from the quadratic predictor).
            jumps: the attempts of this step refused by ``reject`` so far.

        Returns:
            (the ``Correction``, the step taken, whether it lands on λ_end).
        """
        ar, st, lam, lam_end, corrector = self.ar, self.st, self.lam, self.lam_end, self.corrector
        w = ar.w
        lam_p = lam + ds * ar.tl
        landing = (lam_p - lam_end) * self.direction >= 0 and ar.tl * self.direction > 0
        step = ds * ((lam_end - lam) / (lam_p - lam) if landing else 1.0)
        ar.w_old.copy(w)
        w.axpy(step, ar.tw)
        w.copy(ar.wp)
        lam_start = None
        if self.last is not None and not landing and jumps == 0 and step == ds_first:
            lam_start = self.quadratic_start(step, lam_p)
        ar.sync()
        if landing:  # λ = λ_end: the hyperplane τ = (0, 1)
            c = bordered_newton(ar, st, lam_end, plane=(self.zero, 1.0, self.zero), **corrector)
        else:
            c = bordered_newton(ar, st, lam_p, lam_start, plane=None if self.plane_c is None
                                else (self.plane_c, 0.0, ar.wp), **corrector)
        if c.ok and not landing and (c.lam - lam_end) * self.direction > 0:
            # the corrector crossed λ_end: land on it from the chord's interpolant
            f = (lam_end - lam) / (c.lam - lam)
            w.copy(ar.wp)
            ar.wp.axpy(-1.0, ar.w_old)
            ar.w_old.copy(w)
            w.axpy(f, ar.wp)
            ar.sync()
            landing = True
            step *= f
            c = bordered_newton(ar, st, lam_end, plane=(self.zero, 1.0, self.zero), **corrector)
        if c.ok and jumped(w, ar.w_old, step * float(ar.tw.norm())):
            log.debug("continuation: a jump at kappa L = %.6g refused; step cut", c.lam)
            c = c._replace(ok=False)
        if c.ok and self.control is not None and not landing and _turned(
                ar, self.scratch, c.lam - lam, step):
            # past a fold of the control there is no solution at the predictor's c nearby:
            # Newton lands on another part of the branch with that c
            log.debug("continuation: a turn at kappa L = %.6g refused; step cut", c.lam)
            c = c._replace(ok=False)
        return c, step, landing

    def quadratic_start(self, step: float, lam_p: float) -> float:
        """Add the quadratic term to the predicted state (``ar.w``).

        Args:
            step: the step taken.
            lam_p: the predictor's λ.

        Returns:
            The λ Newton starts from, on the same quadratic.
        """
        ar, (w_last, lam_last, h) = self.ar, self.last
        w_last.copy(self.curve)  # c h² = x_-1 - x_0 + h τ_0
        self.curve.axpy(-1.0, ar.w_old)
        self.curve.axpy(h, ar.tw)
        ar.w.axpy((step / h) ** 2, self.curve)
        return lam_p + (step / h) ** 2 * (lam_last - self.lam + h * ar.tl)


#: with a ``control``, a step is refused whose secant turns from the predictor's direction by
#: more than MAX_TURN (radians) or is longer than MAX_STRETCH times the predictor's step, both
#: in the continuation norm: past a fold of the control its corrector, at a value of c the
#: branch does not take nearby, lands on a farther part of the branch, which may lie in
#: nearly the same direction (docs/design-notes.md, "Jumps of the corrector")
MAX_TURN = math.pi / 3
MAX_STRETCH = 3.0


def _turned(ar: Arclength, scratch: Any, dlam: float, step: float) -> bool:
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
