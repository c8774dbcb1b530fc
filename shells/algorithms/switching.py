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
    ns = solver or NewtonSolver(problem)
    L = problem.length_scale()
    ar = Arclength(ns, L, settings.state_weight)
    n = ar.w.getLocalSize()
    wc = ar.w.duplicate()
    wp = wc.duplicate()
    dirs: list[Any] = []
    amp_dir = tangent = pred = defl_stab = steps = resume_prev = None
    extra: list[Any] = []
    t_start = time.perf_counter()
    try:
        ar.w.array_w[:] = cp.state[:n]
        ar.sync()
        lam_c = state_kappa(ns, ar, cp.kappa_L)
        lam_end = kappa_end * L
        ar.lam_ref = 0.01 * max(abs(lam_c), abs(lam_end))
        max_dlam = 2.0 * abs(lam_end - lam_c) + 0.1 * abs(lam_c)
        ar.w.copy(wc)
        k = 1 if control is not None else max(1, cp.multiplicity if pinned is None else pinned)
        dirs, vals = _critical_directions(problem, ar, cp.mode,
                                          max(k, cluster) if control is not None else k)
        pins = list(phase) if control is not None else dirs[1:k]  # (k = 1 with a control)
        defl_stab = Stability(problem) if deflate else None
        defl = Deflation(problem, defl_stab, deflate, keep=dirs[0]) if deflate else None
        log.info("switch: critical state at kappa L = %.6g, eigenvalues %s", lam_c,
                 ", ".join(f"{v:.3e}" for v in vals))
        # the first corrector starts off the branch, from the mode's linear prediction
        st_first = replace(settings, max_newton_its=max(settings.max_newton_its, 30))
        corrector = dict(pins=pins, wc=wc, singular_ok=True, deflate=defl, max_dlam=max_dlam,
                         keep_best=False)
        # with a control, each point off the first corrector's is converged by plain Newton to
        # ``newton_tol``: at fixed c the Jacobian is regular on the branch, and the
        # corrector's acceptance of a stalled Newton (``singular_ok``: the residual bound
        # after 3 iterations) kept states off the branch there; the deflation, which removes
        # the cluster's components from every increment, bent the branch onto others
        # (docs/design-notes.md, "Branch switching")
        strict = dict(corrector, singular_ok=False, deflate=None)
        # the first point, a small amplitude along the mode, lies next to κ_c: a corrector
        # that went farther than a quarter of κ_c (plus 1 % of the range) converged onto
        # another branch (docs/model.md, "The 1D model's closed sphere"); it is refused like a
        # failure and the next amplitude is tried
        first_corrector = dict(corrector, max_dlam=min(max_dlam,
                                                       0.25 * abs(lam_c) + ar.lam_ref))
        sgn = 1.0 if sign >= 0 else -1.0

        # the amplitude is taken along φ_0 made orthogonal (in the continuation norm's
        # inner product) to the fundamental branch's tangent at w_c: the DOF inner product is
        # not the physical one (the 1D model's unknowns carry no area weight), so φ_0 itself
        # can overlap the fundamental branch's direction, whose own motion in κ would then
        # meet the amplitude condition (docs/design-notes.md, "Branch switching")
        amp_dir, tangent = _off_branch_direction(problem, ns, ar, dirs[0])
        pred = dirs[0].copy()
        pred.scale(1.0 / (ar.cw * amp_dir.dot(dirs[0])))

        def amplitude() -> float:
            ar.w.copy(wp)
            wp.axpy(-1.0, wc)
            return ar.cw * amp_dir.dot(wp)

        c_c = 0.0 if control is None else control.dot(wc)
        by_arc = [resume is not None and resume.by_arclength]  # past a fold of the control
        arc_max = [0.0 if resume is None else resume.ds_max]  # the arclength steps' ds_max
        # the smallest arclength per unit change of c: near a fold of c it grows without bound
        stretch_min = [math.inf if resume is None or not resume.stretch_min > 0
                       else resume.stretch_min]

        def side_amplitude() -> float:
            """What decides the side: the amplitude along φ_0, or c - c_c with a control."""
            return amplitude() if control is None else control.dot(ar.w) - c_c

        def deviation() -> float:
            """The distance (continuation norm) of the state from the fundamental branch's
            linear prediction w_c + (λ - λ_c) z: unlike the amplitude along φ_0 it stays
            large on a branch that has left the mode's shape (a dimple localised at one pole
            of a sphere, whose projection on P_n can shrink and change sign)."""
            ar.w.copy(wp)
            wp.axpy(-1.0, wc)
            wp.axpy(-(ar.get_lambda() - lam_c), tangent)
            return math.sqrt(max(ar.cw * wp.dot(wp), 0.0))

        def crossed(amp: float, dev: float) -> bool:
            """On the other side of the mode: the amplitude changed sign and the state lies
            along -φ_0 (its deviation ``dev`` is mostly that amplitude), i.e. a step jumped
            across the fundamental branch, not a branch that left the mode's shape."""
            if control is not None:  # (past a fold of c, c - c_c may change sign freely)
                return amp * a1 < 0 and not by_arc[0]
            return amp * a1 < 0 and abs(amp) >= 0.5 * dev

        def point(index: int, its: int, step: float, tl: float, s: np.ndarray) -> Point:
            sc = problem.scalars()
            sc["mode_amplitude"] = amplitude()
            sc["kappa_c"] = lam_c / L  # where the branch leaves the fundamental one
            info = problem.classify_mode(wp, None)  # wp: w - w_c (left by amplitude())
            sc["deviation_m"], sc["deviation_n"] = info.m, info.n
            wp.set(0.0)
            for j, pin in enumerate(pins):
                wp.axpy(s[j], pin)
            sc["pin_force"] = float(wp.norm())
            sc["residual"] = ns.residual_norm()
            # (with the corrector's last Jacobian and ∂R/∂λ)
            sc["residual_bound"] = ar.residual_bound(settings, ar.get_lambda())
            if control is not None:  # 1: at a fixed c, 0: by arclength past a fold of c
                sc["control_parameter"] = 0.0 if by_arc[0] else 1.0
            return Point(index=index, kappa=ar.get_lambda() / L, kappa_L=ar.get_lambda(),
                         newton_its=its, step=step, dkappa_ds=tl,
                         wall_time=time.perf_counter() - t_start, scalars=sc)

        # first point: amplitude a along φ_0 (or c - c_c = a along the cluster's direction of
        # largest c), λ free
        first = None
        plane_dir, preds = amp_dir, [pred]
        if control is not None and resume is None:
            plane_dir = control.copy()
            plane_dir.scale(1.0 / ar.cw)
            preds = []
            if response:
                preds.append(_response_direction(problem, control,
                                                 max(abs(v) for v in vals)))
            for size in sorted({min(cluster, len(dirs)), min(2, len(dirs)), 1}, reverse=True):
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
        for f in (() if resume is not None else factors):
            a = sgn * ds * f
            for d in preds:
                wc.copy(wp)
                wp.axpy(a, d)
                wp.copy(ar.w)
                ar.sync()
                c = bordered_newton(ar, st_first, lam_c, plane=(plane_dir, 0.0, wp),
                                     **first_corrector)
                if c.ok and control is not None:  # converged to newton_tol from there
                    ar.w.copy(wp)
                    c = bordered_newton(ar, st_first, c.lam, plane=(plane_dir, 0.0, wp),
                                         **strict)
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
                               f"fundamental branch at amplitudes {ds} x {factors}")
        if resume is None:
            a1, dev1 = (first if control is None else side_amplitude()), deviation()
        else:
            a1, dev1 = resume.first_amplitude, resume.first_distance
        last = [dev1 if resume is None else resume.distance]  # the last accepted point's

        def jumped() -> bool:
            """A corrector that crossed to the -φ_0 side, or fell to a quarter of the last
            point's distance in one step, jumped to another branch (a long step next to a
            cluster of bifurcations; docs/design-notes.md, "Branch switching"): refused, the
            step is shortened."""
            dev = deviation()
            return crossed(side_amplitude(), dev) or dev < 0.25 * last[0]

        def checkpoint(p: Point, lam: float, ds_next: float) -> None:
            """``track`` the point ``p`` at λ = ``lam`` (the loop's), the next step
            ``ds_next``; the previous point's state and λ in ``prev``."""
            if track is not None:
                state = ar.w.array_r.copy()
                track(SwitchResume(index=p.index, lam=lam, lam_prev=prev[1], ds=ds_next,
                                   direction=direction, first_amplitude=a1,
                                   first_distance=dev1, distance=last[0], state=state,
                                   state_prev=prev[0], by_arclength=by_arc[0],
                                   ds_max=arc_max[0],
                                   stretch_min=(stretch_min[0] if math.isfinite(stretch_min[0])
                                                else 0.0)))
                prev[:] = [state, lam]

        if resume is None:
            direction = 1.0 if lam_end >= c.lam else -1.0
            index, lam, ds_next = 0, c.lam, min(max(abs(a1), settings.ds_min), settings.ds_max)
            prev = [wc.array_r.copy() if track is not None else None, lam_c]
            secant_w, lam_prev = wc, lam_c
            p = point(index, c.its, abs(a1), 0.0, c.multipliers)
            checkpoint(p, lam, ds_next)
            yield p
        else:  # after the point of ``resume``
            direction, index, lam, ds_next = (resume.direction, resume.index, resume.lam,
                                              resume.ds)
            secant_w = resume_prev = wc.duplicate()
            resume_prev.array_w[:] = resume.state_prev[:n]
            lam_prev = resume.lam_prev
            ar.w.array_w[:] = resume.state[:n]
            ar.sync()
            ar.set_lambda(lam)
            prev = [resume.state, lam]
            if release_pins is not None and index >= release_pins:
                pins.clear()
        # the last two points (their secant starts the arclength loop past a fold of c)
        cur, before = ar.w.copy(), secant_w.copy()
        extra += [cur, before]
        lam_before = lam_prev
        while True:
            if by_arc[0]:
                st = replace(settings, ds=ds_next, ds_max=arc_max[0], ds_min=1e-6 * arc_max[0],
                             max_steps=settings.max_steps - index)
            else:
                st = replace(settings, ds=ds_next, max_steps=settings.max_steps - index)
            # with a control the loop neither deflates nor accepts a stalled Newton (``strict``)
            steps = arclength_steps(ar, st, lam, lam_end, direction,
                                    secant_from=(before, lam_before), reject=jumped,
                                    control=None if by_arc[0] else control,
                                    **(corrector if control is None else strict))
            arc_last = 0.0
            for its, step, tl, s in steps:
                index += 1
                turning = False
                if control is not None and not by_arc[0]:  # what a switch to arclength needs
                    cur.copy(before)
                    ar.w.copy(cur)
                    lam_before, lam = lam, ar.get_lambda()
                    before.copy(wp)
                    wp.axpy(-1.0, cur)
                    arc_last = math.sqrt(max(ar.cw * wp.dot(wp), 0.0)
                                         + (lam - lam_before) ** 2)
                    arc_max[0] = max(arc_max[0], arc_last)
                    dc = abs(control.dot(wp))
                    stretch = arc_last / dc if dc > 0 else math.inf
                    turning = stretch > FOLD_STRETCH * stretch_min[0]
                    stretch_min[0] = min(stretch_min[0], stretch)
                p = point(index, its, step, tl, s)
                amp = side_amplitude()
                dev = deviation()
                log.debug("switch: point %d at kappa L = %.8g: amplitude %.4g, distance %.4g "
                          "(first point %.4g, %.4g)", index, p.kappa_L, amp, dev, a1, dev1)
                last[0] = dev
                if dev < min_amplitude * dev1 or crossed(amp, dev):
                    raise RuntimeError(
                        f"branch switching: back on the fundamental branch at kappa = "
                        f"{p.kappa:.6g} (mode amplitude {amp:.3g}, distance {dev:.3g}; first "
                        f"point {a1:.3g}, {dev1:.3g})")
                checkpoint(p, p.kappa_L, next_step(st, step, its))
                yield p
                if release_pins is not None and index >= release_pins and pins:
                    pins.clear()
                if turning:  # c is about to turn: on by arclength before the steps crawl
                    break
            steps.close()
            landed = abs(ar.get_lambda() - lam_end) <= 1e-12 * max(1.0, abs(lam_end))
            if (control is None or by_arc[0] or landed or index >= settings.max_steps
                    or not arc_max[0] > 0):
                break
            # c stopped moving, or is about to (a fold of c on the branch: its Jacobian at
            # fixed c is singular there): the branch goes on by arclength from the last two
            # points, steps up to the largest a step of c took (strict corrector still)
            by_arc[0] = True
            # (the last steps in c were cut towards the fold: not below a tenth of the largest)
            ds_next = min(max(arc_last, 0.1 * arc_max[0]), arc_max[0])
            log.info("switch: the control parameter turns at kappa L = %.6g; the branch goes "
                     "on by arclength", lam)
    finally:
        if steps is not None:
            steps.close()
        for v in (wc, wp, *dirs, *([] if resume_prev is None else [resume_prev]), *extra):
            v.destroy()
        for obj in (amp_dir, tangent, pred, defl_stab):
            if obj is not None:
                obj.destroy()
        if solver is None:
            ns.destroy()
