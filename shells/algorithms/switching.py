"""Branch switching at a located bifurcation (algorithm layer, on ``shells.problem.Problem``).

``switch_branch(problem, cp, ...)`` leaves the fundamental branch along the critical mode: the
first point by the corrector on an amplitude hyperplane along the mode (orthogonal to the
fundamental branch's tangent), then pseudo-arclength steps with secant tangents, pins (phase
conditions) holding the other directions of a multiple critical eigenspace, optional deflation,
and a ``reject`` test that refuses a corrector that jumped back across the fundamental branch.
``SwitchResume`` resumes a side after its last point.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from shells.algorithms.bordered import Arclength, bordered_newton
from shells.algorithms.continuation import Point, arclength_steps, next_step
from shells.algorithms.following import state_kappa
from shells.algorithms.locate import Deflation, m_dot, m_inner
from shells.algorithms.newton import NewtonSolver
from shells.algorithms.records import CriticalPoint, SwitchResume
from shells.algorithms.settings import ContinuationSettings
from shells.algorithms.stability import Stability
from shells.errors import InputError

log = logging.getLogger("shells")

__all__ = ["FOLD_STRETCH", "RESPONSE_OPTIONS", "switch_branch"]


#: the response direction's factorisation (``_response_direction``), under the PETSc prefix
#: ``shells_response_``
RESPONSE_OPTIONS: dict[str, Any] = {"ksp_type": "preonly", "pc_type": "lu",
                                    "pc_factor_mat_solver_type": "mumps"}


def _response_direction(problem: Any, control: Any, sigma: float) -> Any:
    """The state's linear response to the functional e (``control``) as a force, on an elastic
    foundation σ M: d = (H + σ M)⁻¹ e at the current state (H: block None's Hessian, M: its
    mass), scaled to e·d = 1. In the eigenvectors φ_i (H φ_i = μ_i M φ_i) d ∝ Σ (e·φ_i)
    φ_i / (μ_i + σ): with σ the spread of a cluster of near-null eigenvalues, its members
    weigh alike and the modes beyond it fade as 1/μ_i. For a closed sphere poked at its pole
    (e: the pole's depth) that is a dimple localised there, made of every degree near the
    critical one in full, where the projection of e on the eigenvectors nearest 0 holds only
    the degrees (and the members of their 2n + 1 multiplets) that the eigensolve returned."""
    from petsc4py import PETSc

    from shells.algorithms.newton import apply_options, configure_factor, setup_factor

    stab = Stability(problem)
    A = ksp = None
    try:
        A = stab.assemble(None).copy()
        A.axpy(sigma, stab.mass(None), structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        ksp = PETSc.KSP().create(problem.comm)
        options = apply_options(ksp, "shells_response_", RESPONSE_OPTIONS)
        configure_factor(ksp, A, options)
        if not setup_factor(ksp, A, options):
            raise RuntimeError("branch switching: the response's matrix H + sigma M could "
                               "not be factored")
        d = control.duplicate()
        ksp.solve(control, d)
        problem.zero_constrained(d)
        d.scale(1.0 / control.dot(d))
        return d
    finally:
        for obj in (ksp, A):
            if obj is not None:
                obj.destroy()
        stab.destroy()


def _critical_directions(problem: Any, ar: Arclength, mode: np.ndarray, k: int
                         ) -> tuple[list[Any], list[float]]:
    """The critical eigenspace at the model's current state: the eigenvector closest to ``mode``
    first (oriented like it), then the other k - 1 eigenvectors nearest 0; zero on the gauge DOFs,
    orthogonalised (Euclidean, like the constraints that use them), unit in the continuation norm.
    Returns the vectors and their eigenvalues."""
    stab = Stability(problem)
    try:
        vals, vecs = stab.eigenpairs(max(k + 2, 4), modes=True)
    finally:
        stab.destroy()
    if not vals:
        raise RuntimeError("branch switching: no eigenpair converged at the critical state")
    n = ar.w.getLocalSize()
    ref = ar.w.duplicate()
    ref.array_w[:] = mode[:n]
    problem.zero_constrained(ref)
    rn = ref.norm()

    def overlap(i: int) -> float:
        return abs(vecs[i].dot(ref)) / max(vecs[i].norm() * rn, 1e-300)

    first = max(range(len(vals)), key=overlap)
    others = sorted((i for i in range(len(vals)) if i != first), key=lambda i: abs(vals[i]))
    dirs: list[Any] = []
    for i in [first, *others[: k - 1]]:
        v = ar.w.duplicate()
        v.array_w[:] = vecs[i].array_r
        problem.zero_constrained(v)
        for d in dirs:
            v.axpy(-v.dot(d) / d.dot(d), d)
        v.scale(1.0 / math.sqrt(ar.cw * v.dot(v)))
        dirs.append(v)
    if dirs[0].dot(ref) < 0:
        dirs[0].scale(-1.0)
    ref.destroy()
    for v in vecs:
        v.destroy()
    return dirs, [vals[i] for i in [first, *others[: k - 1]]]


def _off_branch_direction(problem: Any, ns: NewtonSolver, ar: Arclength, phi: Any
                          ) -> tuple[Any, Any]:
    """φ made orthogonal (cw inner product) to the fundamental branch's state tangent z at the
    current (critical) state, unit in the continuation norm, and z itself (dw/dλ). z = -J⁻¹
    ∂R/∂λ with its component along φ (M-orthogonal, M the mass of block None) removed: J is
    singular along φ there, so that component of the solve is undetermined."""
    z = phi.duplicate()
    if ns.factor(attempts=2):  # one retry: the failed factor was reset
        ar.dres_dlambda()
        ar.Fl.scale(-1.0)
        ns.lin_solve(ar.Fl, z)
    else:  # J singular to the factorisation: φ alone (z unknown, taken as 0 below)
        z.set(math.nan)
    stab = Stability(problem)
    try:
        M = stab.mass(None)
        z.axpy(-m_inner(M, z, phi) / max(m_dot(M, phi), 1e-300), phi)
    finally:
        stab.destroy()
    out = phi.copy()
    zz = z.dot(z)
    if zz > 0 and math.isfinite(zz):
        out.axpy(-phi.dot(z) / zz, z)
    else:
        z.set(0.0)
    out.scale(1.0 / math.sqrt(max(ar.cw * out.dot(out), 1e-300)))
    return out, z


#: with a ``control``, the branch goes on by arclength once a step's arclength per unit change
#: of the control exceeds this multiple of its smallest so far (a fold of the control ahead:
#: there it grows without bound, and the steps in the control would be cut ever shorter)
FOLD_STRETCH = 10.0


def switch_branch(problem: Any, cp: CriticalPoint, settings: ContinuationSettings,
                  kappa_end: float, *, ds: float = 0.25, solver: NewtonSolver | None = None,
                  sign: float = 1.0, pinned: int | None = None,
                  factors: tuple[float, ...] = (1.0, 0.5, 0.25, 2.0),
                  min_amplitude: float = 0.5, release_pins: int | None = None,
                  deflate: int = 0, resume: SwitchResume | None = None,
                  track: Callable[[SwitchResume], None] | None = None,
                  control: Any = None, cluster: int = 1, response: bool = False,
                  phase: Sequence[Any] = ()) -> Iterator[Point]:
    """Follow the branch that bifurcates at ``cp`` along its critical mode.

    1. The critical state w_c (``cp.state``) and its κ by least squares (``state_kappa``).
    2. The critical eigenspace there: φ_0 the eigenvector of ``cp.mode`` and, for k =
       ``cp.multiplicity`` (or ``pinned``) > 1, the k - 1 other eigenvectors nearest 0.
    3. The first point: Newton from w_c + a φ_0, a = ``sign`` × ``ds`` × each of ``factors``
       in turn, with the amplitude cw φ̂_0·(w - w_c) = a fixed and λ free: for a pitchfork
       λ - λ_c ≈ β a², a regular equation that the fundamental branch does not satisfy (φ̂_0:
       φ_0 made orthogonal to the fundamental branch's tangent).
    4. Secant pseudo-arclength steps (``arclength_steps``) from (w_c, λ_c), the other k - 1
       eigenvectors pinned at their w_c values (phase conditions: the orientation of a
       pattern on a shape of revolution is nearly neutral, and unpinned Newton drifts along
       it), to ``kappa_end``. A step that jumps across the fundamental branch is refused.

    With a ``control`` e (a localised branch: a dimple at a closed sphere's pole), the first
    direction is the combination of largest c = e·w of the ``cluster`` eigenvectors nearest 0,
    independent of which member of a cluster of nearly coincident bifurcations crossed first,
    and the branch is followed with c as its parameter until c turns (``FOLD_STRETCH``), then
    by secant arclength. The reasons: docs/design-notes.md, "Branch switching".

    Args:
        problem: the problem.
        cp: the located bifurcation, with its state and mode.
        settings: continuation settings, steps in arclength; the first step is |a|.
        kappa_end: the κ the branch lands on.
        ds: the first amplitude (RMS in thicknesses), or with a control the first change of c.
        solver: the Newton solver to use (default: a new one).
        sign: the side: +1 along φ_0, -1 against it.
        pinned: the dimension k of the critical eigenspace (default ``cp.multiplicity``).
        factors: the multiples of ``ds`` tried in turn for the first point.
        min_amplitude: the branch has led back to the fundamental branch when its distance
            from w_c + (λ - λ_c) dw/dλ falls below this fraction of the first point's.
        release_pins: drop the pins after that many points.
        deflate: every corrector omits dominant components along that many near-null
            eigenvectors of the Jacobian other than the followed mode (``Deflation``).
        resume: a ``SwitchResume`` from ``track``: the run continues after that point as the
            tracked one did (same problem partition, critical point and arguments).
        track: called as ``track(r)`` with each point's ``SwitchResume`` before it is yielded.
        control: the functional e (a state-shaped vector), e.g. a pole's depth.
        cluster: with a control, how many eigenvectors the first direction combines.
        response: with a control, try first the response (H + σ M)⁻¹ e to e as a force,
            which holds every degree of a multiplet whether or not the eigensolve returned it.
        phase: with a control, functionals pinned at their w_c values along the branch (a
            dimple's sliding over a closed sphere, which is neutral).

    Yields:
        The points, from the first one off the fundamental branch. Their ``scalars`` add
        ``mode_amplitude``, ``kappa_c``, ``deviation_m``/``deviation_n`` (the class of
        w - w_c), ``pin_force`` = ||Σ s_j ψ_j||, ``residual``, ``residual_bound`` and, with a
        control, ``control_parameter`` (1: at fixed c, 0: by arclength past a fold of c).

    Raises:
        InputError: if ``cp`` has no state or mode, ``ds`` is not positive, or the steps are
            not in arclength.
        RuntimeError: if no first point converges, or the branch leads back to the
            fundamental branch (its distance below ``min_amplitude`` times the first
            point's, or the state along -φ_0).
    """
    if cp.state is None or cp.mode is None:
        raise InputError("this critical point carries no state/mode to switch from")
    if not ds > 0:
        raise InputError(f"the first amplitude ds must be positive, got {ds}")
    if settings.ds_unit != "arclength":
        raise InputError("switch_branch takes its steps in arclength (ds_unit='arclength')")
    sw = _Switch(problem, cp, settings, kappa_end, solver, ds=ds, sign=sign, pinned=pinned,
                 factors=factors, min_amplitude=min_amplitude, release_pins=release_pins,
                 deflate=deflate, resume=resume, track=track, control=control,
                 cluster=cluster, response=response, phase=phase)
    try:
        yield from sw.run()
    finally:
        sw.destroy()


class _Switch:
    """One run of ``switch_branch``: its critical state, directions, correctors and the
    position along the bifurcated branch. The arguments are ``switch_branch``'s."""

    def __init__(self, problem: Any, cp: CriticalPoint, settings: ContinuationSettings,
                 kappa_end: float, solver: NewtonSolver | None, *, ds: float, sign: float,
                 pinned: int | None, factors: tuple[float, ...], min_amplitude: float,
                 release_pins: int | None, deflate: int, resume: SwitchResume | None,
                 track: Callable[[SwitchResume], None] | None, control: Any, cluster: int,
                 response: bool, phase: Sequence[Any]) -> None:
        self.problem, self.cp, self.settings, self.kappa_end = problem, cp, settings, kappa_end
        self.ds, self.sign, self.pinned, self.factors = ds, sign, pinned, factors
        self.min_amplitude, self.release_pins, self.deflate = min_amplitude, release_pins, deflate
        self.resume, self.track, self.control = resume, track, control
        self.cluster, self.response, self.phase = cluster, response, phase
        self.own_solver = solver is None
        self.ns = solver or NewtonSolver(problem)
        self.L = problem.length_scale()
        self.ar = Arclength(self.ns, self.L, settings.state_weight)
        self.n = self.ar.w.getLocalSize()
        self.wc = self.ar.w.duplicate()
        self.wp = self.wc.duplicate()
        self.dirs: list[Any] = []
        self.amp_dir = self.tangent = self.pred = self.defl_stab = self.steps = None
        self.resume_prev = None
        self.extra: list[Any] = []
        self.t_start = time.perf_counter()

    def destroy(self) -> None:
        """Close the arclength loop and free every vector and solver the run made."""
        if self.steps is not None:
            self.steps.close()
        for v in (self.wc, self.wp, *self.dirs,
                  *([] if self.resume_prev is None else [self.resume_prev]), *self.extra):
            v.destroy()
        for obj in (self.amp_dir, self.tangent, self.pred, self.defl_stab):
            if obj is not None:
                obj.destroy()
        if self.own_solver:
            self.ns.destroy()

    def run(self) -> Iterator[Point]:
        """The stages in order: the critical state and its directions, the first point (or
        the resumed one), the arclength steps.

        Yields:
            The points (``switch_branch``'s).
        """
        self.critical_state()
        self.set_directions()
        self.set_correctors()
        c = self.first_point()
        if self.resume is None:
            yield self.start_fresh(c)
        else:
            self.start_resumed()
        yield from self.follow()

    def critical_state(self) -> None:
        """The critical state w_c (into ``wc``) and its λ_c by least squares; the range."""
        ar = self.ar
        ar.w.array_w[:] = self.cp.state[:self.n]
        ar.sync()
        self.lam_c = state_kappa(self.ns, ar, self.cp.kappa_L)
        self.lam_end = self.kappa_end * self.L
        ar.lam_ref = 0.01 * max(abs(self.lam_c), abs(self.lam_end))
        self.max_dlam = 2.0 * abs(self.lam_end - self.lam_c) + 0.1 * abs(self.lam_c)
        ar.w.copy(self.wc)

    def set_directions(self) -> None:
        """The critical eigenspace, the pins, the deflation, and the amplitude's direction
        φ̂_0 with the fundamental branch's tangent and the first predictor."""
        problem, control = self.problem, self.control
        cp, pinned = self.cp, self.pinned
        k = 1 if control is not None else max(1, cp.multiplicity if pinned is None else pinned)
        self.dirs, self.vals = _critical_directions(
            problem, self.ar, cp.mode, max(k, self.cluster) if control is not None else k)
        # (k = 1 with a control)
        self.pins = list(self.phase) if control is not None else self.dirs[1:k]
        self.defl_stab = Stability(problem) if self.deflate else None
        self.defl = (Deflation(problem, self.defl_stab, self.deflate, keep=self.dirs[0])
                     if self.deflate else None)
        log.info("switch: critical state at kappa L = %.6g, eigenvalues %s", self.lam_c,
                 ", ".join(f"{v:.3e}" for v in self.vals))
        # the amplitude is taken along φ_0 made orthogonal (in the continuation norm's
        # inner product) to the fundamental branch's tangent at w_c: the DOF inner product is
        # not the physical one (the 1D model's unknowns carry no area weight), so φ_0 itself
        # can overlap the fundamental branch's direction, whose own motion in κ would then
        # meet the amplitude condition (docs/design-notes.md, "Branch switching")
        self.amp_dir, self.tangent = _off_branch_direction(problem, self.ns, self.ar,
                                                           self.dirs[0])
        self.pred = self.dirs[0].copy()
        self.pred.scale(1.0 / (self.ar.cw * self.amp_dir.dot(self.dirs[0])))

    def set_correctors(self) -> None:
        """The correctors' settings and keywords (first point, along the branch, strict),
        and the control's bookkeeping (its value at w_c; from ``resume`` if given)."""
        settings, ar, resume = self.settings, self.ar, self.resume
        # the first corrector starts off the branch, from the mode's linear prediction
        self.st_first = replace(settings, max_newton_its=max(settings.max_newton_its, 30))
        self.corrector = dict(pins=self.pins, wc=self.wc, singular_ok=True, deflate=self.defl,
                              max_dlam=self.max_dlam, keep_best=False)
        # with a control, each point off the first corrector's is converged by plain Newton to
        # ``newton_tol``: at fixed c the Jacobian is regular on the branch, and the
        # corrector's acceptance of a stalled Newton (``singular_ok``: the residual bound
        # after 3 iterations) kept states off the branch there; the deflation, which removes
        # the cluster's components from every increment, bent the branch onto others
        # (docs/design-notes.md, "Branch switching")
        self.strict = dict(self.corrector, singular_ok=False, deflate=None)
        # the first point, a small amplitude along the mode, lies next to κ_c: a corrector
        # that went farther than a quarter of κ_c (plus 1 % of the range) converged onto
        # another branch (docs/model.md, "The 1D model's closed sphere"); it is refused like a
        # failure and the next amplitude is tried
        self.first_corrector = dict(self.corrector, max_dlam=min(
            self.max_dlam, 0.25 * abs(self.lam_c) + ar.lam_ref))
        self.sgn = 1.0 if self.sign >= 0 else -1.0
        self.c_c = 0.0 if self.control is None else self.control.dot(self.wc)
        self.by_arc = resume is not None and resume.by_arclength  # past a fold of the control
        self.arc_max = 0.0 if resume is None else resume.ds_max  # the arclength steps' ds_max
        # the smallest arclength per unit change of c: near a fold of c it grows without bound
        self.stretch_min = (math.inf if resume is None or not resume.stretch_min > 0
                            else resume.stretch_min)

    def amplitude(self) -> float:
        """The amplitude cw φ̂_0·(w - w_c); leaves w - w_c in ``wp``."""
        self.ar.w.copy(self.wp)
        self.wp.axpy(-1.0, self.wc)
        return self.ar.cw * self.amp_dir.dot(self.wp)

    def side_amplitude(self) -> float:
        """What decides the side: the amplitude along φ_0, or c - c_c with a control."""
        if self.control is None:
            return self.amplitude()
        return self.control.dot(self.ar.w) - self.c_c

    def deviation(self) -> float:
        """The distance (continuation norm) of the state from the fundamental branch's
        linear prediction w_c + (λ - λ_c) z: unlike the amplitude along φ_0 it stays
        large on a branch that has left the mode's shape (a dimple localised at one pole
        of a sphere, whose projection on P_n can shrink and change sign)."""
        ar, wp = self.ar, self.wp
        ar.w.copy(wp)
        wp.axpy(-1.0, self.wc)
        wp.axpy(-(ar.get_lambda() - self.lam_c), self.tangent)
        return math.sqrt(max(ar.cw * wp.dot(wp), 0.0))

    def crossed(self, amp: float, dev: float) -> bool:
        """On the other side of the mode: the amplitude changed sign and the state lies
        along -φ_0 (its deviation ``dev`` is mostly that amplitude), i.e. a step jumped
        across the fundamental branch, not a branch that left the mode's shape."""
        if self.control is not None:  # (past a fold of c, c - c_c may change sign freely)
            return amp * self.a1 < 0 and not self.by_arc
        return amp * self.a1 < 0 and abs(amp) >= 0.5 * dev

    def jumped(self) -> bool:
        """A corrector that crossed to the -φ_0 side, or fell to a quarter of the last
        point's distance in one step, jumped to another branch (a long step next to a
        cluster of bifurcations; docs/design-notes.md, "Branch switching"): refused, the
        step is shortened."""
        dev = self.deviation()
        return self.crossed(self.side_amplitude(), dev) or dev < 0.25 * self.last

    def point(self, index: int, its: int, step: float, tl: float, s: np.ndarray) -> Point:
        """The ``Point`` at the current state, with the scalars ``switch_branch`` adds.

        Args:
            index: the point's index.
            its: the corrector's iterations.
            step: the step that led to it.
            tl: τ_λ there.
            s: the pins' multipliers.
        """
        problem, ar, wp = self.problem, self.ar, self.wp
        sc = problem.scalars()
        sc["mode_amplitude"] = self.amplitude()
        sc["kappa_c"] = self.lam_c / self.L  # where the branch leaves the fundamental one
        info = problem.classify_mode(wp, None)  # wp: w - w_c (left by amplitude())
        sc["deviation_m"], sc["deviation_n"] = info.m, info.n
        wp.set(0.0)
        for j, pin in enumerate(self.pins):
            wp.axpy(s[j], pin)
        sc["pin_force"] = float(wp.norm())
        sc["residual"] = self.ns.residual_norm()
        # (with the corrector's last Jacobian and ∂R/∂λ)
        sc["residual_bound"] = ar.residual_bound(self.settings, ar.get_lambda())
        if self.control is not None:  # 1: at a fixed c, 0: by arclength past a fold of c
            sc["control_parameter"] = 0.0 if self.by_arc else 1.0
        return Point(index=index, kappa=ar.get_lambda() / self.L, kappa_L=ar.get_lambda(),
                     newton_its=its, step=step, dkappa_ds=tl,
                     wall_time=time.perf_counter() - self.t_start, scalars=sc)

    def first_predictors(self) -> tuple[Any, list[Any]]:
        """The first corrector's hyperplane direction and its predictors (unit amplitude).

        Returns:
            (φ̂_0, [the mode's predictor]); with a control (and no ``resume``), new vectors:
            e / cw, and the response (if asked) and the combinations of the ``cluster``
            (then 2, 1) eigenvectors nearest 0 of largest c, each scaled to a unit change
            of c.
        """
        control, dirs = self.control, self.dirs
        if control is None or self.resume is not None:
            return self.amp_dir, [self.pred]
        plane_dir = control.copy()
        plane_dir.scale(1.0 / self.ar.cw)
        preds = []
        if self.response:
            preds.append(_response_direction(self.problem, control,
                                             max(abs(v) for v in self.vals)))
        for size in sorted({min(self.cluster, len(dirs)), min(2, len(dirs)), 1}, reverse=True):
            d = dirs[0].duplicate()
            d.set(0.0)
            for v in dirs[:size]:
                d.axpy(control.dot(v) / v.dot(v), v)
            cd = control.dot(d)
            if abs(cd) > 0.0:
                d.scale(1.0 / cd)  # unit change of c
                preds.append(d)
            else:
                d.destroy()
        return plane_dir, preds

    def first_point(self) -> Any:
        """The first point: amplitude a along φ_0 (or c - c_c = a along the cluster's
        direction of largest c), λ free, for each amplitude of ``factors`` and each predictor
        in turn until one converges; sets the first point's amplitude and distance (from
        ``resume`` when resuming).

        Returns:
            The converged ``Correction`` (None when resuming).

        Raises:
            RuntimeError: if no amplitude converges.
        """
        ar, wc, wp, control, resume = self.ar, self.wc, self.wp, self.control, self.resume
        first = c = None
        plane_dir, preds = self.first_predictors()
        for f in (() if resume is not None else self.factors):
            a = self.sgn * self.ds * f
            for d in preds:
                wc.copy(wp)
                wp.axpy(a, d)
                wp.copy(ar.w)
                ar.sync()
                c = bordered_newton(ar, self.st_first, self.lam_c, plane=(plane_dir, 0.0, wp),
                                    **self.first_corrector)
                if c.ok and control is not None:  # converged to newton_tol from there
                    ar.w.copy(wp)
                    c = bordered_newton(ar, self.st_first, c.lam, plane=(plane_dir, 0.0, wp),
                                        **self.strict)
                log.info("switch: amplitude %.4g: %s in %d its, kappa L = %.6g", a,
                         "converged" if c.ok else "failed", c.its, c.lam)
                if c.ok:
                    first = a
                    break
            if first is not None:
                break
        if control is not None and resume is None:
            for d in preds:
                d.destroy()
            plane_dir.destroy()
        if first is None and resume is None:
            raise RuntimeError("branch switching: the corrector did not converge off the "
                               f"fundamental branch at amplitudes {self.ds} x {self.factors}")
        if resume is None:
            self.a1 = first if control is None else self.side_amplitude()
            self.dev1 = self.deviation()
        else:
            self.a1, self.dev1 = resume.first_amplitude, resume.first_distance
        self.last = self.dev1 if resume is None else resume.distance  # the last point's
        return c

    def checkpoint(self, p: Point, lam: float, ds_next: float) -> None:
        """``track`` the point ``p`` at λ = ``lam`` (the loop's), the next step
        ``ds_next``; the previous point's state and λ in ``prev``."""
        if self.track is not None:
            state = self.ar.w.array_r.copy()
            self.track(SwitchResume(
                index=p.index, lam=lam, lam_prev=self.prev[1], ds=ds_next,
                direction=self.direction, first_amplitude=self.a1,
                first_distance=self.dev1, distance=self.last, state=state,
                state_prev=self.prev[0], by_arclength=self.by_arc, ds_max=self.arc_max,
                stretch_min=(self.stretch_min if math.isfinite(self.stretch_min) else 0.0)))
            self.prev = [state, lam]

    def start_fresh(self, c: Any) -> Point:
        """The first point's position and record, from its ``Correction`` ``c``.

        Returns:
            The first point (tracked).
        """
        settings, a1 = self.settings, self.a1
        self.direction = 1.0 if self.lam_end >= c.lam else -1.0
        self.index, self.lam = 0, c.lam
        self.ds_next = min(max(abs(a1), settings.ds_min), settings.ds_max)
        self.prev = [self.wc.array_r.copy() if self.track is not None else None, self.lam_c]
        self.secant_w, self.lam_prev = self.wc, self.lam_c
        p = self.point(self.index, c.its, abs(a1), 0.0, c.multipliers)
        self.checkpoint(p, self.lam, self.ds_next)
        return p

    def start_resumed(self) -> None:
        """The position after the point of ``resume``: its state, λ and the point before."""
        r, ar = self.resume, self.ar
        self.direction, self.index, self.lam, self.ds_next = r.direction, r.index, r.lam, r.ds
        self.secant_w = self.resume_prev = self.wc.duplicate()
        self.resume_prev.array_w[:] = r.state_prev[:self.n]
        self.lam_prev = r.lam_prev
        ar.w.array_w[:] = r.state[:self.n]
        ar.sync()
        ar.set_lambda(self.lam)
        self.prev = [r.state, self.lam]
        if self.release_pins is not None and self.index >= self.release_pins:
            self.pins.clear()

    def pass_settings(self) -> ContinuationSettings:
        """The settings of the next pass of arclength steps (by arclength past a fold of the
        control: steps up to the largest a step of c took)."""
        settings = self.settings
        if self.by_arc:
            return replace(settings, ds=self.ds_next, ds_max=self.arc_max,
                           ds_min=1e-6 * self.arc_max, max_steps=settings.max_steps - self.index)
        return replace(settings, ds=self.ds_next, max_steps=settings.max_steps - self.index)

    def follow(self) -> Iterator[Point]:
        """Secant pseudo-arclength steps to λ_end, with a control first at fixed steps of c,
        then (past a fold of c) by arclength.

        Yields:
            The points after the first (or the resumed) one.

        Raises:
            RuntimeError: if the branch leads back to the fundamental branch.
        """
        ar, settings, control = self.ar, self.settings, self.control
        # the last two points (their secant starts the arclength loop past a fold of c)
        self.cur, self.before = ar.w.copy(), self.secant_w.copy()
        self.extra += [self.cur, self.before]
        self.lam_before = self.lam_prev
        while True:
            st = self.pass_settings()
            # with a control the loop neither deflates nor accepts a stalled Newton (``strict``)
            self.steps = arclength_steps(ar, st, self.lam, self.lam_end, self.direction,
                                         secant_from=(self.before, self.lam_before),
                                         reject=self.jumped,
                                         control=None if self.by_arc else control,
                                         **(self.corrector if control is None else self.strict))
            self.arc_last = 0.0
            for its, step, tl, s in self.steps:
                self.index += 1
                turning = self.control_stretch() if control is not None and not self.by_arc \
                    else False
                p = self.point(self.index, its, step, tl, s)
                self.check_side(p)
                self.checkpoint(p, p.kappa_L, next_step(st, step, its))
                yield p
                if self.release_pins is not None and self.index >= self.release_pins \
                        and self.pins:
                    self.pins.clear()
                if turning:  # c is about to turn: on by arclength before the steps crawl
                    break
            self.steps.close()
            landed = abs(ar.get_lambda() - self.lam_end) <= 1e-12 * max(1.0, abs(self.lam_end))
            if (control is None or self.by_arc or landed or self.index >= settings.max_steps
                    or not self.arc_max > 0):
                break
            # c stopped moving, or is about to (a fold of c on the branch: its Jacobian at
            # fixed c is singular there): the branch goes on by arclength from the last two
            # points, steps up to the largest a step of c took (strict corrector still)
            self.by_arc = True
            # (the last steps in c were cut towards the fold: not below a tenth of the largest)
            self.ds_next = min(max(self.arc_last, 0.1 * self.arc_max), self.arc_max)
            log.info("switch: the control parameter turns at kappa L = %.6g; the branch goes "
                     "on by arclength", self.lam)

    def control_stretch(self) -> bool:
        """After a step at fixed c: the last two points, the step's arclength and its
        arclength per unit change of c (what a switch to arclength needs).

        Returns:
            Whether c is about to turn (``FOLD_STRETCH``).
        """
        ar, wp, cur, before = self.ar, self.wp, self.cur, self.before
        cur.copy(before)
        ar.w.copy(cur)
        self.lam_before, self.lam = self.lam, ar.get_lambda()
        before.copy(wp)
        wp.axpy(-1.0, cur)
        self.arc_last = math.sqrt(max(ar.cw * wp.dot(wp), 0.0)
                                  + (self.lam - self.lam_before) ** 2)
        self.arc_max = max(self.arc_max, self.arc_last)
        dc = abs(self.control.dot(wp))
        stretch = self.arc_last / dc if dc > 0 else math.inf
        turning = stretch > FOLD_STRETCH * self.stretch_min
        self.stretch_min = min(self.stretch_min, stretch)
        return turning

    def check_side(self, p: Point) -> None:
        """Record the point's distance from the fundamental branch.

        Raises:
            RuntimeError: if the branch is back on the fundamental branch (its distance
                below ``min_amplitude`` times the first point's, or the state along -φ_0).
        """
        amp = self.side_amplitude()
        dev = self.deviation()
        log.debug("switch: point %d at kappa L = %.8g: amplitude %.4g, distance %.4g "
                  "(first point %.4g, %.4g)", self.index, p.kappa_L, amp, dev, self.a1,
                  self.dev1)
        self.last = dev
        if dev < self.min_amplitude * self.dev1 or self.crossed(amp, dev):
            raise RuntimeError(
                f"branch switching: back on the fundamental branch at kappa = "
                f"{p.kappa:.6g} (mode amplitude {amp:.3g}, distance {dev:.3g}; first "
                f"point {self.a1:.3g}, {self.dev1:.3g})")
