"""Critical points along a branch: detection by Hessian inertia, location, classification, modes
(algorithm layer, on ``shells.problem.Problem``).

``follow(problem, ...)`` runs the pseudo-arclength continuation and, at every point, the inertia of
every stability block it is given (MUMPS LDLᵀ): the Hessian (block ``None``; the surface model's
only block) or the axisymmetric model's Fourier blocks H_m. A change of a block's negative count
between two points brackets a critical point, a sign change of dκ/ds a fold; both are located
inside that step (``locate``):

* the step is re-taken from its first point with a shorter arclength σ (same tangent, same
  bordered corrector), so σ parametrises the branch between the two points, through folds too;
* **fold**: the zero of dκ/ds(σ) is bracketed and refined (Illinois/secant steps, bisection
  safeguard) until the error bound of κ, |dκ/ds| Δσ / 2, is below ``rel_tol`` |κ|; κ at a fold
  is stationary, so this is cheap. The step is then searched for crossings up to the fold's
  near side (a loss of symmetry just before a snap);
* **bifurcation**: the first σ where the negative count of one of the changed blocks leaves its
  value at the start of the step is bracketed by inertia (exact, decides the side; where the
  problem's eigenvalues are Rayleigh quotients by quadrature, ``Stability.eigenpairs``, the
  crossing eigenvalue's sign decides it within the factorisation's round-off of 0) and refined
  with secant steps on the crossing eigenvalue (SLEPc) until |κ_hi - κ_lo| < ``rel_tol`` |κ|
  or until its root, interpolated through the trials nearest it, is that accurate. All changed
  blocks are bracketed together, so the first crossing of any is found: a closed sphere's
  2n+1 multiplet (split by the mesh by < 1e-4 in κ) and its neighbouring degrees spread over
  dozens of Fourier blocks; a trial stops factorising at the first block that moved. Each other
  changed block's first crossing is located as well unless ``max_critical`` says otherwise.

Several eigenvalues of one block crossing inside one step are reported as one critical point
whose ``multiplicity`` is the change of that block's negative count over the step; its κ is the
first crossing. The mode: the eigenvector of the eigenvalue nearest 0 of the crossing block at
the trial nearest the point, named by the problem's ``classify_mode`` (m from the block or the
mode's Rayleigh quotients, n on spheres).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Hashable, Iterable, Iterator, Sequence
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np

from shells.continuation import (
    ContinuationSettings,
    Point,
    _Arclength,
    _bordered_newton,
    arclength_steps,
    continuation,
    in_arclength,
    next_step,
)
from shells.errors import InputError
from shells.problem import get_state, set_state
from shells.solvers import NewtonSolver
from shells.stability import Stability, StabilityResult

log = logging.getLogger("shells")

__all__ = ["CriticalSettings", "CriticalPoint", "FollowResume", "SwitchResume", "follow",
           "locate", "locate_between", "switch_branch"]


#: the eigenvalues near 0 of a stability block are reproducible only to about this multiple
#: of their change when the point is solved again at a κ shifted by round-off
#: (``_Locator.eigenvalue_roundoff``), so a crossing only to that over |dμ/dκ|, which the
#: reported accuracy includes. Set when the eigenvalues were the shift-invert's (measured,
#: benchmarks/locator_noise.py, on the 1D model's m = 2 block of the θ̄ = 15.11 cap going down,
#: h/R = 0.01, ||H||_F = 4.6e9, dμ/dκR = 2.3e-3: the state solved again at κ (1 ± 1e-10) moved
#: the crossing eigenvalue by up to 1.9e-7, the trial states scattered it by 3.5e-7 run against
#: run and the located κ by 3.1e-4 relative; with this factor the runs reported 1.5e-4 to
#: 7.0e-4). Where the problem gives Rayleigh quotients (``Stability.eigenpairs``) the change
#: is 1e-12 there, the located κ spread 3e-11 and the reported accuracy 2e-9
EIGEN_ROUNDOFF = 6.0
#: the relative shift of κ at which ``_Locator.eigenvalue_roundoff`` solves a point again
ROUNDOFF_SHIFT = 1.0e-10
#: Krylov subspace of the round-off measurement's solves (one eigenvalue, nearest 0): 8 converges
#: as 24 does (the same value to 1e-12 on the θ̄ = 8 cap) at half the cost of a solve
ROUNDOFF_NCV = 8


@dataclass(frozen=True)
class CriticalSettings:
    """How critical points are located.

    Attributes:
        rel_tol: location accuracy, relative in κ.
        max_evaluations: at most this many corrector solves per critical point.
        stop_at_fold: stop following the branch after the first fold.
        stop_at_first: stop after the first critical point of any kind.
        max_critical: stop after this many critical points (None: no limit).
        folds_only_after_first: after the first bifurcation, stop computing inertia (the
            counts are carried) and locate folds only: the branch is then followed up to its
            fold at the price of the corrector alone.
        nev: eigenvalues computed at each trial point (nearest 0).
        deflate: in steps without a fold, the locator's corrector omits from each Newton step
            its components along the ``deflate`` eigenvectors of the Jacobian nearest 0 when
            such a component exceeds 10 times the rest of the step: round-off amplified by
            the nearly singular Jacobian, or the start of a switch to a branch bifurcating
            close by (a closed sphere's cluster of axisymmetric modes). Costs one eigensolve
            per Newton iteration: for the 1D model. 0 (default): off.
    """

    rel_tol: float = 1.0e-4
    max_evaluations: int = 25
    stop_at_fold: bool = True
    stop_at_first: bool = False
    max_critical: int | None = None
    folds_only_after_first: bool = False
    nev: int = 4
    deflate: int = 0

    def __post_init__(self) -> None:
        if not (0 < self.rel_tol < 0.1):
            raise InputError(f"rel_tol must lie in (0, 0.1), got {self.rel_tol}")
        if self.max_evaluations < 2 or self.nev < 1:
            raise InputError("need max_evaluations >= 2 and nev >= 1")
        if self.max_critical is not None and not (isinstance(self.max_critical, int)
                                                  and self.max_critical >= 1):
            raise InputError(f"max_critical must be a positive integer, got "
                             f"{self.max_critical!r}")
        if not (isinstance(self.deflate, int) and 0 <= self.deflate <= 20):
            raise InputError(f"deflate must be an integer in [0, 20], got {self.deflate!r}")


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
    block: Any = None
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
class FollowResume:
    """Where ``follow`` stood after one of its points: what a resumed ``follow`` needs to
    continue after that point as the uninterrupted run did (a checkpoint).

    Attributes:
        index: the point's index.
        kappa, kappa_prev: κ at the point and at the one before it (the point's own κ at the
            first point): their secant orients the first tangent after a resume.
        dkappa_ds: the κ-component of the point's unit tangent (a fold: its sign changes).
        newton_its, step: the corrector's iterations and the arclength step to the point.
        ds: the next step, in arclength (``continuation.next_step``; the first step after
            the first point).
        tl0: the first point's ``dkappa_ds``, with which steps given in κL (``ds_unit``
            "kappa") were converted to arclength (``continuation.in_arclength``).
        counts: the negative count of each stability block at the point (blocks in a stable
            order: ``None`` first); the first step after a resume is searched for a change.
        found: critical points located up to the point.
        folds_only: inertia no longer computed (``folds_only_after_first``).
        ended: the run ended at the point (its stop rule, or ``kappa_end`` reached): a resumed
            ``follow`` yields nothing.
        state, state_prev: this rank's owned state values at the point and at the one before
            it (the point's own at the first point).
        tangent: the state part of the unit tangent at the point that the next step's
            predictor follows (owned values; its κ part is ``dkappa_ds``): the resumed run
            predicts with it (None: the Jacobian's tangent there, oriented by the secant).
    """

    index: int
    kappa: float
    kappa_prev: float
    dkappa_ds: float
    newton_its: int
    step: float
    ds: float
    tl0: float
    counts: dict[Hashable, int]
    found: int = 0
    folds_only: bool = False
    ended: bool = False
    state: np.ndarray = field(default=None, repr=False)
    state_prev: np.ndarray = field(default=None, repr=False)
    tangent: np.ndarray | None = field(default=None, repr=False)

    def scalars(self) -> dict[str, Any]:
        """The scalars (JSON-ready: ``counts`` as [[block, count], ...]); the arrays are
        left out."""
        d = {k: v for k, v in asdict(self).items()
             if k not in ("state", "state_prev", "tangent")}
        d["counts"] = [[b, int(c)] for b, c in sorted(self.counts.items(),
                                                      key=lambda bc: _block_key(bc[0]))]
        return d

    @classmethod
    def from_scalars(cls, d: dict[str, Any], state: np.ndarray, state_prev: np.ndarray,
                     tangent: np.ndarray | None = None) -> FollowResume:
        """The inverse of ``scalars``, with the arrays."""
        d = dict(d)
        d["counts"] = {b: int(c) for b, c in d["counts"]}
        return cls(**d, state=state, state_prev=state_prev, tangent=tangent)


@dataclass
class SwitchResume:
    """Where ``switch_branch`` stood after one of its points: what a resumed ``switch_branch``
    needs to continue after that point as the uninterrupted run did (a checkpoint).

    Attributes:
        index: the point's index.
        lam, lam_prev: λ = κL of the point and of the one before it (λ_c before the first): the
            secant the next predictor follows.
        ds: the next step (the arclength loop's, ``continuation.next_step``).
        direction: the sign of the loop's direction in λ.
        first_amplitude, first_distance: the first point's mode amplitude a and distance from
            the fundamental branch, and ``distance`` the point's: what the return and jump
            tests measure against.
        state, state_prev: this rank's owned state values at the point and at the one before
            it (w_c before the first).
        by_arclength, ds_max, stretch_min: a branch followed with a ``control`` went on by
            arclength past a fold of the control (``switch_branch``), with this largest step;
            the smallest arclength per unit change of the control so far.
    """

    index: int
    lam: float
    lam_prev: float
    ds: float
    direction: float
    first_amplitude: float
    first_distance: float
    distance: float
    state: np.ndarray = field(repr=False)
    state_prev: np.ndarray = field(repr=False)
    by_arclength: bool = False
    ds_max: float = 0.0
    stretch_min: float = 0.0

    def scalars(self) -> dict[str, Any]:
        """The scalars (JSON-ready; the same on every rank); the arrays are left out."""
        return {k: v for k, v in asdict(self).items() if k not in ("state", "state_prev")}


@dataclass
class _Eval:
    """A trial point of a step: σ, κL, dκ/ds, its state (owned values) and, for the blocks
    it was checked on, their negative counts and eigenvalues nearest 0 (ascending)."""

    sigma: float
    lam: float
    tl: float
    state: Any = None
    counts: dict[Hashable, int] = field(default_factory=dict)
    eigs: dict[Hashable, tuple[float, ...]] = field(default_factory=dict)
    eig: float = math.nan
    complete: bool = True  # the counts of all blocks asked for are known


class _Locator:
    """Re-takes the arclength step from a stored point with trial lengths σ."""

    def __init__(self, problem: Any, st: ContinuationSettings, crit: CriticalSettings,
                 stab: Stability) -> None:
        self.problem = problem
        self.st = st
        # trial solves next to a singular point may need more Newton iterations
        self.st_locate = replace(st, max_newton_its=max(st.max_newton_its, 30))
        self.crit = crit
        self.stab = stab
        self.L = problem.length_scale()
        self.ns = NewtonSolver(problem)
        self.ar = _Arclength(self.ns, self.L, st.state_weight)
        self.w0 = problem.state.duplicate()
        self.z = problem.state.duplicate()
        self.fold = False  # the step being located contains a fold
        # what the step's trials computed (``start``): the crossings of several blocks in one
        # step are located one after another from the same points, and their secant steps
        # often take the same first trials (a deep cap's m = 4 and 5 in one step: three). The
        # step it belongs to is the one ``start`` holds in w0, lam0 and fold (none yet)
        self._memo: dict[tuple, Any] = {}
        self.lam0 = math.nan

    def destroy(self) -> None:
        self.ns.destroy()
        for v in (self.w0, self.z):
            v.destroy()

    def start(self, w0: np.ndarray, lam0: float, tl0: float, fold: bool = False) -> None:
        """Set the step's first point and its tangent (oriented like the branch there);
        ``fold``: the step contains a fold (no deflation there: the branch turns into the
        near-null direction)."""
        from mpi4py import MPI

        n_own = self.w0.getLocalSize()
        same = self.lam0 == lam0 and self.fold == fold \
            and np.array_equal(self.w0.array_r[:n_own], w0[:n_own])
        if not self.problem.comm.allreduce(same, op=MPI.LAND):  # every rank decides alike
            self._memo.clear()  # another step: nothing computed for this one yet
        self.fold = fold
        set_state(self.problem, w0)
        self.problem.state.copy(self.w0)
        self.lam0 = lam0
        self.ar.set_lambda(lam0)
        self.ar.start_tangent(None, 1.0 if tl0 >= 0 else -1.0)

    def state_tangent(self) -> Any:
        """z = -J⁻¹ ∂R/∂λ at the current point (``self.z``): the tangent's state part, with
        λ-part 1 (unnormalised; along the Jacobian's null vector next to a fold)."""
        ar, ns = self.ar, self.ns
        if not ns.factor(attempts=2):  # one retry: the failed factor was reset
            raise RuntimeError(f"the Jacobian at kappa L = {ar.get_lambda():.6g} could not be "
                               "factored (twice)")
        ar.dres_dlambda()
        ar.Fl.scale(-1.0)
        ns.lin_solve(ar.Fl, self.z)
        return self.z

    def _signed_tl(self) -> float:
        """κ-component of the unit tangent at the current point, oriented like the step's."""
        ar = self.ar
        self.state_tangent()
        norm = math.sqrt(ar.cw * self.z.dot(self.z) + 1.0)
        s = ar.cw * self.z.dot(ar.tw) / norm + ar.tl / norm
        return (1.0 if s >= 0 else -1.0) / norm

    def _load(self, state: np.ndarray, lam: float) -> None:
        """Back to a stored converged state (owned values) at κL = ``lam``, without a solve."""
        w = self.ar.w
        w.array_w[:] = state[: w.getLocalSize()]
        self.ar.sync()
        self.ar.set_lambda(lam)

    def eigs_at(self, e: _Eval, nev: int, blocks: tuple[Hashable, ...]
                ) -> dict[Hashable, tuple[float, ...]]:
        """The ``nev`` eigenvalues nearest 0 (ascending) of each of ``blocks`` at an evaluated
        (converged) point."""
        out = {}
        for b in blocks:
            key = ("eigs", e.sigma, e.lam, b, nev)
            if key not in self._memo:
                self._load(e.state, e.lam)
                self._memo[key] = tuple(sorted(self.stab.eigenpairs(nev, block=b)[0]))
            out[b] = self._memo[key]
        return out

    def eigenvalue_roundoff(self, e: _Eval, block: Hashable) -> float:
        """The round-off of block's eigenvalue nearest 0 at an evaluated point, measured:
        ``EIGEN_ROUNDOFF`` times its largest change when the point is solved again at
        κL (1 ± ``ROUNDOFF_SHIFT``) (the corrector from the point's state; where it fails,
        a 1-ulp perturbation w (1 ± ε) of the state, random signs, a fixed seed, instead).
        The shift is far too small to change the physics (dμ/dκ times it is ~1e-13 on the 1D
        model's caps), but it changes every entry of the block's matrix, and so redraws the
        round-off of its assembly and factorisation, which bounds a shift-invert eigenvalue
        that small: on the h/R = 0.01, θ̄ = 15.11 cap's m = 2 block (‖H‖_F = 4.6e9) μ moved
        by a std of 7.4e-8 over 13 such shifts, and the same state gave μ = 1.3e-7 by the
        chain LU and -3.6e-8 by MUMPS, while 1-ulp perturbations of the state moved it by
        1.5e-11 only; its Rayleigh quotient (``Stability.eigenpairs``, where the problem has
        ``hessian_quadratic``) moves by a std of 3.5e-13 (``benchmarks/locator_noise.py``),
        which this measures then. 0 where it cannot be measured
        (an eigensolve that fails: the shift-invert factorisation of an exactly singular
        block, as at an algebraic problem's exact root)."""
        from petsc4py import PETSc

        self._load(e.state, e.lam)
        w0 = get_state(self.problem)
        rng = np.random.default_rng(20261203 + self.problem.comm.rank)
        eps = float(np.finfo(float).eps)
        change = 0.0
        zero = self.w0.duplicate()
        zero.set(0.0)
        try:
            # the point's own eigenvalue nearest 0 where the locator computed it already
            known = e.eigs.get(block)
            mu0 = ([min(known, key=abs)] if known
                   else self.stab.eigenpairs(1, block=block, ncv=ROUNDOFF_NCV)[0])
            for sign in (1.0, -1.0):
                self._load(e.state, e.lam)
                lam = e.lam * (1.0 + sign * ROUNDOFF_SHIFT) if e.lam != 0 else \
                    sign * ROUNDOFF_SHIFT
                c = _bordered_newton(self.ar, self.st_locate, lam, plane=(zero, 1.0, zero),
                                     singular_ok=True)
                if not c.ok:
                    set_state(self.problem,
                              w0 * (1.0 + eps * rng.choice((-1.0, 1.0), size=w0.size)))
                mu = self.stab.eigenpairs(1, block=block, ncv=ROUNDOFF_NCV)[0]
                if mu and mu0:
                    change = max(change, abs(mu[0] - mu0[0]))
        except PETSc.Error:
            change = 0.0
        finally:
            zero.destroy()
            self._load(e.state, e.lam)
        return EIGEN_ROUNDOFF * change

    def counts_at(self, e: _Eval, blocks: tuple[Hashable, ...]) -> dict[Hashable, int]:
        """The negative counts of ``blocks`` at an evaluated (converged) point."""
        missing = tuple(b for b in blocks if ("count", e.sigma, e.lam, b) not in self._memo)
        if missing:
            self._load(e.state, e.lam)
            for b, c in self.stab.negative_counts(missing).items():
                self._memo[("count", e.sigma, e.lam, b)] = c
        return {b: self._memo[("count", e.sigma, e.lam, b)] for b in blocks}

    def _memo_counts(self, e: _Eval, blocks: tuple[Hashable, ...],
                     base: dict[Hashable, int] | None) -> dict[Hashable, int] | None:
        """``negative_counts(blocks, base)`` at ``e`` from what this step computed already;
        None if some count it would report is not known."""
        out = {}
        for b in blocks:
            c = self._memo.get(("count", e.sigma, e.lam, b))
            if c is None:
                return None
            out[b] = c
            if base is not None and c != base[b]:
                break
        return out

    def modes_at(self, e: _Eval, nev: int, block: Hashable = None
                 ) -> tuple[_Eval, list[Any], list[float]]:
        """The ``nev`` eigenpairs nearest 0 of ``block`` at an evaluated (converged) point,
        from its stored state (no corrector, which may not converge again right next to a
        bifurcation), ordered by |μ|: the point with the nearest eigenvalue, the vectors, the
        eigenvalues."""
        self._load(e.state, e.lam)
        vals, vecs = self.stab.eigenpairs(nev, modes=True, block=block)
        if not vals:
            return e, [], []
        order = np.argsort(np.abs(vals))
        return (replace(e, eig=vals[order[0]]), [vecs[i] for i in order],
                [float(vals[i]) for i in order])

    def evaluate(self, sigma: float, near: _Eval | None = None,
                 blocks: tuple[Hashable, ...] = (),
                 base: dict[Hashable, int] | None = None) -> _Eval:
        """Corrector on the hyperplane at arclength σ of the step, then the negative count of
        each of ``blocks`` (eigenvalues: ``eigs_at``, on demand), up to the first whose count
        differs from ``base`` when that is given (``complete`` False if some were left
        unchecked); starts from ``near``'s state (shifted along the tangent) when given:
        Newton is slow next to a bifurcation, where the Jacobian is singular, so the closest
        known solution is the best start."""
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
        key = ("solve", sigma, None if near is None or near.state is None else near.sigma)
        if key in self._memo:  # this step's same trial: the same (deterministic) solution
            known = self._memo[key]
            if known is None:
                raise RuntimeError(f"corrector failed at sigma = {sigma:.3e}")
            e = _Eval(sigma, known[0], known[1], known[2].copy())
            self._load(e.state, e.lam)
        else:
            deflate = (_Deflation(self.problem, self.stab, self.crit.deflate)
                       if self.crit.deflate and not self.fold else None)
            ok, its, lam, _ = _bordered_newton(ar, st, self.lam0 + sigma * ar.tl,
                                               lam_start=lam_p, singular_ok=True,
                                               deflate=deflate)
            log.debug("locate: sigma = %.6g  kappa L = %.8g  converged %s in %d its (%.1f s)",
                      sigma, lam, ok, its, time.perf_counter() - t0)
            if not ok:
                self._memo[key] = None
                raise RuntimeError(f"corrector failed at sigma = {sigma:.3e}")
            e = _Eval(sigma, lam, self._signed_tl(), get_state(self.problem))
            self._memo[key] = (e.lam, e.tl, e.state.copy())
        if blocks:
            counts = self._memo_counts(e, blocks, base)
            if counts is None:
                # one call: a problem that tests all blocks' definiteness at once does so here
                counts = self.stab.negative_counts(blocks, base=base)
                for b, c in counts.items():
                    self._memo[("count", e.sigma, e.lam, b)] = c
            e.counts.update(counts)
            e.complete = len(e.counts) == len(blocks)
        log.debug("locate:   negative %d %s, dkappa/ds %.3e (%.1f s)", _total(e.counts),
                  {b: c for b, c in e.counts.items() if c}, e.tl, time.perf_counter() - t0)
        return e


class _Deflation:
    """The corrector's safeguard next to singular points: removes from Newton's solves their
    components along the Jacobian's ``k`` eigenvectors nearest 0 (M-orthogonal projection, M
    the mass of block ``None``) where such a component exceeds 10 times the rest: round-off
    amplified by the nearly singular Jacobian, or the start of a switch to a branch that
    bifurcates close by. ``keep``: a direction (a followed mode) whose near-parallel
    eigenvectors are not removed. One eigensolve per call (at the problem's current state)."""

    def __init__(self, problem: Any, stab: Stability, k: int, keep: Any = None) -> None:
        self.problem, self.stab, self.k, self.keep = problem, stab, k, keep

    def __call__(self, *xs: Any) -> None:
        _, vecs = self.stab.eigenpairs(self.k, modes=True, block=None)
        M = self.stab.mass(None)
        Mv = [M.createVecLeft() for _ in vecs]
        tmp = self.problem.state.duplicate()
        try:
            for v, mv in zip(vecs, Mv, strict=True):
                M.mult(v, mv)
                nv = math.sqrt(max(v.dot(mv), 1e-300))
                v.scale(1.0 / nv)
                mv.scale(1.0 / nv)
            if self.keep is not None:
                kn = math.sqrt(max(_m_dot(M, self.keep), 1e-300))
                pairs = [(v, mv) for v, mv in zip(vecs, Mv, strict=True)
                         if abs(self.keep.dot(mv)) / kn < 0.5]
            else:
                pairs = list(zip(vecs, Mv, strict=True))
            tiny = 1e-14 * math.sqrt(max(_m_dot(M, self.problem.state), 0.0)) + 1e-300
            for x in xs:
                c = [x.dot(mv) for _, mv in pairs]
                x.copy(tmp)
                for ci, (v, _) in zip(c, pairs, strict=True):
                    tmp.axpy(-ci, v)
                rest = math.sqrt(max(_m_dot(M, tmp), 0.0))
                for ci, (v, _) in zip(c, pairs, strict=True):
                    if abs(ci) > 10.0 * rest + tiny:
                        x.axpy(-ci, v)
        finally:
            for v in (*vecs, *Mv, tmp):
                v.destroy()


def _m_dot(M: Any, x: Any) -> float:
    """xᵀ M x."""
    return _m_inner(M, x, x)


def _block_key(b: Hashable) -> tuple[int, Any]:
    """Blocks in a stable order: ``None`` (the Jacobian) first, then by label."""
    return (0, 0) if b is None else (1, b)


def _total(counts: dict[Hashable, int]) -> int:
    return int(sum(counts.values()))


def _confirmed_counts(stab: Stability, before: dict[Hashable, int],
                      after: dict[Hashable, int]) -> dict[Hashable, int]:
    """The negative counts ``after`` of a branch point whose blocks' counts were ``before`` at
    the point before, where a count moved by one checked against the sign of its crossing
    eigenvalue's Rayleigh quotient by quadrature (``Stability.eigenpairs``; problems that give
    them): the eigenvalue nearest 0 on the side the inertia moved it to (a rising count: the
    negative one nearest 0). A thin shell's block (the 1D model at h/R = 3e-4 on 1600 cells)
    puts a point within the factorisation's round-off of a crossing: its inertia counted
    μ = -3.4e-8 while the quotient is +1.4e-8 and the crossing lies in the next step; located
    in this one, it came out 6e-4 early. Where the quotient disagrees, the block keeps its
    count (the next step brackets the crossing)."""
    from shells.stability import _rayleigh

    out = dict(after)
    for b, c1 in after.items():
        c0 = before.get(b, c1)
        if abs(c1 - c0) != 1:
            continue
        vals, vecs = stab.eigenpairs(2, modes=True, block=b, refine=False)
        try:
            side = [(v, x) for v, x in zip(vals, vecs, strict=True) if (v < 0) == (c1 > c0)]
            if not side:
                continue
            mu, vec = min(side, key=lambda vx: abs(vx[0]))
            q = _rayleigh(stab.problem.hessian_quadratic(b, vec), stab.mass(b), vec, mu)
            if (q < 0) != (mu < 0):
                log.debug("block %s: the inertia's count %d at this point is round-off "
                          "(eigenvalue %.3e, Rayleigh quotient %.3e): kept at %d", b, c1, mu,
                          q, c0)
                out[b] = c0
        finally:
            for x in vecs:
                x.destroy()
    return out


def locate(loc: _Locator, p0: Point, w0: np.ndarray, counts0: dict[Hashable, int], p1: Point,
           counts1: dict[Hashable, int] | None, w1: np.ndarray, *,
           limit: int | None = None) -> list[CriticalPoint]:
    """The critical points in the step from ``p0`` to ``p1``, in branch order: the crossings of
    every stability block whose negative count changes (``counts0`` to ``counts1``, by block),
    and the fold when dκ/ds changes sign (last: the branch is followed up to it). A step with a
    fold is searched for crossings up to the fold's near side only (the counts there decide).
    ``counts1`` None: folds only. ``limit``: at most this many crossings (the first ones)."""
    fold = (p0.dkappa_ds >= 0) != (p1.dkappa_ds >= 0)
    n_own = loc.w0.getLocalSize()
    lo = _Eval(0.0, p0.kappa_L, p0.dkappa_ds, w0[:n_own].copy())
    end = _Eval(p1.step, p1.kappa_L, p1.dkappa_ds, w1[:n_own].copy())
    found: list[CriticalPoint] = []
    fold_cp = None
    counts_end = counts1
    if fold:
        fold_cp, near = _locate_fold(loc, p0, w0, p1, w1)
        if counts1 is None:
            before, after = _total(counts0), _total(counts0) + 1
        else:
            if near.sigma > 0:
                end = near
                counts_end = loc.counts_at(near, tuple(counts0))
            else:
                counts_end = counts0  # no trial on the near side: its crossings are unknown
            before, after = _total(counts_end), _total(counts1)
        fold_cp.negative_before, fold_cp.negative_after = before, after
        fold_cp.multiplicity = max(1, abs(after - before))
    if counts_end is not None and (limit is None or limit > 0):
        changed = sorted((b for b in counts0 if counts_end[b] != counts0[b]), key=_block_key)
        if changed:
            found = _locate_crossings(loc, p0, w0, lo, end, counts0, counts_end, changed, limit)
    return found + ([fold_cp] if fold_cp is not None else [])


def locate_between(problem: Any, settings: ContinuationSettings, p0: Point, w0: np.ndarray,
                   counts0: dict[Hashable, int], p1: Point, w1: np.ndarray,
                   counts1: dict[Hashable, int], crit: CriticalSettings | None = None,
                   stab: Stability | None = None) -> list[CriticalPoint]:
    """The critical points between two converged points of any branch, however it was
    followed (the pseudo-arclength of ``follow``, a switched branch's steps in a control such as
    a dimple's depth): ``locate`` on the step from ``p0`` re-taken by pseudo-arclength along the
    tangent there (J z = -∂R/∂λ, oriented by ``p0.dkappa_ds``), ``p1`` at its arclength
    coordinate on that tangent (the projection of p1 - p0: p1 lies on the trial hyperplane of
    that σ). Blocks compared: those of ``counts0`` (give only the blocks to search: a neutral
    orbit mode's count is of either sign). The problem is left at ``p1``'s state and κ.
    ``settings``: the corrector's (its state weight, Newton iterations, residual bounds)."""
    stab_own = stab is None
    stab = Stability(problem) if stab is None else stab
    loc = _Locator(problem, settings, crit or CriticalSettings(), stab)
    L = problem.length_scale()
    try:
        loc.start(w0, p0.kappa_L, p0.dkappa_ds)
        ar = loc.ar
        d = ar.w.duplicate()
        try:
            d.array_w[:] = (np.asarray(w1) - np.asarray(w0))[: d.getLocalSize()]
            sigma1 = ar.cw * ar.tw.dot(d) + ar.tl * (p1.kappa_L - p0.kappa_L)
        finally:
            d.destroy()
        if not sigma1 > 0:
            raise RuntimeError(f"the point at kappa L = {p1.kappa_L:.6g} does not lie ahead of "
                               f"the tangent at kappa L = {p0.kappa_L:.6g}: nothing to locate")
        return locate(loc, p0, w0, counts0, replace(p1, step=sigma1),
                      {b: counts1[b] for b in counts0}, w1)
    finally:
        loc.destroy()
        if stab_own:
            stab.destroy()
        set_state(problem, w1)
        problem.set_kappa(p1.kappa_L / L)


def _locate_crossings(loc: _Locator, p0: Point, w0: np.ndarray, lo: _Eval, end: _Eval,
                      counts0: dict[Hashable, int], counts_end: dict[Hashable, int],
                      changed: list[Hashable], limit: int | None) -> list[CriticalPoint]:
    """Crossings of the ``changed`` blocks between ``lo`` and ``end``: the first one, located
    on all of them at once (a closed sphere's 2n+1 multiplet and its neighbours cross within
    1e-4 in κ, spread over many Fourier blocks); with ``limit`` 1 that is all, otherwise the
    first crossing of every other changed block as well, all in branch order."""
    first = _locate_crossing(loc, p0, w0, lo, end, tuple(changed), counts0, counts_end)
    found = [first]
    if limit is None or limit > 1:
        for b in changed:
            if b != first.block:
                found.append(_locate_crossing(loc, p0, w0, lo, end, (b,), counts0, counts_end))
        found.sort(key=lambda c: c.kappa * (1.0 if p0.dkappa_ds >= 0 else -1.0))
        if limit is not None:
            found = found[:limit]
    return found


def _locate_fold(loc: _Locator, p0: Point, w0: np.ndarray, p1: Point, w1: np.ndarray
                 ) -> tuple[CriticalPoint, _Eval]:
    """The fold in the step: the zero of dκ/ds(σ), bracketed and refined (Illinois secant
    steps) until the error bound of κ, |dκ/ds| Δσ / 2, is below ``rel_tol`` |κ|. Returns the
    fold and the trial nearest it on the step's near side (σ = 0 if there is none)."""
    t0 = time.perf_counter()
    crit = loc.crit
    loc.start(w0, p0.kappa_L, p0.dkappa_ds, fold=True)
    tl0 = loc.ar.tl
    lo = _Eval(0.0, p0.kappa_L, tl0, w0[: loc.w0.getLocalSize()].copy())
    hi = _Eval(p1.step, p1.kappa_L, p1.dkappa_ds, w1[: loc.w0.getLocalSize()])
    sgn = 1.0 if tl0 >= 0 else -1.0
    best = lo
    evals, failures = 0, 0
    sides: list[bool] = []  # the side (low: True) each trial landed on
    s_fail: float | None = None
    while evals < crit.max_evaluations:
        width = hi.sigma - lo.sigma
        err = max(abs(lo.tl), abs(hi.tl)) * width / 2
        if err <= crit.rel_tol * abs(best.lam) * 0.5 and evals >= 2:
            break
        s = _secant(lo, hi, lo.tl, hi.tl, sides)
        if s_fail is not None and s >= s_fail:
            s = lo.sigma + 0.5 * (s_fail - lo.sigma)
        e = _trial(loc, s, lo, hi, ())
        if e is None:
            failures += 1
            s_fail = s if s_fail is None else min(s_fail, s)
            if failures < 5:
                continue
            log.info("fold located to the bracket kappa L in [%.6g, %.6g] only: the corrector "
                     "does not converge closer to it", lo.lam, hi.lam)
            break
        evals += 1
        sides.append((e.tl >= 0) == (tl0 >= 0))
        if sides[-1]:
            lo = e
        else:
            hi = e
        best = max((best, e), key=lambda q: q.lam * sgn)
    # κ is stationary at the fold: the best sample bounds it on one side; on the other side
    # its error bound |dκ/ds| Δσ / 2 (κ(σ) is concave about the fold in direction sgn)
    err = max(abs(lo.tl), abs(hi.tl)) * (hi.sigma - lo.sigma) / 2
    lam_star = best.lam
    if math.isfinite(lo.tl) and math.isfinite(hi.tl) and lo.tl != hi.tl:
        # parabola through the tangent zero: κ* = κ(σ_i) + tl_i (σ* - σ_i) / 2
        s_star = lo.sigma - lo.tl * (hi.sigma - lo.sigma) / (hi.tl - lo.tl)
        est = [lo.lam + lo.tl * (s_star - lo.sigma) / 2,
               hi.lam + hi.tl * (s_star - hi.sigma) / 2]
        lam_star = max(est, key=lambda v: v * sgn)
    lam_star = min(max(lam_star * sgn, best.lam * sgn), (best.lam + sgn * err) * sgn) * sgn
    near = lo if lo.sigma > 0 else hi
    cp = _critical_point(loc, "fold", lam_star, (best.lam, best.lam + sgn * err), err, near,
                         None, 0, 1, evals, p0, t0)
    return cp, lo


def _locate_crossing(loc: _Locator, p0: Point, w0: np.ndarray, lo: _Eval, hi: _Eval,
                     blocks: tuple[Hashable, ...], c0: dict[Hashable, int],
                     c1: dict[Hashable, int]) -> CriticalPoint:
    """The first σ in (lo, hi) where the negative count of one of ``blocks`` leaves its value
    ``c0``: bracketed by the inertia of all of them (exact, decides the side) and refined with
    secant steps on the crossing eigenvalue (SLEPc) of the first block that moved by the
    bracket's high end, until |κ_hi - κ_lo| < ``rel_tol`` |κ|, or until that eigenvalue's
    root, interpolated through the samples nearest it, is that accurate and no other block
    moved inside the bracket. The point's block is that block."""
    t0 = time.perf_counter()
    crit = loc.crit
    loc.start(w0, p0.kappa_L, p0.dkappa_ds, fold=False)
    nev = crit.nev
    # the crossing eigenvalues at both ends, from their converged states (no corrector):
    # secant steps from the start. Not samples for the root's quadratic fit: a step's end can
    # lie far from the crossing (past an imperfect bifurcation, near the other branch)
    lo = replace(lo, counts={b: c0[b] for b in blocks}, eigs={})
    hi = replace(hi, counts={b: c1[b] for b in blocks}, eigs={})
    lo0 = lo

    def moved_at(e: _Eval) -> list[Hashable]:
        """The blocks known to have a count other than c0 at ``e`` (all, if none)."""
        return [b for b in blocks if e.counts.get(b, c0[b]) != c0[b]] or list(blocks)

    # the blocks that may have crossed by the high end: those moved at the last high end whose
    # counts are all known. Trials check these only, and stop at the first that moved (a high
    # side trial then costs one factorisation, not one per block)
    suspects = moved_at(hi)
    # the eigenvalues are Rayleigh quotients by quadrature (``Stability.eigenpairs``): their
    # sign may overrule the inertia's next to 0 (``crossing``, ``settle``)
    refined = loc.stab.rayleigh_quotients

    def complete(e: _Eval) -> None:
        """The counts of every suspect at ``e``."""
        if not e.complete:
            missing = tuple(b for b in suspects if b not in e.counts)
            e.counts.update(loc.counts_at(e, missing))
            e.complete = True

    def crossing(e: _Eval, b: Hashable) -> float:
        """The eigenvalue of block b that crosses 0, counted from 0 by the inertia (the
        nearest-0 eigenvalues computed need not hold the most negative ones): a count rising
        from c0, k = count - c0 past it: the smallest positive one before (k = 0), the k-th
        negative one counted from 0 after; a falling count: the mirror image. NaN where that
        eigenvalue was not computed."""
        k = e.counts.get(b, c0[b]) - c0[b]
        rising = c1[b] >= c0[b]
        if abs(k) > nev - 1:
            return math.nan  # far past its crossing: not among the nearest-0 eigenvalues
        if b not in e.eigs:  # on demand: a few of the blocks need them, near the crossing
            e.eigs.update(loc.eigs_at(e, nev, (b,)))
        vals = e.eigs[b]
        if rising and k <= 0 and sum(v < 0 for v in vals) > e.counts.get(b, c0[b]):
            # more negative eigenvalues than the inertia counts: the one nearest 0 lies at
            # round-off (|μ| ~ 1e-17 ||H||, measured on a deep cap's m = 2 block next to its
            # crossing), where the factorisation's sign is arbitrary; it has crossed
            return max(v for v in vals if v < 0)
        if not rising:
            vals, k = tuple(-v for v in vals), -k
        if k <= 0:
            pos = [v for v in vals if v >= 0]
            out = min(pos) if pos else math.nan
        else:
            neg = sorted((v for v in vals if v < 0), reverse=True)
            pos = [v for v in vals if v >= 0]
            if len(neg) >= k:
                out = neg[k - 1]
            elif refined and len(neg) == k - 1 and pos:
                # one negative fewer than the inertia counts: the crossing eigenvalue's
                # Rayleigh quotient (``Stability.eigenpairs``) is still positive, the
                # factorisation's sign being round-off this close to 0
                out = min(pos)
            else:
                out = math.nan  # unknown: not computed
        return out if rising else -out

    def settle(e: _Eval) -> None:
        """The side of ``e`` for the followed block, where its count changes by one across
        the step, decided by the sign of its crossing eigenvalue where that is known and
        disagrees with the inertia: the eigenvalue is a Rayleigh quotient, accurate to far
        below the factorisation's round-off (``Stability.eigenpairs``), which decides the
        inertia's sign within ~1e-7 of 0 on the 1D model's stiff blocks (a bracket decided
        by it would exclude the root that its eigenvalue samples give)."""
        b = moved_at(hi)[0]
        # the trial at most one count past c0: the crossing eigenvalue is the first to cross
        # (a closed sphere's m = 0 block gains 148 in one step at h/R = 1e-4: its first
        # crossing decides the side as well, and its count one past c0 can be round-off)
        if not refined or c1[b] == c0[b] or b not in e.counts \
                or abs(e.counts[b] - c0[b]) > 1:
            return
        f = crossing(e, b)
        if not math.isfinite(f):
            return
        rising = c1[b] > c0[b]
        crossed = (f < 0) == rising
        if crossed != (e.counts[b] != c0[b]):
            log.debug("locate: the crossing eigenvalue %.3e of block %s decides the side, "
                      "not the inertia (count %d)", f, b, e.counts[b])
            e.counts[b] = (c0[b] + (1 if rising else -1)) if crossed else c0[b]

    def is_low(e: _Eval) -> bool:
        return all(e.counts[b] == c0[b] for b in e.counts)

    def tracked() -> tuple[Hashable, float | None]:
        """The block followed, and the linear root (κL) of its crossing eigenvalue in the
        bracket (None if unknown): the first of the blocks whose count changed by the high end.
        The inertia of all of them decides the bracket, so it closes on the first crossing of
        any; eigenvalues are computed for the followed block only (a closed sphere's multiplet
        spreads over dozens of Fourier blocks)."""
        b = moved_at(hi)[0]
        fh = crossing(hi, b)
        fl = crossing(lo, b) if math.isfinite(fh) else math.nan
        if math.isfinite(fl) and math.isfinite(fh) and fl * fh < 0:
            return b, lo.lam + fl * (hi.lam - lo.lam) / (fl - fh)
        return b, None

    samples: list[_Eval] = []

    def eig_root() -> tuple[float, float] | None:
        """Root of the first crossing eigenvalue in κL: linear in the bracket, quadratic
        through the three samples nearest it; their difference estimates the error."""
        b, lin = tracked()
        if lin is None:
            return None
        pts = sorted((q for q in samples if math.isfinite(crossing(q, b))),
                     key=lambda q: abs(q.lam - lin))[:3]
        if len(pts) < 3 or len({q.lam for q in pts}) < 3:
            return None
        c = np.polyfit([q.lam - lin for q in pts], [crossing(q, b) for q in pts], 2)
        roots = np.roots(c)
        roots = roots[np.abs(roots.imag) < 1e-14].real + lin
        roots = roots[(roots - min(lo.lam, hi.lam)) * (roots - max(lo.lam, hi.lam)) <= 0]
        if roots.size == 0:
            return None
        quad = float(roots[np.argmin(np.abs(roots - lin))])
        return quad, abs(quad - lin)

    evals, failures = 0, 0
    sides: list[bool] = []  # the side (low: True) each trial landed on
    interpolated: tuple[float, float] | None = None
    s_fail: float | None = None
    while evals < crit.max_evaluations:
        width = hi.sigma - lo.sigma
        if abs(hi.lam - lo.lam) <= crit.rel_tol * abs(lo.lam) * 0.5 and evals >= 1:
            break
        b_t = tracked()[0]
        fl, fh = crossing(lo, b_t), crossing(hi, b_t)
        if fl * fh > 0 and (fl < 0) == (c1[b_t] > c0[b_t]):
            # the crossing eigenvalue has crossed at the low end already (its inertia there
            # was decided by round-off): the crossing lies just before it, extrapolated
            # linearly with the eigenvalue's slope over the bracket
            slope = (fh - fl) / (hi.lam - lo.lam)
            interpolated = (lo.lam - fl / slope, abs(fl / slope))
            log.info("critical point at the bracket's low end kappa L = %.8g: its crossing "
                     "eigenvalue %.3e has the sign of the high end", lo.lam, fl)
            break
        if width <= 1e-7 * max(hi.sigma, 1e-300):
            # κ jumps across a vanishing arclength interval: the path turns sharply, as at a
            # bifurcation made imperfect by the mesh's broken rotational symmetry; the
            # crossing cannot be pinned closer than this jump (reported as accuracy)
            break
        r = eig_root()
        if r is not None and r[1] <= 0.25 * crit.rel_tol * abs(r[0]):
            # accurate, if no other block crossed in the bracket (it might cross first)
            complete(hi)
            if len(moved_at(hi)) == 1:
                interpolated = eig_root()
                break
            suspects = moved_at(hi)
        b_t = tracked()[0]
        s = _secant(lo, hi, crossing(lo, b_t), crossing(hi, b_t), sides)
        if s_fail is not None and s >= s_fail:
            # the corrector failed there: approach the critical point from the near side,
            # where the Jacobian is better conditioned
            s = lo.sigma + 0.5 * (s_fail - lo.sigma)
        first = [b for b in suspects if hi.counts.get(b, c0[b]) != c0[b]]
        e = _trial(loc, s, lo, hi, tuple(first + [b for b in suspects if b not in first]), c0)
        if e is None:
            # right next to a bifurcation (a nearby bifurcated branch, a nearly singular
            # Jacobian) Newton may not converge: retry nearer the low end; in the end keep
            # what is known, the bracket (and the eigenvalue interpolation), and report its
            # width as the accuracy
            failures += 1
            s_fail = s if s_fail is None else min(s_fail, s)
            if failures < 5:
                continue
            interpolated = eig_root()
            if interpolated is not None:
                log.info("critical point at kappa L = %.8g from the eigenvalue samples "
                         "(+- %.2g): the corrector does not converge closer to it",
                         *interpolated)
            else:
                log.info("critical point located to the bracket kappa L in [%.6g, %.6g] only: "
                         "the corrector does not converge closer to it", lo.lam, hi.lam)
            break
        evals += 1
        samples.append(e)
        settle(e)
        sides.append(is_low(e))
        if sides[-1]:
            lo = e
        else:
            hi = e
            if hi.complete:
                suspects = moved_at(hi)
    block, lin = tracked()
    if interpolated is not None:
        lam_star, accuracy = interpolated
    elif lin is not None:
        lam_star, accuracy = lin, abs(hi.lam - lo.lam)
    else:
        lam_star = 0.5 * (lo.lam + hi.lam)
        accuracy = abs(hi.lam - lo.lam) / 2
    # the mode at the trial point nearest the critical point (on the near side)
    near = lo if lo.sigma > lo0.sigma else hi
    fl, fh = crossing(lo, block), crossing(hi, block)
    if math.isfinite(fl) and math.isfinite(fh) and fl != fh and hi.lam != lo.lam \
            and not refined:
        # no better than the round-off of the crossing eigenvalue allows. Not measured where
        # the eigenvalues are Rayleigh quotients by quadrature (``Stability.eigenpairs``),
        # whose measured round-off (1e-10 to 1.5e-10 in μ on the θ̄ = 8 cap's five crossings,
        # 2 solves and 2 eigensolves each) left every reported accuracy as the interpolation
        # alone gives it, there and at the θ̄ = 15.11 cap's slow crossing (2e-9)
        accuracy = max(accuracy, loc.eigenvalue_roundoff(near, block)
                       * abs(hi.lam - lo.lam) / abs(fh - fl))
    if interpolated is not None and hi.lam != lo.lam:
        # the root was interpolated from eigenvalue samples: its nearest trial state may lie
        # well away from it (a branch switch starts from the state); one trial at the root
        s_star = lo.sigma + (lam_star - lo.lam) / (hi.lam - lo.lam) * (hi.sigma - lo.sigma)
        try:
            e_star = loc.evaluate(s_star)
            evals += 1
            if abs(e_star.lam - lam_star) < abs(near.lam - lam_star):
                near = e_star
        except RuntimeError:
            pass
    return _critical_point(loc, "bifurcation", lam_star, (lo.lam, hi.lam), accuracy, near,
                           block, c0[block], c1[block], evals, p0, t0)


def _secant(lo: _Eval, hi: _Eval, fl: float, fh: float, sides: list[bool]) -> float:
    """The next trial σ: regula falsi with the Illinois modification when the values bracket
    a root; the midpoint when they do not, when the secant falls within 5 % of an end, or
    after two trials in a row on the same side (regula falsi creeps there when one end's value
    is far from linear, as a crossing eigenvalue is past a cluster of bifurcations)."""
    width = hi.sigma - lo.sigma
    s = 0.5 * (lo.sigma + hi.sigma)
    if len(sides) >= 2 and sides[-1] == sides[-2]:
        return s
    if math.isfinite(fl) and math.isfinite(fh) and fl != fh and fl * fh < 0:
        if sides and sides[-1]:
            fh *= 0.5
        elif sides:
            fl *= 0.5
        cand = lo.sigma - fl * width / (fh - fl)
        if lo.sigma + 0.05 * width < cand < hi.sigma - 0.05 * width:
            s = cand
    return s


def _trial(loc: _Locator, s: float, lo: _Eval, hi: _Eval,
           blocks: tuple[Hashable, ...], base: dict[Hashable, int] | None = None
           ) -> _Eval | None:
    """The corrector at σ = s. It starts from the step's own predictor w0 + σ τ, which has no
    component along the critical mode: a start taken from an earlier trial solution carries
    round-off that the nearly singular Jacobian has amplified along that mode, and Newton then
    lands on the bifurcated branch, which the hyperplane also cuts. The nearest solution is
    the fallback. None if both fail."""
    for near in (None, lo if s - lo.sigma <= hi.sigma - s else hi):
        try:
            return loc.evaluate(s, near=near, blocks=blocks, base=base)
        except RuntimeError:
            continue
    return None


#: a fold's mode is the eigenvector nearest 0 whose cosine (mass inner product) with the state
#: tangent is largest, if at least this; else the tangent itself (``_critical_point``)
FOLD_ALONG = 0.5


def _critical_point(loc: _Locator, kind: str, lam_star: float, bracket: tuple[float, float],
                    accuracy: float, near: _Eval, block: Hashable, c0: int, c1: int,
                    evals: int, p0: Point, t0: float) -> CriticalPoint:
    """The located point, with its mode at ``near``: the eigenvector nearest 0 of ``block``; a
    fold's, the Jacobian's null vector (the eigenvector along the state tangent, else that
    tangent: ``FOLD_ALONG``).

    Its name (m, n) is that of the cleanest of the eigenvectors whose eigenvalues lie within a
    factor 10 of the nearest one (largest ``m_power``, where the problem reports it): the two
    members of a pair split by the rigid-motion gauge can differ in purity, measured on the
    θ̄ = 5 cap next to its snap: μ = 5.8e-5 with 72 % of its power in m = 1 and 1.0e-4 with
    100 % in m = 2, crossing together (m = 1 crosses only past the fold, in the 1D model)."""
    e, vecs, vals = loc.modes_at(near, max(loc.crit.nev, 1), block)
    if kind == "fold" and vecs:
        # a fold's mode is the Jacobian's null vector, the branch's own direction there
        # (J τ_w = 0 where τ_λ = 0): of the eigenvectors nearest 0, the one along the state
        # tangent, whatever other soft mode lies nearer 0 at the trial (measured: a coarse
        # 30° surface cap's m = 1 pair at 1.1e-3, within 10 times the fold's 2.5e-4 and
        # 0.03 % purer, named the fold m = 1)
        z = loc.state_tangent()  # at e's state, which modes_at loaded
        M = loc.stab.mass(block)
        zz = max(_m_dot(M, z), 1e-300)
        along = [abs(_m_inner(M, v, z)) / math.sqrt(max(_m_dot(M, v), 1e-300) * zz)
                 for v in vecs]
        best = int(np.argmax(along))
        if along[best] >= FOLD_ALONG:
            e = replace(e, eig=vals[best])
            vecs, vals = [vecs[best]], [vals[best]]  # named by that one alone
        else:
            # none of them is: the fold's eigenvalue at the trial lies beyond the nev modes
            # that crossed before it (measured: the h/R = 0.04 ellipsoid's fold, P3 surface
            # model, past its m = 3, 4, 2 bifurcations: its four nearest 0 were the m = 2 and
            # m = 3 pairs at -3.4e-3 to -3.9e-3, each at cosine < 1e-4 with the tangent, which
            # is m = 0 to 5e-7 of its power; the fold was named m = 2). The tangent itself
            # then, M-normalised, with its Rayleigh quotient as the eigenvalue
            v = z.copy()
            v.scale(1.0 / math.sqrt(zz))
            mu = _m_dot(loc.stab.assemble(block), v)
            e = replace(e, eig=mu)
            vecs, vals = [v], [mu]
    info = None
    for v, mu in zip(vecs, vals, strict=True):
        if info is not None and abs(mu) > 10 * abs(vals[0]):
            break
        cand = loc.problem.classify_mode(v, block)
        if info is None or cand.rayleigh.get("m_power", 0) > info.rayleigh.get("m_power", 1):
            info = cand
        if "m_power" not in info.rayleigh:
            break  # no purity to compare: the nearest names the point
    L = loc.L
    k_lo, k_hi = sorted((bracket[0] / L, bracket[1] / L))
    return CriticalPoint(kind=kind, kappa=lam_star / L, kappa_L=lam_star, kappa_lo=k_lo,
                         kappa_hi=k_hi, negative_before=c0, negative_after=c1,
                         multiplicity=abs(c1 - c0), eigenvalue=e.eig,
                         mode_m=info.m if info else None, mode_n=info.n if info else None,
                         mode_rayleigh=dict(info.rayleigh) if info else {}, block=block,
                         evaluations=evals + 1, after_point=p0.index,
                         accuracy=accuracy / max(abs(lam_star), 1e-300),
                         wall_time=time.perf_counter() - t0, state=e.state,
                         mode=vecs[0].array_r.copy() if vecs else None)


def follow(problem: Any, settings: ContinuationSettings, kappa_end: float,
           crit: CriticalSettings | None = None, *, solver: NewtonSolver | None = None,
           nev: int = 0, blocks: Iterable[Hashable] | None = None,
           locate_when: Callable[[Point, dict[Hashable, int], dict[Hashable, int]], bool]
           | None = None, locate_points: bool = True, kappa_start: float = 0.0,
           resume: FollowResume | None = None,
           track: Callable[[FollowResume], None] | None = None, scalars: bool = True
           ) -> Iterator[tuple[Point, StabilityResult, list[CriticalPoint]]]:
    """Follow the branch from κ = ``kappa_start`` (default 0; the problem's state must then be
    near the branch's state there) to ``kappa_end`` with stability at every point.

    Yields (point, stability, critical points located in the step that ended at this point).
    The problem's state is the point's state at each yield. Stability: the negative count of
    every block of ``blocks`` (default: ``(None,)``, the Jacobian; the axisymmetric model's
    Fourier blocks are ``problem.stability_blocks()``), in ``StabilityResult.counts``, their
    sum in ``negative_count``; ``nev`` > 0 also computes that many eigenvalues per point (of
    block ``None``). A step is searched for critical points (``locate``) when a count changes
    or dκ/ds changes sign, or, with ``locate_when(point, counts before, counts after)``, when
    that says so (folds are always located); ``locate_points=False``: stability only.

    Resuming: ``track(r)``, if given, is called at every point just before it is yielded, with
    its ``FollowResume`` r; ``follow(..., resume=r)`` with the same problem (any partition: r's
    arrays are this rank's owned values), settings and arguments then continues after that
    point as this run did (``kappa_start`` unused): from r's state and κ, the first tangent
    oriented by r's secant, r's next step in r's arclength units, the points from index
    r.index + 1, and the first step searched for a change of r's counts (and a fold) as any
    other. The points are the uninterrupted run's to the corrector's round-off (the start is
    re-converged by Newton). Nothing is yielded when r ended the run. ``scalars=False``: the
    points carry no ``scalars`` (``continuation``'s).
    """
    crit = crit or CriticalSettings()
    if settings.method != "arclength":
        raise InputError("locating critical points needs the arclength method (folds)")
    if resume is not None and resume.ended:
        return
    blocks = (None,) if blocks is None else tuple(blocks)
    L = problem.length_scale()
    lam_end = kappa_end * L
    prev: tuple[Point, np.ndarray, dict[Hashable, int]] | None = None
    n_found = 0
    folds_only = False
    tl0: float | None = None  # the first point's dκ/ds (steps in κL: converted with it)
    start: dict[str, Any] = dict(kappa_start=kappa_start)
    st = settings
    if resume is not None:
        from mpi4py import MPI

        r = resume
        tl0 = r.tl0
        st = replace(in_arclength(settings, r.tl0), max_steps=max(1, settings.max_steps - r.index))
        set_state(problem, r.state)
        secant = r.state - r.state_prev
        dlam = (r.kappa - r.kappa_prev) * L
        moved = problem.comm.allreduce(bool(np.any(secant)), op=MPI.LOR) or dlam != 0
        start = dict(kappa_start=r.kappa, start_index=r.index + 1, skip_first=True,
                     initial_tangent=(secant, dlam) if moved else None, initial_ds=r.ds,
                     tangent=None if r.tangent is None else (r.tangent, r.dkappa_ds),
                     # the point before, for a quadratic predictor's first step
                     previous=(r.state_prev, r.kappa_prev, r.step) if r.index > 0 else None)
        prev = (Point(index=r.index, kappa=r.kappa, kappa_L=r.kappa * L,
                      newton_its=r.newton_its, step=r.step, dkappa_ds=r.dkappa_ds,
                      wall_time=0.0), r.state.copy(), dict(r.counts))
        n_found, folds_only = r.found, r.folds_only
    ns = solver or NewtonSolver(problem)
    stab = Stability(problem)
    loc = _Locator(problem, settings, crit, stab)
    held: list[np.ndarray] = []  # the tangent the next step follows (for ``track``)

    def hold(tw: np.ndarray, tl: float) -> None:
        held[:] = [tw]

    try:
        for p in continuation(problem, st, kappa_end=kappa_end, solver=ns, **start,
                              on_tangent=None if track is None else hold, scalars=scalars):
            if folds_only:
                counts = dict(prev[2]) if prev is not None else {}
                res = StabilityResult(stable=False, negative_count=_total(counts), zero_count=0,
                                      counts=None)
            elif blocks == (None,):
                res = stab.check(nev=nev)
                counts = {None: res.negative_count}
                res.counts = counts
            else:
                counts = stab.negative_counts(blocks)
                if prev is not None and locate_points and counts != prev[2] \
                        and stab.rayleigh_quotients:
                    counts = _confirmed_counts(stab, prev[2], counts)
                vals = stab.eigenpairs(nev)[0] if nev > 0 else []
                total = _total(counts)
                res = StabilityResult(stable=total == 0, negative_count=total, zero_count=0,
                                      eigenvalues=vals, counts=counts)
            found: list[CriticalPoint] = []
            if prev is not None and locate_points:
                fold = (prev[0].dkappa_ds >= 0) != (p.dkappa_ds >= 0)
                wanted = (locate_when(p, prev[2], counts) if locate_when is not None
                          else counts != prev[2])
                if fold or (wanted and not folds_only):
                    w1 = get_state(problem)
                    k1 = problem.get_kappa()
                    left = (None if crit.max_critical is None
                            else crit.max_critical - n_found)
                    found = locate(loc, prev[0], prev[1], prev[2], p,
                                   None if folds_only or not wanted else counts, w1,
                                   limit=left)
                    if crit.max_critical is not None:
                        found = found[:left]
                    n_found += len(found)
                    # back to the branch point: the continuation goes on from it
                    set_state(problem, w1)
                    problem.set_kappa(k1)
            stop = bool(found) and (
                crit.stop_at_first or (crit.stop_at_fold and any(c.kind == "fold" for c in found))
                or (crit.max_critical is not None and n_found >= crit.max_critical))
            if crit.folds_only_after_first and any(c.kind != "fold" for c in found):
                folds_only = True
            state = get_state(problem)
            if tl0 is None:
                tl0 = p.dkappa_ds
            if track is not None:
                # the next step: the arclength loop's (the first: the settings' own)
                st_arc = in_arclength(st, tl0)
                ds = st_arc.ds if prev is None else next_step(st_arc, p.step, p.newton_its)
                landed = abs(p.kappa_L - lam_end) <= 1e-12 * abs(lam_end)
                track(FollowResume(
                    index=p.index, kappa=p.kappa,
                    kappa_prev=p.kappa if prev is None else prev[0].kappa,
                    dkappa_ds=p.dkappa_ds, newton_its=p.newton_its, step=p.step, ds=ds,
                    tl0=tl0, counts=dict(counts), found=n_found, folds_only=folds_only,
                    ended=stop or landed, state=state,
                    state_prev=state if prev is None else prev[1],
                    tangent=held[-1] if held else None))
            prev = (p, state, counts)
            yield p, res, found
            if stop:
                return
    finally:
        loc.destroy()
        stab.destroy()
        if solver is None:
            ns.destroy()


def _state_kappa(ns: NewtonSolver, ar: _Arclength, lam: float) -> float:
    """κL at which the model's current state is nearest to equilibrium (least squares).

    The residual is affine in κ (b̄ = b° + κ a° enters the energy quadratically), so one
    least-squares step from any guess is exact. A critical point's state comes from a trial
    solve whose κ is not the located κ (which is interpolated).
    """
    ar.set_lambda(lam)
    F = ns.b
    ns.assemble_residual(F)
    ar.dres_dlambda()
    fl2 = ar.Fl.dot(ar.Fl)
    if fl2 > 0:
        lam -= F.dot(ar.Fl) / fl2
    ar.set_lambda(lam)
    return lam


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

    from shells.solvers import apply_options, configure_factor, setup_factor

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


def _critical_directions(problem: Any, ar: _Arclength, mode: np.ndarray, k: int
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


def _off_branch_direction(problem: Any, ns: NewtonSolver, ar: _Arclength, phi: Any
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
        z.axpy(-_m_inner(M, z, phi) / max(_m_dot(M, phi), 1e-300), phi)
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


def _m_inner(M: Any, x: Any, y: Any) -> float:
    """xᵀ M y."""
    t = M.createVecLeft()
    M.mult(y, t)
    out = float(x.dot(t))
    t.destroy()
    return out


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

    1. The critical state w_c (``cp.state``) and its κ (least squares: the residual is affine
       in κ; the state is a trial solve next to the located κ, not at it).
    2. The critical eigenspace there (SLEPc): φ_0 the eigenvector of ``cp.mode``, and, when
       k = ``cp.multiplicity`` (or ``pinned``) > 1, the k - 1 other eigenvectors nearest 0.
    3. The first point at mode amplitude a = ``sign`` × ``ds`` (continuation norm: RMS in
       thicknesses, ``settings.state_weight``): Newton from w_c + a φ_0 on R(w, λ) = 0 with
       cw φ_0·(w - w_c) = a and λ free (the corrector ``continuation._bordered_newton`` on
       that hyperplane): for a pitchfork λ - λ_c ≈ β a², a regular equation in λ for a ≠ 0
       that the fundamental branch (no φ_0-component) does not satisfy. If it fails, a is
       retried with ``ds`` times each of ``factors``.
    4. Pseudo-arclength continuation (``continuation.arclength_steps``) with secant
       predictors from (w_c, λ_c) and that point onwards, adaptive steps from ``settings``
       (arclength units: ``ds_unit`` must be "arclength"; the first step is |a|), landing on
       ``kappa_end`` exactly when the branch crosses it, or ending after ``settings.max_steps``
       points or when the step falls below
       ``ds_min``. Each yielded point carries in ``scalars``: ``mode_amplitude`` =
       cw φ_0·(w - w_c), ``residual`` = ||R(w, λ)|| and ``residual_bound`` (the corrector's
       bound, ``ContinuationSettings``) and ``pin_force`` = ||Σ s_j ψ_j||. If the state's
       distance from the fundamental branch (its linear prediction w_c + (λ - λ_c) dw/dλ) falls
       below ``min_amplitude`` times the first point's, or the state lies along -φ_0 (the
       amplitude changed sign and makes up at least half of that distance), the branch has
       led back to the fundamental branch and a RuntimeError is raised (a step that would jump
       to the -φ_0 side is refused and shortened instead). The distance, not the amplitude:
       a dimple localised at one pole of a sphere leaves the shape of P_n, and its amplitude
       along P_n shrinks and changes sign far from the fundamental branch. ``release_pins``:
       after that many points the pins are dropped (below). ``deflate`` > 0: every corrector omits
       dominant components along that many near-null eigenvectors of the Jacobian other than
       the followed mode (``_Deflation``; for clusters of nearly simultaneous bifurcations,
       the closed sphere's neighbouring degrees on the 1D model).

    Localised branches (``control`` = a state-shaped vector e, the functional c = e·w, e.g.
    the depth of a dimple at a pole; no pins). Where several bifurcations nearly coincide, a
    single critical mode is an arbitrary member of the cluster, chosen by round-off (which
    crossed first at the located state), and the branches along different members part
    within a few steps. The direction followed is instead the cluster's combination of largest
    c: the projection of e on the ``cluster`` eigenvectors nearest 0 (φ_0 among them), which
    for a closed sphere's axisymmetric modes P_n (all of value 1 at the pole) is a packet
    localised at the pole. The first point has c - c_c = ``sign`` × ``ds`` × f (λ free), with
    ``cluster``, 2 and 1 eigenvectors in turn until its corrector converges (``response``:
    first along the state's response to e as a force, ``_response_direction``, which holds
    every degree of a multiplet whether or not the cluster's eigenvectors do; ``phase``:
    functionals ψ_j held at their values at w_c, as pins, along the whole branch, for a
    neutral direction the state would otherwise drift along, a dimple's sliding over a closed
    sphere: where its eigenvalue, of either sign on a mesh, crosses 0 the corrector at fixed
    c is singular and the steps stall); the branch is then
    followed with c as its parameter (``continuation.arclength_steps``' ``control``: secant
    predictor, corrector at fixed c converged by plain Newton, no deflation), steps in c from
    ``settings``. Where c turns (a fold of c on the branch: the steps in c are refused until
    they fall below ``ds_min``), the branch goes on by secant arclength from the last two
    points (steps up to the largest a step of c took; points carry ``control_parameter`` 1
    before, 0 after). The return tests stay (distance from the fundamental branch; a side
    crossed when c - c_c changes sign while c is the parameter). Measured on the h/R = 0.01
    closed sphere (1D model): first amplitudes 0.25 and 0.35 give the same dimple branch,
    which the arclength loop did not (docs/model.md).

    Resuming: ``track(r)``, if given, is called at every point just before it is yielded, with
    its ``SwitchResume`` r; ``switch_branch(..., resume=r)`` with the same problem (partition),
    critical point and arguments then continues after that point as this run did: steps 1-2
    again at w_c (the same directions), no first point (3), the loop (4) from r's state with
    r's secant, step and tests, the points from index r.index + 1 (the same to round-off: the
    loop's λ is r.lam = κ L, the corrector's λ through κ).

    Multiple eigenvalues (k > 1). On a shape of revolution every mode m ≥ 1 is a (cos mφ,
    sin mφ) pair and every direction of that plane gives the same branch up to a rotation about
    the axis: the pattern's orientation is a continuous symmetry, and along the new branch it is
    a nearly neutral direction of the Hessian. A mesh breaks the symmetry slightly: (i) the pair
    splits into two simple eigenvalues crossing at nearly the same κ (``cp.multiplicity`` = 2,
    κ located at the first crossing); the branch followed is the one along the first crossing's
    eigenvector, which for a supercritical pitchfork is the stable orientation (the second
    crossing's branch is a saddle with an extra negative eigenvalue of the size of the
    splitting); (ii) the orientation stiffness along the new branch is so small (on a coarse cap
    mesh, a Hessian eigenvalue ~10⁻⁶ against ~10⁻³ for the other modes) that the residual
    tolerance does not determine the orientation: an unpinned Newton step leaves the orbit of
    rotations along its tangent and diverges (the previous, unpinned version of this function
    failed that way). So the other k - 1 eigenvectors are pinned at their w_c values for the
    whole branch (a phase condition) and the force s_j ψ_j that holds the orientation is
    reported as ``pin_force``: it is the only residual of the yielded states (≈ 10⁻⁵ of the
    κ-load on the coarse cap mesh), i.e. they are equilibria up to the mesh's orientation
    force; (iii) the bifurcation is imperfect: the path from κ = 0 turns onto one sign of the
    new branch, the other sign lies on a separate branch with its own fold near κ_c; for |a|
    well above the imperfection both are graphs over a (either ``sign`` works) and
    a² ∝ |κ - κ_c| holds there, not within the imperfection scale of κ_c.

    The perfect sphere's (2n+1)-fold eigenvalue is different: its eigenspace holds inequivalent
    directions (the axisymmetric Y_n^0 among them, and mixtures whose branches are not rotations
    of each other). The direction followed is the eigenvector of ``cp.mode`` (the first to
    cross on the mesh) and the other k - 1 that crossed in the same step are pinned at zero
    amplitude; this follows *a* branch tangent to that direction if one exists (pinning
    suppresses the others); which inequivalent branch it is, and whether another is preferred,
    needs the reduced bifurcation equations on the whole eigenspace and is not analysed.
    """
    if cp.state is None or cp.mode is None:
        raise InputError("this critical point carries no state/mode to switch from")
    if not ds > 0:
        raise InputError(f"the first amplitude ds must be positive, got {ds}")
    if settings.ds_unit != "arclength":
        raise InputError("switch_branch takes its steps in arclength (ds_unit='arclength')")
    ns = solver or NewtonSolver(problem)
    L = problem.length_scale()
    ar = _Arclength(ns, L, settings.state_weight)
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
        lam_c = _state_kappa(ns, ar, cp.kappa_L)
        lam_end = kappa_end * L
        ar.lam_ref = 0.01 * max(abs(lam_c), abs(lam_end))
        max_dlam = 2.0 * abs(lam_end - lam_c) + 0.1 * abs(lam_c)
        ar.w.copy(wc)
        k = 1 if control is not None else max(1, cp.multiplicity if pinned is None else pinned)
        dirs, vals = _critical_directions(problem, ar, cp.mode,
                                          max(k, cluster) if control is not None else k)
        pins = list(phase) if control is not None else dirs[1:k]  # (k = 1 with a control)
        defl_stab = Stability(problem) if deflate else None
        defl = _Deflation(problem, defl_stab, deflate, keep=dirs[0]) if deflate else None
        log.info("switch: critical state at kappa L = %.6g, eigenvalues %s", lam_c,
                 ", ".join(f"{v:.3e}" for v in vals))
        # the first corrector starts off the branch, from the mode's linear prediction
        st_first = replace(settings, max_newton_its=max(settings.max_newton_its, 30))
        corrector = dict(pins=pins, wc=wc, singular_ok=True, deflate=defl, max_dlam=max_dlam,
                         keep_best=False)
        # with a control, each point off the first corrector's is converged by plain Newton to
        # ``newton_tol``: at fixed c the Jacobian is regular on the branch (measured: 4-5
        # quadratic iterations to 1e-15 on the 1D spheres with penalty 1e4-1e5), and the
        # corrector's acceptance of a stalled Newton (``singular_ok``: the residual bound
        # after 3 iterations) kept states off the branch there (h/R = 0.01: a point 1 % off
        # in κ, its last Newton step 17 in κL; with penalty 1e6 at h/R = 0.001 no Newton
        # converges, its increments stay near 1e-3 R); the deflation, which removes the
        # cluster's components from every increment, bent the branch onto others
        strict = dict(corrector, singular_ok=False, deflate=None)
        # the first point, a small amplitude along the mode, lies next to κ_c: a corrector
        # that went farther than a quarter of κ_c (plus 1 % of the range) converged onto
        # another branch (measured: the h/R = 0.05 sphere's outward side, amplitude 0.125,
        # from κL = 29.65 to an equilibrium at κL = -0.009); it is refused like a failure and
        # the next amplitude is tried
        first_corrector = dict(corrector, max_dlam=min(max_dlam,
                                                       0.25 * abs(lam_c) + ar.lam_ref))
        sgn = 1.0 if sign >= 0 else -1.0

        # the amplitude is measured along φ_0 made orthogonal (in the continuation norm's
        # inner product) to the fundamental branch's tangent at w_c: the DOF inner product is
        # not the physical one (the 1D model's unknowns carry no area weight), so φ_0 itself
        # can overlap the fundamental branch's direction, whose own motion in κ would then
        # meet the amplitude condition (measured: the 1D sphere's first corrector landed back
        # on the fundamental branch 1 % below κ_c)
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
                c = _bordered_newton(ar, st_first, lam_c, plane=(plane_dir, 0.0, wp),
                                     **first_corrector)
                if c.ok and control is not None:  # converged to newton_tol from there
                    ar.w.copy(wp)
                    c = _bordered_newton(ar, st_first, c.lam, plane=(plane_dir, 0.0, wp),
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
            cluster of bifurcations; measured: from a sphere's dimple branch back to the
            fundamental branch 25 % lower in κ): refused, the step is shortened."""
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
