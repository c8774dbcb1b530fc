"""Critical points along a branch: detection by Hessian inertia, location, classification, modes.

``follow(model, ...)`` runs the pseudo-arclength continuation and, at every point, the inertia of
the Hessian (MUMPS LDLᵀ). A change of the negative count between two points brackets a critical
point, which is then located inside that step:

* the step is re-taken from its first point with a shorter arclength σ (same tangent, same
  bordered corrector), so σ parametrises the branch between the two points, through folds too;
* **fold** (the κ-component of the tangent changes sign in the step): the zero of dκ/ds(σ) is
  bracketed and refined (Illinois/secant steps, bisection safeguard) until the error bound of κ,
  |dκ/ds| Δσ / 2, is below ``rel_tol`` |κ|; κ at a fold is stationary, so this is cheap;
* **bifurcation** (no fold): the first σ where the negative count leaves its value at the start
  of the step is bracketed by inertia (exact, decides the side) and refined with secant steps on
  the eigenvalue nearest 0 (SLEPc), until |κ_hi - κ_lo| < ``rel_tol`` |κ|.

Several eigenvalues crossing inside one step (the 2n+1-fold eigenvalue of a perfect sphere, split
slightly by the mesh) are reported as one critical point whose ``multiplicity`` is the change of
the negative count over the step; its κ is the first crossing.

The mode: the eigenvector of the eigenvalue nearest 0 at the located point, characterised by its
normal component w = u·n° through Rayleigh quotients: on a sphere x = R² ∫|∇w|²/∫w² = n(n+1)
(spherical-harmonic degree n); on surfaces of revolution about z, m² = ∫(∂_φ w)²/∫w² (azimuthal
wavenumber m).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Iterator
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np

from shells.continuation import (
    ContinuationSettings,
    Point,
    _Arclength,
    _bordered_newton,
    continuation,
)
from shells.errors import InputError
from shells.solvers import NewtonSolver
from shells.stability import Stability, StabilityResult

log = logging.getLogger("shells")

__all__ = ["CriticalSettings", "CriticalPoint", "ModeAnalysis", "follow", "locate",
           "switch_branch"]


@dataclass(frozen=True)
class CriticalSettings:
    """How critical points are located.

    Attributes:
        rel_tol: location accuracy, relative in κ.
        max_evaluations: at most this many corrector solves per critical point.
        stop_at_fold: stop following the branch after the first fold.
        stop_at_first: stop after the first critical point of any kind.
        nev: eigenvalues computed at each trial point (nearest 0).
    """

    rel_tol: float = 1.0e-4
    max_evaluations: int = 25
    stop_at_fold: bool = True
    stop_at_first: bool = False
    nev: int = 4

    def __post_init__(self) -> None:
        if not (0 < self.rel_tol < 0.1):
            raise InputError(f"rel_tol must lie in (0, 0.1), got {self.rel_tol}")
        if self.max_evaluations < 2 or self.nev < 1:
            raise InputError("need max_evaluations >= 2 and nev >= 1")


@dataclass
class CriticalPoint:
    """A located critical point (κ absolute; κL = κ times the shape's length scale)."""

    kind: str
    kappa: float
    kappa_L: float  # noqa: N815
    kappa_lo: float
    kappa_hi: float
    negative_before: int
    negative_after: int
    multiplicity: int
    eigenvalue: float
    mode_m: int | None = None
    mode_n: int | None = None
    mode_rayleigh: dict[str, float] = field(default_factory=dict)
    evaluations: int = 0
    accuracy: float = math.nan
    after_point: int = 0
    wall_time: float = 0.0
    state: np.ndarray | None = field(default=None, repr=False)
    mode: np.ndarray | None = field(default=None, repr=False)

    def as_dict(self) -> dict[str, Any]:
        """The scalars (JSON-ready); the state and mode arrays are left out."""
        return {k: v for k, v in asdict(self).items() if k not in ("state", "mode")}


@dataclass
class _Eval:
    sigma: float
    lam: float
    count: int
    tl: float
    eig: float
    state: Any = None
    eigs: tuple[float, ...] = ()


class ModeAnalysis:
    """Rayleigh quotients of the normal component of a mode: n(n+1) on spheres, m² about z."""

    def __init__(self, model: Any) -> None:
        import ufl
        from dolfinx import fem

        self.model = model
        self.v = fem.Function(model.W)
        u, _ = model.split(self.v)
        wn = ufl.dot(u, model.n0)
        x = model._x
        grad_s = model.P0 * ufl.grad(wn)
        e_phi = ufl.as_vector([-x[1], x[0], 0.0])  # ∂x/∂φ about the z axis
        dx = model.dx
        self.forms = {"w2": fem.form(wn * wn * dx), "grad2": fem.form(ufl.dot(grad_s, grad_s) * dx),
                      "dphi2": fem.form(ufl.dot(e_phi, ufl.grad(wn)) ** 2 * dx)}

    def __call__(self, vec: Any) -> dict[str, float]:
        from dolfinx import fem
        from mpi4py import MPI

        vec.copy(self.v.x.petsc_vec)
        self.v.x.scatter_forward()
        comm = self.model.shell.comm
        vals = {k: comm.allreduce(fem.assemble_scalar(f), op=MPI.SUM)
                for k, f in self.forms.items()}
        w2 = max(vals["w2"], 1e-300)
        R = self.model.shape.R
        out = {"m2": vals["dphi2"] / w2}
        if math.isfinite(R):
            out["x"] = vals["grad2"] / w2 * R * R
        return out

    def classify(self, q: dict[str, float]) -> tuple[int | None, int | None]:
        """(m, n): n for closed spheres (m is not defined on a degenerate eigenspace), else m."""
        from shells.geometry import Sphere

        if isinstance(self.model.shape, Sphere):
            x = q["x"]
            return None, int(round((-1 + math.sqrt(1 + 4 * max(x, 0.0))) / 2))
        return int(round(math.sqrt(max(q["m2"], 0.0)))), None


class _Locator:
    """Re-takes the arclength step from a stored point with trial lengths σ."""

    def __init__(self, model: Any, st: ContinuationSettings, crit: CriticalSettings,
                 stab: Stability) -> None:
        self.model = model
        self.st = st
        # trial solves next to a singular point may need more Newton iterations
        self.st_locate = replace(st, max_newton_its=max(st.max_newton_its, 30))
        self.crit = crit
        self.stab = stab
        self.L = model.shape.characteristic_size()
        self.ns = NewtonSolver(model)
        self.ar = _Arclength(self.ns, self.L, st.state_weight)
        self.w0 = model.w.x.petsc_vec.duplicate()
        self.z = model.w.x.petsc_vec.duplicate()
        self.modes = ModeAnalysis(model)

    def destroy(self) -> None:
        self.ns.destroy()

    def start(self, w0: np.ndarray, lam0: float, tl0: float) -> None:
        """Set the step's first point and its tangent (oriented like the branch there)."""
        self.model.w.x.array[:] = w0
        self.model.w.x.scatter_forward()
        self.model.w.x.petsc_vec.copy(self.w0)
        self.lam0 = lam0
        self.ar.set_lambda(lam0)
        self.ar.tangent(None, 1.0 if tl0 >= 0 else -1.0)

    def _signed_tl(self) -> float:
        """κ-component of the unit tangent at the current point, oriented like the step's."""
        ar, ns = self.ar, self.ns
        ns.factor()
        ar.dres_dlambda()
        ar.Fl.scale(-1.0)
        ns.lin_solve(ar.Fl, self.z)
        norm = math.sqrt(ar.cw * self.z.dot(self.z) + 1.0)
        s = ar.cw * self.z.dot(ar.tw) / norm + ar.tl / norm
        return (1.0 if s >= 0 else -1.0) / norm

    def evaluate(self, sigma: float, nev: int, modes: bool = False,
                 near: _Eval | None = None) -> tuple[_Eval, list[Any]]:
        """Corrector on the hyperplane at arclength σ of the step; starts from ``near``'s state
        (shifted along the tangent) when given: Newton is slow next to a bifurcation, where the
        Jacobian is singular, so the closest known solution is the best start."""
        ar = self.ar
        w = ar.w
        self.w0.copy(w)
        w.axpy(sigma, ar.tw)
        w.copy(ar.wp)
        lam_p = self.lam0 + sigma * ar.tl
        if near is not None and near.state is not None:
            w.array_w[:] = near.state[: w.getLocalSize()]
            w.axpy(sigma - near.sigma, ar.tw)
            lam_p = near.lam + (sigma - near.sigma) * ar.tl
        ar.sync()
        st = self.st_locate
        t0 = time.perf_counter()
        ok, its, lam = _bordered_newton(ar, st, self.lam0 + sigma * ar.tl, lam_start=lam_p,
                                        singular_ok=True)
        log.debug("locate: sigma = %.6g  kappa L = %.8g  converged %s in %d its (%.1f s)",
                  sigma, lam, ok, its, time.perf_counter() - t0)
        if not ok:
            raise RuntimeError(f"corrector failed at sigma = {sigma:.3e}")
        count = self.stab.inertia()[0]
        vals, vecs = self.stab.eigenpairs(nev, modes=modes, assemble=False)
        eig = min(vals, key=abs) if vals else math.nan
        tl = self._signed_tl()
        log.debug("locate:   negative %d, eigenvalue nearest 0 %.3e, dkappa/ds %.3e (%.1f s)",
                  count, eig, tl, time.perf_counter() - t0)
        vecs_near = [vecs[int(np.argmin(np.abs(vals)))]] if modes and vals else []
        state = w.array_r.copy()
        return _Eval(sigma, lam, count, tl, eig, state, tuple(sorted(vals))), vecs_near


def locate(loc: _Locator, p0: Point, w0: np.ndarray, c0: int, p1: Point, c1: int,
           w1: np.ndarray) -> CriticalPoint:
    """Locate the critical point in the step from ``p0`` (count c0) to ``p1`` (count c1)."""
    t0 = time.perf_counter()
    crit = loc.crit
    L = loc.L
    fold = (p0.dkappa_ds >= 0) != (p1.dkappa_ds >= 0)
    loc.start(w0, p0.kappa_L, p0.dkappa_ds)
    nev = max(crit.nev, abs(c1 - c0) + 2)
    tl0 = loc.ar.tl
    lo = _Eval(0.0, p0.kappa_L, c0, tl0, math.nan)
    hi = _Eval(p1.step, p1.kappa_L, c1, p1.dkappa_ds, math.nan, w1[: loc.w0.getLocalSize()])
    evals = 0
    side_lo_prev = None
    nev = max(nev, max(c0, c1) + 3)
    track = min(c0, c1)  # the eigenvalue that crosses: the (track+1)-th smallest
    samples: list[_Eval] = []
    interpolated: tuple[float, float] | None = None

    def low_side(e: _Eval) -> bool:
        if fold:
            return (e.tl >= 0) == (tl0 >= 0)
        return e.count == c0

    def value(e: _Eval) -> float:
        if fold:
            return e.tl
        return e.eigs[track] if len(e.eigs) > track else math.nan

    def eig_root() -> tuple[float, float] | None:
        """Root of the crossing eigenvalue in κL: linear in the bracket, quadratic through the
        three samples nearest it; their difference estimates the error."""
        fl, fh = value(lo), value(hi)
        if not (math.isfinite(fl) and math.isfinite(fh) and fl * fh < 0):
            return None
        lin = lo.lam + fl * (hi.lam - lo.lam) / (fl - fh)
        pts = sorted((q for q in samples if math.isfinite(value(q))),
                     key=lambda q: abs(q.lam - lin))[:3]
        if len(pts) < 3 or len({q.lam for q in pts}) < 3:
            return None
        c = np.polyfit([q.lam - lin for q in pts], [value(q) for q in pts], 2)
        roots = np.roots(c)
        roots = roots[np.abs(roots.imag) < 1e-14].real + lin
        roots = roots[(roots - min(lo.lam, hi.lam)) * (roots - max(lo.lam, hi.lam)) <= 0]
        if roots.size == 0:
            return None
        quad = float(roots[np.argmin(np.abs(roots - lin))])
        return quad, abs(quad - lin)

    best = lo
    while evals < crit.max_evaluations:
        width = hi.sigma - lo.sigma
        if fold:
            err = max(abs(lo.tl), abs(hi.tl)) * width / 2
            if err <= crit.rel_tol * abs(best.lam) * 0.5 and evals >= 2:
                break
        else:
            if abs(hi.lam - lo.lam) <= crit.rel_tol * abs(lo.lam) * 0.5 and evals >= 1:
                break
            if width <= 1e-7 * max(hi.sigma, 1e-300):
                # κ jumps across a vanishing arclength interval: the path turns sharply, as
                # at a bifurcation made imperfect by the mesh's broken rotational symmetry;
                # the crossing cannot be pinned closer than this jump (reported as accuracy)
                break
            r = eig_root()
            if r is not None and r[1] <= 0.25 * crit.rel_tol * abs(r[0]):
                interpolated = r
                break
        # secant (regula falsi with the Illinois modification) when both ends have values
        s = 0.5 * (lo.sigma + hi.sigma)
        fl, fh = value(lo), value(hi)
        if math.isfinite(fl) and math.isfinite(fh) and fl != fh and fl * fh < 0:
            if side_lo_prev is True:
                fh *= 0.5
            elif side_lo_prev is False:
                fl *= 0.5
            cand = lo.sigma - fl * width / (fh - fl)
            if lo.sigma + 0.05 * width < cand < hi.sigma - 0.05 * width:
                s = cand
        e = None
        # Start from the step's own predictor w0 + σ τ, which has no component along the
        # critical mode: a start taken from an earlier trial solution carries round-off that
        # the nearly singular Jacobian has amplified along that mode, and Newton then lands on
        # the bifurcated branch, which the hyperplane also cuts. Nearby starts are a fallback.
        for shift, near in ((0.0, False), (0.0, True), (0.1, True), (-0.1, True)):
            s_try = s + shift * width
            try:
                e, _ = loc.evaluate(s_try, nev, near=(
                    (lo if s_try - lo.sigma <= hi.sigma - s_try else hi) if near else None))
                break
            except RuntimeError:
                continue
        if e is None:
            # right next to a bifurcation (a nearby bifurcated branch, a nearly singular
            # Jacobian) Newton may not converge: keep what is known, the bracket (and the
            # eigenvalue interpolation), and report its width as the accuracy
            r = None if fold else eig_root()
            if r is not None:
                interpolated = r
            log.info("critical point located to the bracket kappa L in [%.6g, %.6g] only: "
                     "the corrector does not converge closer to it", lo.lam, hi.lam)
            break
        evals += 1
        samples.append(e)
        if low_side(e):
            lo, side_lo_prev = e, True
        else:
            hi, side_lo_prev = e, False
        if fold:
            best = max((best, e), key=lambda q: q.lam * (1 if tl0 >= 0 else -1))
    # the located κ and a bracket that contains it
    if fold:
        sgn = 1.0 if tl0 >= 0 else -1.0
        # κ is stationary at the fold: the best sample bounds it on one side; on the other
        # side its error bound |dκ/ds| Δσ / 2 (κ(σ) is concave about the fold in direction sgn)
        err = max(abs(lo.tl), abs(hi.tl)) * (hi.sigma - lo.sigma) / 2
        lam_star = best.lam
        if math.isfinite(lo.tl) and math.isfinite(hi.tl) and lo.tl != hi.tl:
            # parabola through the tangent zero: κ* = κ(σ_i) + tl_i (σ* - σ_i) / 2
            s_star = lo.sigma - lo.tl * (hi.sigma - lo.sigma) / (hi.tl - lo.tl)
            est = [lo.lam + lo.tl * (s_star - lo.sigma) / 2,
                   hi.lam + hi.tl * (s_star - hi.sigma) / 2]
            lam_star = max(est, key=lambda v: v * sgn)
        lam_star = min(max(lam_star * sgn, best.lam * sgn), (best.lam + sgn * err) * sgn) * sgn
        bracket = (best.lam, best.lam + sgn * err)
        kind = "fold"
        accuracy = err
    else:
        fl, fh = value(lo), value(hi)
        if interpolated is not None:
            lam_star, accuracy = interpolated
        elif math.isfinite(fl) and math.isfinite(fh) and fl * fh < 0:
            lam_star = lo.lam + fl * (hi.lam - lo.lam) / (fl - fh)
            accuracy = abs(hi.lam - lo.lam)
        else:
            lam_star = 0.5 * (lo.lam + hi.lam)
            accuracy = abs(hi.lam - lo.lam) / 2
        bracket = (lo.lam, hi.lam)
        kind = "bifurcation"
    # mode at the trial point nearest the critical point (on the near side)
    near = lo if lo.sigma > 0 else hi
    try:
        e, vecs = loc.evaluate(near.sigma, nev, modes=True)
    except RuntimeError:
        e, vecs = loc.evaluate(near.sigma, nev, modes=True, near=near)
    q = loc.modes(vecs[0]) if vecs else {}
    m, n = loc.modes.classify(q) if q else (None, None)
    k_lo, k_hi = sorted((bracket[0] / L, bracket[1] / L))
    return CriticalPoint(kind=kind, kappa=lam_star / L, kappa_L=lam_star, kappa_lo=k_lo,
                         kappa_hi=k_hi, negative_before=c0, negative_after=c1,
                         multiplicity=abs(c1 - c0), eigenvalue=e.eig, mode_m=m, mode_n=n,
                         mode_rayleigh=q, evaluations=evals + 1, after_point=p0.index,
                         accuracy=accuracy / max(abs(lam_star), 1e-300),
                         wall_time=time.perf_counter() - t0, state=e.state,
                         mode=vecs[0].array_r.copy() if vecs else None)


def follow(model: Any, settings: ContinuationSettings, kappa_end: float,
           crit: CriticalSettings | None = None, *, solver: NewtonSolver | None = None,
           nev: int = 0) -> Iterator[tuple[Point, StabilityResult, list[CriticalPoint]]]:
    """Follow the branch from κ = 0 to ``kappa_end`` with stability at every point.

    Yields (point, stability, critical points located in the step that ended at this point).
    The model's state is the point's state at each yield. ``nev`` > 0 also computes that many
    eigenvalues per point.
    """
    crit = crit or CriticalSettings()
    if settings.method != "arclength":
        raise InputError("locating critical points needs the arclength method (folds)")
    ns = solver or NewtonSolver(model)
    stab = Stability(model)
    loc = _Locator(model, settings, crit, stab)
    prev: tuple[Point, np.ndarray, int] | None = None
    try:
        for p in continuation(model, settings, kappa_start=0.0, kappa_end=kappa_end, solver=ns):
            res = stab.check(nev=nev)
            found: list[CriticalPoint] = []
            if prev is not None and res.negative_count != prev[2]:
                w1 = model.w.x.array.copy()
                k1 = float(model.kappa.value)
                cp = locate(loc, prev[0], prev[1], prev[2], p, res.negative_count, w1)
                found.append(cp)
                # back to the branch point: the continuation goes on from it
                model.w.x.array[:] = w1
                model.w.x.scatter_forward()
                model.kappa.value = k1
            prev = (p, model.w.x.array.copy(), res.negative_count)
            yield p, res, found
            if found and (crit.stop_at_first or
                          (crit.stop_at_fold and any(c.kind == "fold" for c in found))):
                return
    finally:
        loc.destroy()
        stab.destroy()
        if solver is None:
            ns.destroy()


def switch_branch(model: Any, cp: CriticalPoint, settings: ContinuationSettings,
                  kappa_end: float, *, ds: float = 1.0, solver: NewtonSolver | None = None
                  ) -> Iterator[Point]:
    """Follow the branch that bifurcates at ``cp`` along its critical mode.

    The first step is a pseudo-arclength step of length ``ds`` (in the continuation norm: RMS
    displacement in thicknesses) with the tangent (φ, 0), φ the critical mode: the corrector
    works on the hyperplane orthogonal to φ, which the fundamental branch (tangent ⟂ φ) does not
    cross near the bifurcation, so it lands on the new branch. The ordinary continuation then
    takes over, oriented by the secant from the bifurcation point.

    Multiple eigenvalues: on shapes of revolution every mode m ≥ 1 comes as a (cos mφ, sin mφ)
    pair, and all directions of that plane give the same branch up to a rotation about the axis,
    so any eigenvector of the pair will do. The perfect sphere's 2n+1-fold eigenvalue is
    different: its eigenspace holds inequivalent directions (the axisymmetric Y_n^0 among them);
    the direction used is the eigenvector SLEPc returns, i.e. the one the mesh singles out.
    """
    if cp.state is None or cp.mode is None:
        raise InputError("this critical point carries no state/mode to switch from")
    ns = solver or NewtonSolver(model)
    L = model.shape.characteristic_size()
    ar = _Arclength(ns, L, settings.state_weight)
    n = ar.w.getLocalSize()
    wc = ar.w.duplicate()
    wc.array_w[:] = cp.state[:n]
    lam_c = cp.kappa_L
    # the tangent (φ, 0), unit in the continuation norm
    ar.tw.array_w[:] = cp.mode[:n]
    ar.tw.scale(1.0 / math.sqrt(ar.cw * ar.tw.dot(ar.tw)))
    ar.tl = 0.0
    wc.copy(ar.w)
    ar.w.axpy(ds, ar.tw)
    ar.w.copy(ar.wp)
    ar.sync()
    st = replace(settings, max_newton_its=max(settings.max_newton_its, 30))
    ok, _, lam1 = _bordered_newton(ar, st, lam_c, singular_ok=True)
    if not ok:
        raise RuntimeError("branch switching: the corrector did not converge off the "
                           "fundamental branch (try another ds)")
    secant = ar.w.array_r.copy() - cp.state[:n]
    try:
        yield from continuation(model, settings, kappa_start=lam1 / L, kappa_end=kappa_end,
                                solver=ns, initial_tangent=(secant, lam1 - lam_c))
    finally:
        wc.destroy()
        if solver is None:
            ns.destroy()
