"""Following a branch with its stability (algorithm layer, on ``shells.problem.Problem``).

``follow(problem, ...)`` runs the pseudo-arclength continuation and, at every point, the inertia
of every stability block it is given: the Hessian (block ``None``; the surface model's only
block) or the axisymmetric model's Fourier blocks H_m. A change of a block's negative count
between two points brackets a critical point, a sign change of dκ/ds a fold; both are located
inside that step by ``shells.algorithms.locate``. ``FollowResume`` hands out the run's state at
every point, and ``follow(..., resume=r)`` continues after it as the run did.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Hashable, Iterable, Iterator
from dataclasses import replace
from typing import Any

import numpy as np

from shells.algorithms.bordered import Arclength
from shells.algorithms.continuation import Point, continuation, next_step
from shells.algorithms.locate import Locator, locate, negative_total
from shells.algorithms.newton import NewtonSolver
from shells.algorithms.records import CriticalPoint, FollowResume
from shells.algorithms.settings import ContinuationSettings, CriticalSettings, in_arclength
from shells.algorithms.stability import Stability, StabilityResult, rayleigh_quotient
from shells.errors import InputError
from shells.problem.interface import get_state, set_state

log = logging.getLogger("shells")

__all__ = ["follow", "state_kappa"]


def follow(problem: Any, settings: ContinuationSettings, kappa_end: float,
           crit: CriticalSettings | None = None, *, solver: NewtonSolver | None = None,
           nev: int = 0, blocks: Iterable[Hashable] | None = None,
           locate_when: Callable[[Point, dict[Hashable, int], dict[Hashable, int]], bool]
           | None = None, locate_points: bool = True, kappa_start: float = 0.0,
           resume: FollowResume | None = None,
           track: Callable[[FollowResume], None] | None = None, scalars: bool = True
           ) -> Iterator[tuple[Point, StabilityResult, list[CriticalPoint]]]:
    """Follow the branch to ``kappa_end`` with stability at every point.

    Stability is the negative count of every block of ``blocks``, in
    ``StabilityResult.counts``, their sum in ``negative_count``. A step is searched for
    critical points (``locate``) when a count changes or dκ/ds changes sign.

    Args:
        problem: the problem; its state must be near the branch's state at ``kappa_start``.
        settings: continuation settings (arclength method).
        kappa_end: the κ the run ends at.
        crit: how critical points are located and when the run stops (default
            ``CriticalSettings()``).
        solver: the Newton solver to use (default: a new one).
        nev: compute that many eigenvalues of block ``None`` per point (0: none).
        blocks: the stability blocks to count (default ``(None,)``, the Jacobian; the
            axisymmetric model's Fourier blocks are ``problem.stability_blocks()``).
        locate_when: ``locate_when(point, counts before, counts after)`` decides whether a
            step is searched for bifurcations (default: when a count changes); folds are
            always located.
        locate_points: False: stability only, no location.
        kappa_start: the start's κ (unused when resuming).
        resume: a ``FollowResume`` handed out by ``track``: with the same problem (any
            partition: its arrays are this rank's owned values), settings and arguments the
            run continues after that point as the tracked run did: from its state and κ, the
            first tangent oriented by its secant, its next step in its arclength units, the
            points from index r.index + 1, the first step searched for a change of its counts
            (and a fold). The points are the uninterrupted run's to the corrector's round-off
            (the start is re-converged). Nothing is yielded when that run had ended.
        track: called as ``track(r)`` at every point just before it is yielded, with its
            ``FollowResume`` r (a checkpoint).
        scalars: False: the points carry no ``scalars`` (``continuation``'s).

    Yields:
        (point, stability, critical points located in the step that ended at this point).
        The problem's state is the point's state at each yield.

    Raises:
        InputError: if ``settings.method`` is not "arclength".
    """
    crit = crit or CriticalSettings()
    if settings.method != "arclength":
        raise InputError("locating critical points needs the arclength method (folds)")
    if resume is not None and resume.ended:
        return
    run = _Follow(problem, settings, kappa_end, crit, solver, nev=nev, blocks=blocks,
                  locate_when=locate_when, locate_points=locate_points,
                  kappa_start=kappa_start, resume=resume, track=track, scalars=scalars)
    try:
        yield from run.points()
    finally:
        run.destroy()


class _Follow:
    """One run of ``follow``: the continuation's start, the last point (point, state,
    counts), the critical points found so far and the locator. The arguments are
    ``follow``'s."""

    def __init__(self, problem: Any, settings: ContinuationSettings, kappa_end: float,
                 crit: CriticalSettings, solver: NewtonSolver | None, *, nev: int,
                 blocks: Iterable[Hashable] | None,
                 locate_when: Callable[[Point, dict[Hashable, int], dict[Hashable, int]], bool]
                 | None, locate_points: bool, kappa_start: float,
                 resume: FollowResume | None, track: Callable[[FollowResume], None] | None,
                 scalars: bool) -> None:
        self.problem, self.settings, self.kappa_end, self.crit = problem, settings, kappa_end, crit
        self.nev, self.locate_when, self.locate_points = nev, locate_when, locate_points
        self.track, self.scalars = track, scalars
        self.blocks = (None,) if blocks is None else tuple(blocks)
        self.L = problem.length_scale()
        self.lam_end = kappa_end * self.L
        self.prev: tuple[Point, np.ndarray, dict[Hashable, int]] | None = None
        self.n_found = 0
        self.folds_only = False
        self.tl0: float | None = None  # the first point's dκ/ds (steps in κL: converted with it)
        self.start: dict[str, Any] = dict(kappa_start=kappa_start)
        self.st = settings
        if resume is not None:
            self.resume_from(resume)
        self.own_solver = solver is None
        self.ns = solver or NewtonSolver(problem)
        self.stab = Stability(problem)
        self.loc = Locator(problem, settings, crit, self.stab)
        self.held: list[np.ndarray] = []  # the tangent the next step follows (for ``track``)

    def destroy(self) -> None:
        """Free the locator, the stability and a solver of the run's own."""
        self.loc.destroy()
        self.stab.destroy()
        if self.own_solver:
            self.ns.destroy()

    def resume_from(self, r: FollowResume) -> None:
        """The start after the point of ``r``: its state, settings, first tangent and step,
        the point before, and the critical points found so far."""
        from mpi4py import MPI

        problem, L, settings = self.problem, self.L, self.settings
        self.tl0 = r.tl0
        self.st = replace(in_arclength(settings, r.tl0),
                          max_steps=max(1, settings.max_steps - r.index))
        set_state(problem, r.state)
        secant = r.state - r.state_prev
        dlam = (r.kappa - r.kappa_prev) * L
        moved = problem.comm.allreduce(bool(np.any(secant)), op=MPI.LOR) or dlam != 0
        self.start = dict(
            kappa_start=r.kappa, start_index=r.index + 1, skip_first=True,
            initial_tangent=(secant, dlam) if moved else None, initial_ds=r.ds,
            tangent=None if r.tangent is None else (r.tangent, r.dkappa_ds),
            # the point before, for a quadratic predictor's first step
            previous=(r.state_prev, r.kappa_prev, r.step) if r.index > 0 else None)
        self.prev = (Point(index=r.index, kappa=r.kappa, kappa_L=r.kappa * L,
                           newton_its=r.newton_its, step=r.step, dkappa_ds=r.dkappa_ds,
                           wall_time=0.0), r.state.copy(), dict(r.counts))
        self.n_found, self.folds_only = r.found, r.folds_only

    def hold(self, tw: np.ndarray, tl: float) -> None:
        """Keep the tangent the next step follows (``continuation``'s ``on_tangent``)."""
        self.held[:] = [tw]

    def points(self) -> Iterator[tuple[Point, StabilityResult, list[CriticalPoint]]]:
        """The continuation, with each point's stability and the critical points in its step.

        Yields:
            ``follow``'s triples.
        """
        crit, problem = self.crit, self.problem
        for p in continuation(problem, self.st, kappa_end=self.kappa_end, solver=self.ns,
                              **self.start, on_tangent=None if self.track is None else self.hold,
                              scalars=self.scalars):
            res, counts = self.stability()
            found = self.locate_step(p, counts)
            stop = bool(found) and (
                crit.stop_at_first or (crit.stop_at_fold and any(c.kind == "fold" for c in found))
                or (crit.max_critical is not None and self.n_found >= crit.max_critical))
            if crit.folds_only_after_first and any(c.kind != "fold" for c in found):
                self.folds_only = True
            state = get_state(problem)
            if self.tl0 is None:
                self.tl0 = p.dkappa_ds
            if self.track is not None:
                self.checkpoint(p, counts, state, stop)
            self.prev = (p, state, counts)
            yield p, res, found
            if stop:
                return

    def stability(self) -> tuple[StabilityResult, dict[Hashable, int]]:
        """The stability at the current point: the negative counts of the blocks (the last
        point's, unchecked, once only folds are located).

        Returns:
            (the ``StabilityResult``, the counts by block).
        """
        prev, stab = self.prev, self.stab
        if self.folds_only:
            counts = dict(prev[2]) if prev is not None else {}
            res = StabilityResult(stable=False, negative_count=negative_total(counts),
                                  zero_count=0, counts=None)
        elif self.blocks == (None,):
            res = stab.check(nev=self.nev)
            counts = {None: res.negative_count}
            res.counts = counts
        else:
            counts = stab.negative_counts(self.blocks)
            if prev is not None and self.locate_points and counts != prev[2] \
                    and stab.rayleigh_quotients:
                counts = _confirmed_counts(stab, prev[2], counts)
            vals = stab.eigenpairs(self.nev)[0] if self.nev > 0 else []
            total = negative_total(counts)
            res = StabilityResult(stable=total == 0, negative_count=total, zero_count=0,
                                  eigenvalues=vals, counts=counts)
        return res, counts

    def locate_step(self, p: Point, counts: dict[Hashable, int]) -> list[CriticalPoint]:
        """The critical points in the step that ended at ``p`` (a fold where dκ/ds changed
        sign; bifurcations where ``locate_when``, or a change of the counts, says so), at
        most ``max_critical`` in all; the problem is left at ``p``.

        Returns:
            The critical points, in branch order.
        """
        prev, crit, problem = self.prev, self.crit, self.problem
        if prev is None or not self.locate_points:
            return []
        fold = (prev[0].dkappa_ds >= 0) != (p.dkappa_ds >= 0)
        wanted = (self.locate_when(p, prev[2], counts) if self.locate_when is not None
                  else counts != prev[2])
        if not (fold or (wanted and not self.folds_only)):
            return []
        w1 = get_state(problem)
        k1 = problem.get_kappa()
        left = None if crit.max_critical is None else crit.max_critical - self.n_found
        found = locate(self.loc, prev[0], prev[1], prev[2], p,
                       None if self.folds_only or not wanted else counts, w1, limit=left)
        if crit.max_critical is not None:
            found = found[:left]
        self.n_found += len(found)
        # back to the branch point: the continuation goes on from it
        set_state(problem, w1)
        problem.set_kappa(k1)
        return found

    def checkpoint(self, p: Point, counts: dict[Hashable, int], state: np.ndarray,
                   stop: bool) -> None:
        """``track`` the point ``p`` (its counts and state; ``stop``: the run ends there)."""
        prev = self.prev
        # the next step: the arclength loop's (the first: the settings' own)
        st_arc = in_arclength(self.st, self.tl0)
        ds = st_arc.ds if prev is None else next_step(st_arc, p.step, p.newton_its)
        landed = abs(p.kappa_L - self.lam_end) <= 1e-12 * abs(self.lam_end)
        self.track(FollowResume(
            index=p.index, kappa=p.kappa,
            kappa_prev=p.kappa if prev is None else prev[0].kappa,
            dkappa_ds=p.dkappa_ds, newton_its=p.newton_its, step=p.step, ds=ds,
            tl0=self.tl0, counts=dict(counts), found=self.n_found, folds_only=self.folds_only,
            ended=stop or landed, state=state,
            state_prev=state if prev is None else prev[1],
            tangent=self.held[-1] if self.held else None))


def state_kappa(ns: NewtonSolver, ar: Arclength, lam: float) -> float:
    """κL at which the model's current state is nearest to equilibrium (least squares).

    The residual is affine in κ (b̄ = b° + κ a° enters the energy quadratically), so one
    least-squares step from any guess is exact. A critical point's state comes from a trial
    solve whose κ is not the located κ (which is interpolated).

    Args:
        ns: the problem's Newton solver.
        ar: the arclength vectors (for ∂R/∂λ).
        lam: a guess of λ = κL.

    Returns:
        The least-squares λ; the problem's κ is set to it.
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


def _confirmed_counts(stab: Stability, before: dict[Hashable, int],
                      after: dict[Hashable, int]) -> dict[Hashable, int]:
    """The negative counts ``after`` of a branch point whose blocks' counts were ``before`` at
    the point before, where a count that moved by one is checked against the sign of its
    crossing eigenvalue's Rayleigh quotient by quadrature (``Stability.eigenpairs``; problems
    that give them): the eigenvalue nearest 0 on the side the inertia moved it to (a rising
    count: the negative one nearest 0). Where the quotient disagrees, the point lies within
    the factorisation's round-off of a crossing that belongs to the next step, and the block
    keeps its count (the next step brackets the crossing); docs/model.md, "The thin end"."""
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
            q = rayleigh_quotient(stab.problem.hessian_quadratic(b, vec), stab.mass(b), vec, mu)
            if (q < 0) != (mu < 0):
                log.debug("block %s: the inertia's count %d at this point is round-off "
                          "(eigenvalue %.3e, Rayleigh quotient %.3e): kept at %d", b, c1, mu,
                          q, c0)
                out[b] = c0
        finally:
            for x in vecs:
                x.destroy()
    return out
