"""Locating critical points along a branch: folds and bifurcations inside a step, their
classification and modes (algorithm layer, on ``shells.problem.Problem``).

A change of a stability block's negative count between two points of a branch
(``shells.algorithms.following.follow``) brackets a critical point, a sign change of dκ/ds a
fold; both are located inside that step (``locate``):

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
from collections.abc import Hashable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from shells.algorithms.bordered import Arclength, bordered_newton
from shells.algorithms.continuation import Point
from shells.algorithms.newton import NewtonSolver
from shells.algorithms.records import CriticalPoint, block_key
from shells.algorithms.settings import ContinuationSettings, CriticalSettings
from shells.algorithms.stability import Stability
from shells.problem.interface import get_state, set_state

log = logging.getLogger("shells")

__all__ = ["EIGEN_ROUNDOFF", "FOLD_ALONG", "ROUNDOFF_NCV", "ROUNDOFF_SHIFT", "Deflation", "Locator",
           "locate", "locate_between", "m_dot", "m_inner", "negative_total"]


#: the eigenvalues near 0 of a stability block are reproducible only to about this multiple
#: of their change when the point is solved again at a κ shifted by round-off
#: (``Locator.eigenvalue_roundoff``), so a crossing only to that over |dμ/dκ|, which the
#: reported accuracy includes; the factor makes the reported accuracy cover the spread of
#: repeated runs (docs/design-notes.md, "Locator: round-off of the crossing eigenvalue")
EIGEN_ROUNDOFF = 6.0


#: the relative shift of κ at which ``Locator.eigenvalue_roundoff`` solves a point again
ROUNDOFF_SHIFT = 1.0e-10


#: Krylov subspace of the round-off measurement's solves (one eigenvalue, nearest 0): enough for
#: one eigenvalue to converge as with the default size, at a lower cost per solve
#: (docs/design-notes.md, "Locator: round-off of the crossing eigenvalue")
ROUNDOFF_NCV = 8


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


class Locator:
    """Re-takes an arclength step from its stored first point with trial lengths σ.

    σ parametrises the branch between the step's two points (through folds too); the trials
    (state, dκ/ds, negative counts, eigenvalues) are what ``locate`` brackets a critical point
    with. What a step's trials computed is remembered until another step starts.

    Args:
        problem: the problem.
        st: the continuation's settings (the corrector's; trials allow at least 30 Newton
            iterations, as a trial next to a singular point may need them).
        crit: the location settings.
        stab: the stability solvers to count and solve with.
    """

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
        self.ar = Arclength(self.ns, self.L, st.state_weight)
        self.w0 = problem.state.duplicate()
        self.z = problem.state.duplicate()
        self.fold = False  # the step being located contains a fold
        # what the step's trials computed (``start``): the crossings of several blocks in one
        # step are located one after another from the same points, and their secant steps
        # often take the same first trials. The step it belongs to is the one ``start`` holds
        # in w0, lam0 and fold (none yet)
        self._memo: dict[tuple, Any] = {}
        self.lam0 = math.nan

    def destroy(self) -> None:
        """Free the solver and work vectors."""
        self.ns.destroy()
        for v in (self.w0, self.z):
            v.destroy()

    def start(self, w0: np.ndarray, lam0: float, tl0: float, fold: bool = False) -> None:
        """Set the step's first point and its tangent (oriented like the branch there).

        Args:
            w0: the first point's state (owned values at least).
            lam0: its λ = κL.
            tl0: its dκ/ds (orients the tangent).
            fold: the step contains a fold (no deflation there: the branch turns into the
                near-null direction).

        Raises:
            RuntimeError: if the Jacobian there cannot be factored.
        """
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
        """The tangent's state part z = -J⁻¹ ∂R/∂λ at the current point.

        Returns:
            ``self.z``, for λ-part 1 (unnormalised; along the Jacobian's null vector next to a
            fold).

        Raises:
            RuntimeError: if the Jacobian cannot be factored in two attempts.
        """
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
        """The eigenvalues nearest 0 of blocks at an evaluated (converged) point.

        Args:
            e: the trial point.
            nev: how many eigenvalues per block.
            blocks: the blocks.

        Returns:
            {block: its ``nev`` eigenvalues nearest 0, ascending}.
        """
        out = {}
        for b in blocks:
            key = ("eigs", e.sigma, e.lam, b, nev)
            if key not in self._memo:
                self._load(e.state, e.lam)
                self._memo[key] = tuple(sorted(self.stab.eigenpairs(nev, block=b)[0]))
            out[b] = self._memo[key]
        return out

    def eigenvalue_roundoff(self, e: _Eval, block: Hashable) -> float:
        """Measure the round-off of a block's eigenvalue nearest 0 at an evaluated point.

        The point is solved again at κL (1 ± ``ROUNDOFF_SHIFT``) (the corrector from the
        point's state; where it fails, a 1-ulp perturbation w (1 ± ε) of the state, random
        signs, a fixed seed, instead). The shift is far too small to change the physics, but
        it changes every entry of the block's matrix, and so redraws the round-off of its
        assembly and factorisation, which bounds a shift-invert eigenvalue that small; a
        Rayleigh quotient (``Stability.eigenpairs``, where the problem has
        ``hessian_quadratic``) has far less (docs/model.md, "Stability and critical points";
        ``benchmarks/locator_noise.py``).

        Args:
            e: the trial point.
            block: the block.

        Returns:
            ``EIGEN_ROUNDOFF`` times the eigenvalue's largest change; 0 where it cannot be
            measured (an eigensolve that fails: the shift-invert factorisation of an exactly
            singular block, as at an algebraic problem's exact root).
        """
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
                c = bordered_newton(self.ar, self.st_locate, lam, plane=(zero, 1.0, zero),
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
        """The negative counts of ``blocks`` at an evaluated (converged) point.

        Args:
            e: the trial point.
            blocks: the blocks.

        Returns:
            {block: negative count}.
        """
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
        """The eigenpairs nearest 0 of a block at an evaluated (converged) point.

        From the point's stored state: no corrector, which may not converge again right next
        to a bifurcation.

        Args:
            e: the trial point.
            nev: how many eigenpairs.
            block: the block.

        Returns:
            (``e`` with ``eig`` the eigenvalue nearest 0, the eigenvectors, the eigenvalues),
            ordered by |μ|; (e, [], []) if none converged.
        """
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
        """Solve the trial at arclength σ of the step and count its blocks' negative eigenvalues.

        Args:
            sigma: the trial's arclength σ; the corrector works on the hyperplane there.
            near: a trial whose state (shifted along the tangent) is the Newton start: Newton
                is slow next to a bifurcation, where the Jacobian is singular, so the closest
                known solution is the best start. None: the step's predictor.
            blocks: the blocks to count (eigenvalues: ``eigs_at``, on demand).
            base: stop counting after the first block whose count differs from it
                (``complete`` is then False if some were left unchecked).

        Returns:
            The trial point; the problem holds its state.

        Raises:
            RuntimeError: if the corrector fails.
        """
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
            deflate = (Deflation(self.problem, self.stab, self.crit.deflate)
                       if self.crit.deflate and not self.fold else None)
            ok, its, lam, _ = bordered_newton(ar, st, self.lam0 + sigma * ar.tl,
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
        log.debug("locate:   negative %d %s, dkappa/ds %.3e (%.1f s)", negative_total(e.counts),
                  {b: c for b, c in e.counts.items() if c}, e.tl, time.perf_counter() - t0)
        return e


class Deflation:
    """The corrector's safeguard next to singular points (a ``bordered_newton`` ``deflate``).

    Called with Newton's solves, it removes their components along the Jacobian's ``k``
    eigenvectors nearest 0 (M-orthogonal projection, M the mass of block ``None``) where such
    a component exceeds 10 times the rest: round-off amplified by the nearly singular
    Jacobian, or the start of a switch to a branch that bifurcates close by. One eigensolve
    per call (at the problem's current state).

    Args:
        problem: the problem.
        stab: the stability solvers for the eigensolve.
        k: how many eigenvectors.
        keep: a direction (a followed mode) whose near-parallel eigenvectors are not removed.
    """

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
                kn = math.sqrt(max(m_dot(M, self.keep), 1e-300))
                pairs = [(v, mv) for v, mv in zip(vecs, Mv, strict=True)
                         if abs(self.keep.dot(mv)) / kn < 0.5]
            else:
                pairs = list(zip(vecs, Mv, strict=True))
            tiny = 1e-14 * math.sqrt(max(m_dot(M, self.problem.state), 0.0)) + 1e-300
            for x in xs:
                c = [x.dot(mv) for _, mv in pairs]
                x.copy(tmp)
                for ci, (v, _) in zip(c, pairs, strict=True):
                    tmp.axpy(-ci, v)
                rest = math.sqrt(max(m_dot(M, tmp), 0.0))
                for ci, (v, _) in zip(c, pairs, strict=True):
                    if abs(ci) > 10.0 * rest + tiny:
                        x.axpy(-ci, v)
        finally:
            for v in (*vecs, *Mv, tmp):
                v.destroy()


def m_dot(M: Any, x: Any) -> float:
    """xᵀ M x.

    Args:
        M: a PETSc matrix.
        x: a PETSc vector.

    Returns:
        The product.
    """
    return m_inner(M, x, x)


def negative_total(counts: dict[Hashable, int]) -> int:
    """The number of negative eigenvalues over all blocks.

    Args:
        counts: {block: negative count}.

    Returns:
        Their sum.
    """
    return int(sum(counts.values()))


def locate(loc: Locator, p0: Point, w0: np.ndarray, counts0: dict[Hashable, int], p1: Point,
           counts1: dict[Hashable, int] | None, w1: np.ndarray, *,
           limit: int | None = None) -> list[CriticalPoint]:
    """The critical points in the step from ``p0`` to ``p1``, in branch order.

    The crossings of every stability block whose negative count changes, and the fold when
    dκ/ds changes sign (last: the branch is followed up to it). A step with a fold is searched
    for crossings up to the fold's near side only (the counts there decide).

    Args:
        loc: the locator.
        p0: the step's first point.
        w0: its state (owned values).
        counts0: its negative counts, by block.
        p1: the step's last point (``step``: the step's arclength).
        counts1: its negative counts; None: folds only.
        w1: its state.
        limit: at most this many crossings (the first ones).

    Returns:
        The located points (the problem's state is left at a trial's).

    Raises:
        RuntimeError: if the step's first point cannot be factored.
    """
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
            before, after = negative_total(counts0), negative_total(counts0) + 1
        else:
            if near.sigma > 0:
                end = near
                counts_end = loc.counts_at(near, tuple(counts0))
            else:
                counts_end = counts0  # no trial on the near side: its crossings are unknown
            before, after = negative_total(counts_end), negative_total(counts1)
        fold_cp.negative_before, fold_cp.negative_after = before, after
        fold_cp.multiplicity = max(1, abs(after - before))
    if counts_end is not None and (limit is None or limit > 0):
        changed = sorted((b for b in counts0 if counts_end[b] != counts0[b]), key=block_key)
        if changed:
            found = _locate_crossings(loc, p0, w0, lo, end, counts0, counts_end, changed, limit)
    return found + ([fold_cp] if fold_cp is not None else [])


def locate_between(problem: Any, settings: ContinuationSettings, p0: Point, w0: np.ndarray,
                   counts0: dict[Hashable, int], p1: Point, w1: np.ndarray,
                   counts1: dict[Hashable, int], crit: CriticalSettings | None = None,
                   stab: Stability | None = None) -> list[CriticalPoint]:
    """The critical points between two converged points of any branch, however it was followed.

    E.g. the pseudo-arclength of ``follow``, or a switched branch's steps in a control such as
    a dimple's depth. ``locate`` runs on the step from ``p0`` re-taken by pseudo-arclength
    along the tangent there (J z = -∂R/∂λ, oriented by ``p0.dkappa_ds``), with ``p1`` at its
    arclength coordinate on that tangent (the projection of p1 - p0: p1 lies on the trial
    hyperplane of that σ).

    Args:
        problem: the problem.
        settings: the corrector's settings (state weight, Newton iterations, residual bounds).
        p0, w0, counts0: the first point, its state (owned values) and its negative counts;
            only the blocks of ``counts0`` are compared (give only the blocks to search: a
            neutral orbit mode's count is of either sign).
        p1, w1, counts1: the second point, its state and counts.
        crit: the location settings (default ``CriticalSettings()``).
        stab: the stability solvers to use (default: new ones).

    Returns:
        The located points, in branch order. The problem is left at ``p1``'s state and κ.

    Raises:
        RuntimeError: if ``p1`` does not lie ahead of the tangent at ``p0``.
    """
    stab_own = stab is None
    stab = Stability(problem) if stab is None else stab
    loc = Locator(problem, settings, crit or CriticalSettings(), stab)
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


def _locate_crossings(loc: Locator, p0: Point, w0: np.ndarray, lo: _Eval, end: _Eval,
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


def _locate_fold(loc: Locator, p0: Point, w0: np.ndarray, p1: Point, w1: np.ndarray
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


def _locate_crossing(loc: Locator, p0: Point, w0: np.ndarray, lo: _Eval, hi: _Eval,
                     blocks: tuple[Hashable, ...], c0: dict[Hashable, int],
                     c1: dict[Hashable, int]) -> CriticalPoint:
    """The first σ in (lo, hi) where the negative count of one of ``blocks`` leaves its value
    ``c0``: bracketed by the inertia of all of them (exact, decides the side) and refined with
    secant steps on the crossing eigenvalue (SLEPc) of the first block that moved by the
    bracket's high end, until |κ_hi - κ_lo| < ``rel_tol`` |κ|, or until that eigenvalue's
    root, interpolated through the samples nearest it, is that accurate and no other block
    moved inside the bracket. The point's block is that block."""
    return _CrossingSearch(loc, p0, w0, lo, hi, blocks, c0, c1).run()


class _CrossingSearch:
    """One call of ``_locate_crossing``: the bracket (``lo``, ``hi``), the blocks suspected
    of having crossed, the samples of the crossing eigenvalue and the trial counts. The
    arguments are ``_locate_crossing``'s."""

    def __init__(self, loc: Locator, p0: Point, w0: np.ndarray, lo: _Eval, hi: _Eval,
                 blocks: tuple[Hashable, ...], c0: dict[Hashable, int],
                 c1: dict[Hashable, int]) -> None:
        self.t0 = time.perf_counter()
        self.loc, self.p0, self.blocks, self.c0, self.c1 = loc, p0, blocks, c0, c1
        self.crit = loc.crit
        loc.start(w0, p0.kappa_L, p0.dkappa_ds, fold=False)
        self.nev = self.crit.nev
        # the crossing eigenvalues at both ends, from their converged states (no corrector):
        # secant steps from the start. Not samples for the root's quadratic fit: a step's end
        # can lie far from the crossing (past an imperfect bifurcation, near the other branch)
        self.lo = replace(lo, counts={b: c0[b] for b in blocks}, eigs={})
        self.hi = replace(hi, counts={b: c1[b] for b in blocks}, eigs={})
        self.lo0 = self.lo
        # the blocks that may have crossed by the high end: those moved at the last high end
        # whose counts are all known. Trials check these only, and stop at the first that
        # moved (a high side trial then costs one factorisation, not one per block)
        self.suspects = self.moved_at(self.hi)
        # the eigenvalues are Rayleigh quotients by quadrature (``Stability.eigenpairs``): their
        # sign may overrule the inertia's next to 0 (``crossing``, ``settle``)
        self.refined = loc.stab.rayleigh_quotients
        self.samples: list[_Eval] = []
        self.evals, self.failures = 0, 0
        self.sides: list[bool] = []  # the side (low: True) each trial landed on
        self.interpolated: tuple[float, float] | None = None
        self.s_fail: float | None = None

    def run(self) -> CriticalPoint:
        """Trials until the bracket or the eigenvalue's root is accurate (or no trial
        converges closer), then the critical point."""
        while self.evals < self.crit.max_evaluations:
            if self.done():
                break
            e = self.trial(self.next_sigma())
            if e is None:
                if self.failures < 5:
                    continue
                self.give_up()
                break
            self.accept(e)
        return self.result()

    def moved_at(self, e: _Eval) -> list[Hashable]:
        """The blocks known to have a count other than c0 at ``e`` (all, if none)."""
        c0 = self.c0
        return [b for b in self.blocks if e.counts.get(b, c0[b]) != c0[b]] or list(self.blocks)

    def complete(self, e: _Eval) -> None:
        """The counts of every suspect at ``e``."""
        if not e.complete:
            missing = tuple(b for b in self.suspects if b not in e.counts)
            e.counts.update(self.loc.counts_at(e, missing))
            e.complete = True

    def crossing(self, e: _Eval, b: Hashable) -> float:
        """The eigenvalue of block b that crosses 0, counted from 0 by the inertia (the
        nearest-0 eigenvalues computed need not hold the most negative ones): a count rising
        from c0, k = count - c0 past it: the smallest positive one before (k = 0), the k-th
        negative one counted from 0 after; a falling count: the mirror image. NaN where that
        eigenvalue was not computed."""
        c0, nev = self.c0, self.nev
        k = e.counts.get(b, c0[b]) - c0[b]
        rising = self.c1[b] >= c0[b]
        if abs(k) > nev - 1:
            return math.nan  # far past its crossing: not among the nearest-0 eigenvalues
        if b not in e.eigs:  # on demand: a few of the blocks need them, near the crossing
            e.eigs.update(self.loc.eigs_at(e, nev, (b,)))
        vals = e.eigs[b]
        if rising and k <= 0 and sum(v < 0 for v in vals) > e.counts.get(b, c0[b]):
            # more negative eigenvalues than the inertia counts: the one nearest 0 lies at
            # round-off (|μ| ~ 1e-17 ||H||: docs/model.md, "Stability and critical points"),
            # where the factorisation's sign is arbitrary; it has crossed
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
            elif self.refined and len(neg) == k - 1 and pos:
                # one negative fewer than the inertia counts: the crossing eigenvalue's
                # Rayleigh quotient (``Stability.eigenpairs``) is still positive, the
                # factorisation's sign being round-off this close to 0
                out = min(pos)
            else:
                out = math.nan  # unknown: not computed
        return out if rising else -out

    def settle(self, e: _Eval) -> None:
        """The side of ``e`` for the followed block, where its count changes by one across
        the step, decided by the sign of its crossing eigenvalue where that is known and
        disagrees with the inertia: the eigenvalue is a Rayleigh quotient, accurate to far
        below the factorisation's round-off (``Stability.eigenpairs``), which decides the
        inertia's sign within about ε ||H|| of 0, large on the 1D model's stiff blocks (a
        bracket decided by it would exclude the root that its eigenvalue samples give)."""
        c0, c1 = self.c0, self.c1
        b = self.moved_at(self.hi)[0]
        # the trial at most one count past c0: the crossing eigenvalue is the first to cross
        # (a closed sphere's m = 0 block gains 148 in one step at h/R = 1e-4: its first
        # crossing decides the side as well, and its count one past c0 can be round-off)
        if not self.refined or c1[b] == c0[b] or b not in e.counts \
                or abs(e.counts[b] - c0[b]) > 1:
            return
        f = self.crossing(e, b)
        if not math.isfinite(f):
            return
        rising = c1[b] > c0[b]
        crossed = (f < 0) == rising
        if crossed != (e.counts[b] != c0[b]):
            log.debug("locate: the crossing eigenvalue %.3e of block %s decides the side, "
                      "not the inertia (count %d)", f, b, e.counts[b])
            e.counts[b] = (c0[b] + (1 if rising else -1)) if crossed else c0[b]

    def is_low(self, e: _Eval) -> bool:
        """Whether every count known at ``e`` is still c0's."""
        return all(e.counts[b] == self.c0[b] for b in e.counts)

    def tracked(self) -> tuple[Hashable, float | None]:
        """The block followed, and the linear root (κL) of its crossing eigenvalue in the
        bracket (None if unknown): the first of the blocks whose count changed by the high end.
        The inertia of all of them decides the bracket, so it closes on the first crossing of
        any; eigenvalues are computed for the followed block only (a closed sphere's multiplet
        spreads over dozens of Fourier blocks)."""
        lo, hi = self.lo, self.hi
        b = self.moved_at(hi)[0]
        fh = self.crossing(hi, b)
        fl = self.crossing(lo, b) if math.isfinite(fh) else math.nan
        if math.isfinite(fl) and math.isfinite(fh) and fl * fh < 0:
            return b, lo.lam + fl * (hi.lam - lo.lam) / (fl - fh)
        return b, None

    def eig_root(self) -> tuple[float, float] | None:
        """Root of the first crossing eigenvalue in κL: linear in the bracket, quadratic
        through the three samples nearest it; their difference estimates the error."""
        b, lin = self.tracked()
        if lin is None:
            return None
        pts = sorted((q for q in self.samples if math.isfinite(self.crossing(q, b))),
                     key=lambda q: abs(q.lam - lin))[:3]
        if len(pts) < 3 or len({q.lam for q in pts}) < 3:
            return None
        c = np.polyfit([q.lam - lin for q in pts], [self.crossing(q, b) for q in pts], 2)
        roots = np.roots(c)
        roots = roots[np.abs(roots.imag) < 1e-14].real + lin
        lo, hi = self.lo, self.hi
        roots = roots[(roots - min(lo.lam, hi.lam)) * (roots - max(lo.lam, hi.lam)) <= 0]
        if roots.size == 0:
            return None
        quad = float(roots[np.argmin(np.abs(roots - lin))])
        return quad, abs(quad - lin)

    def done(self) -> bool:
        """Whether the search ends before another trial: the bracket is accurate, the
        crossing lies at its low end, it has shrunk to nothing in arclength, or the
        eigenvalue's root is accurate and no other block crossed in it (``interpolated``
        set by the last two)."""
        lo, hi, crit, c0, c1 = self.lo, self.hi, self.crit, self.c0, self.c1
        width = hi.sigma - lo.sigma
        if abs(hi.lam - lo.lam) <= crit.rel_tol * abs(lo.lam) * 0.5 and self.evals >= 1:
            return True
        b_t = self.tracked()[0]
        fl, fh = self.crossing(lo, b_t), self.crossing(hi, b_t)
        if fl * fh > 0 and (fl < 0) == (c1[b_t] > c0[b_t]):
            # the crossing eigenvalue has crossed at the low end already (its inertia there
            # was decided by round-off): the crossing lies just before it, extrapolated
            # linearly with the eigenvalue's slope over the bracket
            slope = (fh - fl) / (hi.lam - lo.lam)
            self.interpolated = (lo.lam - fl / slope, abs(fl / slope))
            log.info("critical point at the bracket's low end kappa L = %.8g: its crossing "
                     "eigenvalue %.3e has the sign of the high end", lo.lam, fl)
            return True
        if width <= 1e-7 * max(hi.sigma, 1e-300):
            # κ jumps across a vanishing arclength interval: the path turns sharply, as at a
            # bifurcation made imperfect by the mesh's broken rotational symmetry; the
            # crossing cannot be pinned closer than this jump (reported as accuracy)
            return True
        r = self.eig_root()
        if r is not None and r[1] <= 0.25 * crit.rel_tol * abs(r[0]):
            # accurate, if no other block crossed in the bracket (it might cross first)
            self.complete(hi)
            if len(self.moved_at(hi)) == 1:
                self.interpolated = self.eig_root()
                return True
            self.suspects = self.moved_at(hi)
        return False

    def next_sigma(self) -> float:
        """The next trial's σ: a secant step on the followed block's crossing eigenvalue,
        halfway to the nearest failed trial if it lies beyond that."""
        lo, hi = self.lo, self.hi
        b_t = self.tracked()[0]
        s = _secant(lo, hi, self.crossing(lo, b_t), self.crossing(hi, b_t), self.sides)
        if self.s_fail is not None and s >= self.s_fail:
            # the corrector failed there: approach the critical point from the near side,
            # where the Jacobian is better conditioned
            s = lo.sigma + 0.5 * (self.s_fail - lo.sigma)
        return s

    def trial(self, s: float) -> _Eval | None:
        """The trial at σ = ``s``, its counts checked for the suspects (those moved at the
        high end first).

        Returns:
            The trial, or None if its corrector failed (counted in ``failures``).
        """
        c0, hi, suspects = self.c0, self.hi, self.suspects
        first = [b for b in suspects if hi.counts.get(b, c0[b]) != c0[b]]
        e = _trial(self.loc, s, self.lo, hi,
                   tuple(first + [b for b in suspects if b not in first]), c0)
        if e is None:
            # right next to a bifurcation (a nearby bifurcated branch, a nearly singular
            # Jacobian) Newton may not converge: retry nearer the low end
            self.failures += 1
            self.s_fail = s if self.s_fail is None else min(self.s_fail, s)
        return e

    def give_up(self) -> None:
        """After 5 failed trials keep what is known: the bracket (and the eigenvalue
        interpolation), its width reported as the accuracy."""
        self.interpolated = self.eig_root()
        if self.interpolated is not None:
            log.info("critical point at kappa L = %.8g from the eigenvalue samples "
                     "(+- %.2g): the corrector does not converge closer to it",
                     *self.interpolated)
        else:
            log.info("critical point located to the bracket kappa L in [%.6g, %.6g] only: "
                     "the corrector does not converge closer to it", self.lo.lam, self.hi.lam)

    def accept(self, e: _Eval) -> None:
        """A converged trial: a sample of the eigenvalue, and the new low or high end."""
        self.evals += 1
        self.samples.append(e)
        self.settle(e)
        self.sides.append(self.is_low(e))
        if self.sides[-1]:
            self.lo = e
        else:
            self.hi = e
            if e.complete:
                self.suspects = self.moved_at(e)

    def result(self) -> CriticalPoint:
        """The critical point: the root (interpolated, linear, or the bracket's middle),
        its accuracy, and the mode of the trial nearest it (one more trial at an
        interpolated root)."""
        lo, hi, loc = self.lo, self.hi, self.loc
        block, lin = self.tracked()
        if self.interpolated is not None:
            lam_star, accuracy = self.interpolated
        elif lin is not None:
            lam_star, accuracy = lin, abs(hi.lam - lo.lam)
        else:
            lam_star = 0.5 * (lo.lam + hi.lam)
            accuracy = abs(hi.lam - lo.lam) / 2
        # the mode at the trial point nearest the critical point (on the near side)
        near = lo if lo.sigma > self.lo0.sigma else hi
        fl, fh = self.crossing(lo, block), self.crossing(hi, block)
        if math.isfinite(fl) and math.isfinite(fh) and fl != fh and hi.lam != lo.lam \
                and not self.refined:
            # no better than the round-off of the crossing eigenvalue allows. Not measured
            # where the eigenvalues are Rayleigh quotients by quadrature
            # (``Stability.eigenpairs``): their round-off lies below the interpolation's
            # error, and measuring it costs 2 solves and 2 eigensolves (docs/design-notes.md,
            # "Locator: round-off of the crossing eigenvalue")
            accuracy = max(accuracy, loc.eigenvalue_roundoff(near, block)
                           * abs(hi.lam - lo.lam) / abs(fh - fl))
        if self.interpolated is not None and hi.lam != lo.lam:
            # the root was interpolated from eigenvalue samples: its nearest trial state may
            # lie well away from it (a branch switch starts from the state); one trial at the
            # root
            s_star = lo.sigma + (lam_star - lo.lam) / (hi.lam - lo.lam) * (hi.sigma - lo.sigma)
            try:
                e_star = loc.evaluate(s_star)
                self.evals += 1
                if abs(e_star.lam - lam_star) < abs(near.lam - lam_star):
                    near = e_star
            except RuntimeError:
                pass
        return _critical_point(loc, "bifurcation", lam_star, (lo.lam, hi.lam), accuracy,
                               near, block, self.c0[block], self.c1[block], self.evals,
                               self.p0, self.t0)


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


def _trial(loc: Locator, s: float, lo: _Eval, hi: _Eval,
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


def _critical_point(loc: Locator, kind: str, lam_star: float, bracket: tuple[float, float],
                    accuracy: float, near: _Eval, block: Hashable, c0: int, c1: int,
                    evals: int, p0: Point, t0: float) -> CriticalPoint:
    """The located point, with its mode at ``near``: the eigenvector nearest 0 of ``block``; a
    fold's, the Jacobian's null vector (the eigenvector along the state tangent, else that
    tangent: ``FOLD_ALONG``).

    Its name (m, n) is that of the cleanest of the eigenvectors whose eigenvalues lie within a
    factor 10 of the nearest one (largest ``m_power``, where the problem reports it): next to
    another critical point the eigenvector nearest 0 can be a mixture, and the members of a
    pair split by the rigid-motion gauge can differ in purity (docs/design-notes.md,
    "Naming a critical point's mode")."""
    e, vecs, vals = loc.modes_at(near, max(loc.crit.nev, 1), block)
    if kind == "fold" and vecs:
        # a fold's mode is the Jacobian's null vector, the branch's own direction there
        # (J τ_w = 0 where τ_λ = 0): of the eigenvectors nearest 0, the one along the state
        # tangent, whatever other soft mode lies nearer 0 at the trial (docs/design-notes.md,
        # "Naming a critical point's mode")
        z = loc.state_tangent()  # at e's state, which modes_at loaded
        M = loc.stab.mass(block)
        zz = max(m_dot(M, z), 1e-300)
        along = [abs(m_inner(M, v, z)) / math.sqrt(max(m_dot(M, v), 1e-300) * zz)
                 for v in vecs]
        best = int(np.argmax(along))
        if along[best] >= FOLD_ALONG:
            e = replace(e, eig=vals[best])
            vecs, vals = [vecs[best]], [vals[best]]  # named by that one alone
        else:
            # none of them is: the fold's eigenvalue at the trial lies beyond the nev modes
            # that crossed before it (past several bifurcations; docs/design-notes.md,
            # "Naming a critical point's mode"). The tangent itself then, M-normalised, with
            # its Rayleigh quotient as the eigenvalue
            v = z.copy()
            v.scale(1.0 / math.sqrt(zz))
            mu = m_dot(loc.stab.assemble(block), v)
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


def m_inner(M: Any, x: Any, y: Any) -> float:
    """xᵀ M y.

    Args:
        M: a PETSc matrix.
        x, y: PETSc vectors.

    Returns:
        The product.
    """
    t = M.createVecLeft()
    M.mult(y, t)
    out = float(x.dot(t))
    t.destroy()
    return out
