"""The algorithm layer (continuation, stability, critical points, branch switching) on the tiny
algebraic problems of ``shells.problem.algebraic``, whose answers are known exactly: milliseconds
per test. Each rank solves its own copy (MPI.COMM_SELF), so the tests are valid on any number of
ranks; one test distributes a problem over MPI.COMM_WORLD and checks that the answer is the
same.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from shells.algorithms.continuation import continuation
from shells.algorithms.following import follow
from shells.algorithms.settings import ContinuationSettings, CriticalSettings
from shells.algorithms.stability import Stability
from shells.algorithms.switching import switch_branch
from shells.errors import InputError
from shells.problem.algebraic import (
    AlgebraicProblem,
    FoldPitchforkProblem,
    FoldProblem,
    PitchforkProblem,
    SubcriticalPitchforkProblem,
)
from shells.problem.interface import Problem

STEPS = ContinuationSettings(ds=0.1, ds_max=0.2)


def test_the_problems_implement_the_interface():
    assert isinstance(FoldProblem(), Problem)
    assert isinstance(PitchforkProblem(), Problem)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_fold_located_to_1e8(sign):
    """x² + sκ - 1 = 0: the stable branch from x = 1 reaches its fold at κ = s."""
    P = FoldProblem(sign=sign)
    crit = CriticalSettings(rel_tol=1e-8)
    run = list(follow(P, STEPS, 3.0 * sign, crit))
    found = [c for _, _, cps in run for c in cps]
    assert len(found) == 1
    cp = found[0]
    assert cp.kind == "fold"
    assert cp.kappa == pytest.approx(sign, rel=1e-8)
    assert cp.accuracy < 1e-8
    assert (cp.negative_before, cp.negative_after) == (0, 1)
    # on the stable half before the fold: the exact branch, stable
    for p, r, _ in run[:-1]:
        assert p.scalars["w0"] == pytest.approx(P.exact_x(p.kappa), abs=1e-8)
        assert r.negative_count == 0


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_arclength_turns_around_the_fold(sign):
    """Past the fold the branch comes back (κ moves back towards 0) on the unstable half
    x = -sqrt(1 - sκ), with one negative eigenvalue."""
    P = FoldProblem(sign=sign)
    st = ContinuationSettings(ds=0.1, ds_max=0.2, max_steps=20)
    stab = Stability(P)
    pts = []
    for p in continuation(P, st, kappa_end=3.0 * sign):
        pts.append((p.kappa, p.scalars["w0"], p.dkappa_ds, stab.negative_count()))
    stab.destroy()
    assert len(pts) == 21  # the run never reaches κ = 3s: it turned around
    after = [q for q in pts if q[1] < 0]
    assert len(after) >= 5
    for kappa, x, dk, neg in after:
        assert x == pytest.approx(-math.sqrt(1.0 - sign * kappa), abs=1e-8)
        assert dk * sign < 0  # κ moves back
        assert neg == 1
    kappas = [q[0] for q in after]
    assert all((a - b) * sign > 0 for a, b in zip(kappas, kappas[1:], strict=False))


def test_natural_steps_down_mirror_the_steps_up():
    """The fold problem with κ → -κ, followed down by natural steps, is the mirror image of the
    run up: the same points and Newton iterations (the secant predictor once pointed back
    along a downward run: more iterations, a 30° cap's run down took 28 points instead of
    10)."""
    from shells.algorithms.continuation import continuation
    from shells.algorithms.settings import ContinuationSettings

    st = ContinuationSettings(method="natural", ds=0.1, ds_max=0.2)
    up = list(continuation(FoldProblem(1.0), st, kappa_end=0.9))
    down = list(continuation(FoldProblem(-1.0), st, kappa_end=-0.9))
    assert [p.newton_its for p in down] == [p.newton_its for p in up]
    assert [p.kappa for p in down] == pytest.approx([-p.kappa for p in up], abs=1e-14)
    assert [p.scalars["w0"] for p in down] == pytest.approx([p.scalars["w0"] for p in up],
                                                            abs=1e-12)


class _FoldWithFarRoot(FoldProblem):
    """R = (x² + κ - 1)(x - 1000) in one unknown: the fold problem's branch x = sqrt(1 - κ),
    ending at the fold κ = 1, and a second solution x = 1000 for every κ."""

    X = 1000.0

    def __init__(self) -> None:
        AlgebraicProblem.__init__(self, 1, np.ones(1))

    def energy(self, w, k):
        x, a = w[0], k - 1
        return x**4 / 4 - self.X * x**3 / 3 + a * x**2 / 2 - a * self.X * x

    def gradient(self, w, k):
        return np.array([(w[0] ** 2 + k - 1) * (w[0] - self.X)])

    def hessian(self, w, k):
        x = w[0]
        return np.array([[2 * x * (x - self.X) + x * x + k - 1]])

    def dgradient_dkappa(self, w, k):
        return np.array([w[0] - self.X])


def test_natural_steps_refuse_a_jump_to_another_solution(monkeypatch):
    """Natural steps cannot pass the fold at κ = 1; the step past it, from x = 0.32 at κ = 0.9,
    converges to the far root x = 1000 (checked: without the jump test, points at κ = 1.2 and
    1.5 with x = 1000). The run must instead stop at the fold on its own branch. (A 30° cap on
    2 ranks once so jumped to Psi3/h = 1.4e4 just short of its snap-through fold.)"""
    import shells.algorithms.continuation as cont

    st = ContinuationSettings(method="natural", ds=0.3, ds_max=0.3, ds_min=1e-3,
                              max_newton_its=20)
    pts = list(continuation(_FoldWithFarRoot(), st, kappa_end=1.5))
    assert all(abs(p.scalars["w0"] ** 2 + p.kappa - 1) < 1e-8 for p in pts)  # on the branch
    assert 0.999 < pts[-1].kappa < 1.0 and pts[-1].scalars["w0"] > 0
    # the same run without the test does jump: the problem tests what it claims to
    monkeypatch.setattr(cont, "JUMP_FACTOR", math.inf)
    pts = list(continuation(_FoldWithFarRoot(), st, kappa_end=1.5))
    assert pts[-1].kappa == 1.5 and pts[-1].scalars["w0"] == pytest.approx(1000.0)


def test_pitchfork_located_to_1e8():
    P = PitchforkProblem()
    run = list(follow(P, STEPS, 2.5, CriticalSettings(rel_tol=1e-8, stop_at_fold=False)))
    found = [c for _, _, cps in run for c in cps]
    # the x pitchfork at κ = 1 and the z_1 one at κ = c_1 = 2, in that order
    assert [c.kind for c in found] == ["bifurcation", "bifurcation"]
    assert [c.kappa for c in found] == pytest.approx([1.0, 2.0], rel=1e-8)
    assert [c.mode_m for c in found] == [1, 2]
    assert [(c.negative_before, c.negative_after) for c in found] == [(0, 1), (1, 2)]


def test_a_bifurcation_and_a_fold_in_one_step_on_two_blocks():
    """Block 1 (z) loses stability at κ = c = 0.995, block 0 (x) has its fold at κ = 1: one
    step of 0.2 holds both. Both are found, in branch order, each to 1e-8, named by block;
    ``max_critical`` 1 keeps the first; folds-only after it still finds the fold."""
    P = FoldPitchforkProblem(c=0.995)
    st = ContinuationSettings(ds=0.2, ds_max=0.2)
    run = list(follow(P, st, 2.0, CriticalSettings(rel_tol=1e-8), blocks=(0, 1)))
    steps = [cps for _, _, cps in run if cps]
    assert len(steps) == 1  # one step: the bifurcation and the fold together
    found = steps[0]
    assert [c.kind for c in found] == ["bifurcation", "fold"]
    assert [c.kappa for c in found] == pytest.approx([0.995, 1.0], rel=1e-8)
    assert [c.block for c in found] == [1, None]
    assert found[0].mode_m == 1
    assert (found[0].negative_before, found[0].negative_after) == (0, 1)
    assert run[0][1].counts == {0: 0, 1: 0}
    first = [c for _, _, cps in follow(P, st, 2.0, CriticalSettings(rel_tol=1e-8,
                                                                    max_critical=1),
                                       blocks=(0, 1)) for c in cps]
    assert [c.kind for c in first] == ["bifurcation"]
    assert first[0].kappa == pytest.approx(0.995, rel=1e-8)
    # with the Jacobian alone (block None) the z-crossing is found as well
    whole = [c for _, _, cps in follow(P, st, 2.0, CriticalSettings(rel_tol=1e-8)) for c in cps]
    assert [c.kind for c in whole] == ["bifurcation", "fold"]


class _ThreeBlocks(PitchforkProblem):
    """``PitchforkProblem`` with x, z_1 and z_2 as blocks 0, 1, 2: on the branch x = z = 0,
    y = κ they decouple, crossing at κ = 1, c_1 and c_2."""

    block_unknowns = {0: (1,), 1: (2,), 2: (3,)}


def test_crossings_of_several_blocks_in_one_step_share_the_steps_trials(monkeypatch):
    """Three blocks cross in one step, in the reverse order of their keys (κ = 0.96, 0.98, 1):
    each is located to 1e-8 and named by its block. The first search follows block 0's
    eigenvalue (the first block that moved) and closes on block 1's crossing; the search for
    block 0's own crossing then takes the same first trials, which the step computed already:
    fewer corrector solves and eigensolves than with each crossing located afresh, the same
    points to the last digit."""
    from shells.algorithms import locate

    P = _ThreeBlocks(c=(0.96, 0.98))
    st = ContinuationSettings(ds=0.3, ds_max=0.3)
    calls = {"solves": 0, "eigs": 0}
    newton, eigs = locate.bordered_newton, Stability.eigenpairs

    def counted_newton(*args, **kwargs):
        calls["solves"] += 1
        return newton(*args, **kwargs)

    def counted_eigs(self, *args, **kwargs):
        calls["eigs"] += 1
        return eigs(self, *args, **kwargs)

    monkeypatch.setattr(locate, "bordered_newton", counted_newton)
    monkeypatch.setattr(Stability, "eigenpairs", counted_eigs)

    def run() -> tuple[list, dict]:
        calls.update(solves=0, eigs=0)
        steps = [cps for _, _, cps in follow(P, st, 1.3, CriticalSettings(rel_tol=1e-8),
                                             blocks=(0, 1, 2)) if cps]
        return steps, dict(calls)

    steps, shared = run()
    assert len(steps) == 1  # one step holds the three crossings
    assert [c.kappa for c in steps[0]] == pytest.approx([0.96, 0.98, 1.0], rel=1e-8)
    assert [c.block for c in steps[0]] == [1, 2, 0]
    start = locate.Locator.start

    def forgetful_start(self, *args, **kwargs):  # every crossing located afresh
        start(self, *args, **kwargs)
        self._memo.clear()

    monkeypatch.setattr(locate.Locator, "start", forgetful_start)
    alone, afresh = run()
    assert [c.kappa for c in alone[0]] == [c.kappa for c in steps[0]]
    assert shared["solves"] < afresh["solves"] and shared["eigs"] < afresh["eigs"], \
        (shared, afresh)


class _NamedFoldPitchfork(FoldPitchforkProblem):
    """``FoldPitchforkProblem`` whose modes are named: x is m = 1, z is m = 2."""

    mode_unknowns = (0, 1)


def test_a_fold_is_named_by_its_own_mode_not_the_softest():
    """The fold of x (κ = 1) with z's eigenvalue c - κ = 1e-7 there, nearer 0 than the fold's
    own at any trial the locator takes: the fold's mode is the Jacobian's null vector, the
    branch's own direction (x, m = 1), not the eigenvector nearest 0 (z, m = 2)."""
    P = _NamedFoldPitchfork(c=1.0 + 1e-7)
    st = ContinuationSettings(ds=0.05, ds_max=0.2)
    found = [c for _, _, cps in follow(P, st, 2.0, CriticalSettings(rel_tol=1e-6),
                                       blocks=(0, 1)) for c in cps]
    assert [c.kind for c in found] == ["fold"]
    assert found[0].kappa == pytest.approx(1.0, rel=1e-6)
    assert found[0].mode_m == 1
    # the trial it was named at: z's eigenvalue is the one nearest 0 there
    assert abs(found[0].eigenvalue) > 2e-7, found[0]


def test_a_fold_whose_mode_is_not_among_the_eigenpairs_computed_is_named_by_its_tangent():
    """As above with one eigenpair per trial (``nev`` = 1): it is z's, nearly orthogonal to the
    tangent (cosine below ``FOLD_ALONG``), as a surface fold's four nearest 0 are the pairs that
    crossed before it; the fold is named by the state tangent itself (x, m = 1), its eigenvalue
    the tangent's Rayleigh quotient, which vanishes at the fold as the distance to it."""
    P = _NamedFoldPitchfork(c=1.0 + 1e-7)
    st = ContinuationSettings(ds=0.05, ds_max=0.2)
    found = [c for _, _, cps in follow(P, st, 2.0, CriticalSettings(rel_tol=1e-6, nev=1),
                                       blocks=(0, 1)) for c in cps]
    assert [c.kind for c in found] == ["fold"]
    cp = found[0]
    assert cp.kappa == pytest.approx(1.0, rel=1e-6)
    assert cp.mode_m == 1
    mode = np.asarray(cp.mode)
    # the mode is x's direction (the branch's own at the fold), not z's
    n_own = len(mode)
    lo, _ = P.state.getOwnershipRange()
    comps = {i: (mode[i - lo] if lo <= i < lo + n_own else 0.0) for i in (0, 1)}
    comps = {i: P.comm.allreduce(v) for i, v in comps.items()}
    assert abs(comps[0]) == pytest.approx(1.0, rel=1e-3)
    assert abs(comps[1]) < 1e-3
    # μ of x's direction at the trial: the Jacobian's eigenvalue there, small as κ - 1 is
    assert 0 < abs(cp.eigenvalue) < 1e-2


def test_folds_only_after_the_first_bifurcation():
    """Pitchforks at κ = 1 (x) and 2 (z_1) and no fold: with
    ``folds_only_after_first`` the second is not searched for."""
    P = PitchforkProblem()
    run = list(follow(P, STEPS, 2.5, CriticalSettings(rel_tol=1e-8, stop_at_fold=False,
                                                      folds_only_after_first=True)))
    found = [c for _, _, cps in run for c in cps]
    assert [c.kappa for c in found] == pytest.approx([1.0], rel=1e-8)
    assert run[-1][1].counts is None  # not computed past the first bifurcation


def test_switching_onto_the_pitchfork_branch():
    """The bifurcated branch x² = 2(κ - 1): on it exactly, stable, below the fundamental
    branch (E = -(κ - 1)²/2 against 0), amplitude ∝ (κ - κ_c)^½ (fitted exponent)."""
    P = PitchforkProblem()
    run = list(follow(P, STEPS, 1.4, CriticalSettings(rel_tol=1e-8, stop_at_first=True)))
    cp = run[-1][2][0]
    stab = Stability(P)
    pts = []
    for p in switch_branch(P, cp, ContinuationSettings(ds=0.05, ds_max=0.1), 1.4, ds=0.05):
        pts.append((p, stab.negative_count()))
    stab.destroy()
    assert pts[-1][0].kappa == pytest.approx(1.4, rel=1e-12)  # landed on the end
    dk, amp = [], []
    for p, neg in pts:
        k, x, y = p.kappa, p.scalars["w1"], p.scalars["w0"]
        assert x * x == pytest.approx(2 * (k - 1), abs=1e-8)
        assert y == pytest.approx(2 * k - 1, abs=1e-8)
        assert p.scalars["energy"] == pytest.approx(-0.5 * (k - 1) ** 2, abs=1e-10)
        assert p.scalars["energy"] < 0  # the fundamental branch has E = 0
        assert neg == 0
        dk.append(k - cp.kappa)
        amp.append(abs(p.scalars["mode_amplitude"]))
    slope = float(np.polyfit(np.log(dk), np.log(amp), 1)[0])
    assert slope == pytest.approx(0.5, abs=0.01)


def _functional(P, weights):
    """A state-shaped vector e with e·w = Σ weights[i] w_i (on any partition)."""
    e = P.state.duplicate()
    e.set(0.0)
    lo, hi = e.getOwnershipRange()
    for i, v in weights.items():
        if lo <= i < hi:
            e.setValue(i, v)
    e.assemble()
    return e


def test_a_state_parameter_follows_a_subcritical_branch_through_its_fold():
    """``switch_branch(..., control=e)`` with e·w = x: the subcritical branch
    κ = 1 - 3x²/2 + x⁴ in steps of x, down through its fold (x² = 3/4, κ = 7/16) and up to the
    end of the range, exactly on the branch; one negative eigenvalue before the fold, none
    after (until y = κ + x²/2 passes the z-bifurcations at c_i); x grows at every step."""
    P = SubcriticalPitchforkProblem()
    run = list(follow(P, STEPS, 1.5, CriticalSettings(rel_tol=1e-8, stop_at_first=True)))
    cp = run[-1][2][0]
    assert cp.kind == "bifurcation" and cp.kappa == pytest.approx(1.0, rel=1e-8)
    e = _functional(P, {1: 1.0})
    stab = Stability(P)
    pts = []
    for p in switch_branch(P, cp, ContinuationSettings(ds=0.05, ds_max=0.1), 1.5, ds=0.05,
                           control=e, sign=1.0):
        pts.append((p, stab.negative_count()))
    stab.destroy()
    xs = [p.scalars["w1"] for p, _ in pts]
    ks = [p.kappa for p, _ in pts]
    assert xs[0] == pytest.approx(0.05, abs=1e-12)  # the first point's x - x_c
    assert all(b > a for a, b in zip(xs, xs[1:], strict=False))
    for p, neg in pts:
        x, k = p.scalars["w1"], p.kappa
        assert k == pytest.approx(1 - 1.5 * x * x + x**4, abs=1e-9)
        assert p.scalars["w0"] == pytest.approx(k + 0.5 * x * x, abs=1e-9)
        y = p.scalars["w0"]
        if abs(x * x - 0.75) > 1e-6 and min(abs(y - c) for c in P.c) > 1e-6:
            # x's Schur complement x² (4x² - 3), and each z_i once y passes c_i
            assert neg == (x * x < 0.75) + sum(y > c for c in P.c)
    # the fold was passed on the branch, not jumped: no point below it, some near it
    assert 7 / 16 - 1e-9 <= min(ks) < 0.46
    assert ks[-1] == pytest.approx(1.5, rel=1e-12)  # landed on the end of the range
    assert sum(neg == 1 for _, neg in pts) >= 5 and sum(neg == 0 for _, neg in pts) >= 3
    e.destroy()


def test_the_branch_goes_on_by_arclength_past_a_fold_of_its_control():
    """With c = 0.3 x + y as the control, c has a maximum on the subcritical branch
    (dc/dx = 0.3 - 2x + 4x³ = 0 at x = 0.157): the steps in c stop there, the branch goes on by
    arclength from the last two points (``control_parameter`` 0), still exactly on it, to the
    end of the range."""
    P = SubcriticalPitchforkProblem()
    run = list(follow(P, STEPS, 1.5, CriticalSettings(rel_tol=1e-8, stop_at_first=True)))
    cp = run[-1][2][0]
    e = _functional(P, {0: 1.0, 1: 0.3})
    pts = list(switch_branch(P, cp, ContinuationSettings(ds=0.005, ds_max=0.01), 1.5, ds=0.005,
                             control=e, sign=1.0))
    e.destroy()
    by_c = [p for p in pts if p.scalars["control_parameter"] == 1.0]
    by_s = [p for p in pts if p.scalars["control_parameter"] == 0.0]
    assert by_c and by_s and pts[: len(by_c)] == by_c  # c first, then arclength
    assert max(p.scalars["w1"] for p in by_c) == pytest.approx(0.157, abs=0.03)
    for p in pts:
        x, k = p.scalars["w1"], p.kappa
        assert k == pytest.approx(1 - 1.5 * x * x + x**4, abs=1e-9)
    assert pts[-1].kappa == pytest.approx(1.5, rel=1e-12)
    assert min(p.kappa for p in pts) < 0.46  # through the fold in κ as well


def test_a_controlled_branch_resumes_on_either_side_of_the_fold_of_its_control():
    """``switch_branch(..., control=e, resume=r)`` continues as the uninterrupted run did, from
    a point followed with c and from one past the fold of c (by arclength): the same later
    points."""
    P = SubcriticalPitchforkProblem()
    run = list(follow(P, STEPS, 1.5, CriticalSettings(rel_tol=1e-8, stop_at_first=True)))
    cp = run[-1][2][0]
    e = _functional(P, {0: 1.0, 1: 0.3})
    st = ContinuationSettings(ds=0.005, ds_max=0.01)
    tracked = []
    full = list(switch_branch(P, cp, st, 1.5, ds=0.005, control=e, track=tracked.append))
    flags = [r.by_arclength for r in tracked]
    k_c, k_s = flags.index(False) + 2, flags.index(True) + 3  # one of each kind
    assert not flags[k_c] and flags[k_s]
    for k in (k_c, k_s):
        rest = list(switch_branch(P, cp, st, 1.5, ds=0.005, control=e, resume=tracked[k]))
        assert [(p.index, p.newton_its, p.step) for p in rest] == [
            (p.index, p.newton_its, p.step) for p in full[k + 1:]]
        assert [p.kappa for p in rest] == pytest.approx([p.kappa for p in full[k + 1:]],
                                                        rel=1e-10)
    e.destroy()


def test_switching_resumes_after_a_tracked_point():
    """``switch_branch(..., resume=r)`` from the ``SwitchResume`` r tracked at a point continues
    as the uninterrupted run: the same later points (κ, iterations, steps)."""
    P = PitchforkProblem()
    run = list(follow(P, STEPS, 1.4, CriticalSettings(rel_tol=1e-8, stop_at_first=True)))
    cp = run[-1][2][0]
    st = ContinuationSettings(ds=0.02, ds_max=0.1)
    tracked = []
    full = list(switch_branch(P, cp, st, 1.4, ds=0.02, track=tracked.append))
    assert len(full) >= 5 and [r.index for r in tracked] == [p.index for p in full]
    for k in (0, 2):
        rest = list(switch_branch(P, cp, st, 1.4, ds=0.02, resume=tracked[k]))
        assert [(p.index, p.newton_its, p.step) for p in rest] == [
            (p.index, p.newton_its, p.step) for p in full[k + 1:]]
        assert [p.kappa for p in rest] == pytest.approx([p.kappa for p in full[k + 1:]],
                                                        rel=1e-12)


def test_distributed_fold_gives_the_same_answer():
    """The fold problem with its unknowns spread over all ranks: same fold, to round-off."""
    from mpi4py import MPI

    P = FoldProblem(springs=3, comm=MPI.COMM_WORLD)
    run = list(follow(P, STEPS, 3.0, CriticalSettings(rel_tol=1e-8)))
    cp = run[-1][2][0]
    assert cp.kind == "fold" and cp.kappa == pytest.approx(1.0, rel=1e-8)
    assert MPI.COMM_WORLD.allreduce(cp.kappa, op=MPI.MAX) == MPI.COMM_WORLD.allreduce(
        cp.kappa, op=MPI.MIN)


def test_a_round_off_inertia_next_to_the_crossing_does_not_move_the_bifurcation(monkeypatch):
    """The factorisation's sign of an eigenvalue at round-off (|μ| ~ 1e-17 ‖H‖, met on a thin
    cap's m = 2 block) is arbitrary: injected here, the inertia keeps the count of before the
    pitchfork (κ = 1) on (1, 1.03), where the eigenvalue 1 - κ is negative. The locator, which
    took such a count for the low side and settled 3.4 % late on that cap, puts the crossing
    where the eigenvalues say: extrapolated from the low end whose eigenvalue has crossed."""
    P = PitchforkProblem()
    exact = Stability.inertia
    wrong = []

    def round_off_inertia(self, block=None, test=True):
        neg, zero, pos = exact(self, block, test)
        if 1.0 < self.problem.get_kappa() < 1.03 and neg == 1:
            wrong.append(self.problem.get_kappa())
            return 0, zero, pos + 1
        return neg, zero, pos

    monkeypatch.setattr(Stability, "inertia", round_off_inertia)
    st = ContinuationSettings(ds=0.2, ds_max=0.2)
    found = [c for _, _, cps in follow(P, st, 1.5, CriticalSettings(rel_tol=1e-8, max_critical=1))
             for c in cps]
    assert wrong, "no trial point fell into the injected interval: the test tests nothing"
    assert [c.kind for c in found] == ["bifurcation"]
    assert found[0].kappa == pytest.approx(1.0, rel=1e-8)


def test_the_corrector_reuses_its_factorisation_near_the_solution(monkeypatch):
    """Chord steps within ``factor_reuse`` of the last factored iterate, and the tangent from
    the corrector's factorisation: the same points as a factorisation per iteration (to far
    below the Newton tolerance), the same iterations, and at most 3 factorisations per
    arclength step where Newton needs 4-5 (issue 14)."""
    from shells.algorithms import newton as solvers

    real = solvers.setup_factor
    counts = []

    def counted(ksp, A, options):
        counts[-1] += 1
        return real(ksp, A, options)

    monkeypatch.setattr(solvers, "setup_factor", counted)
    runs = {}
    for reuse in (0.0, 1e-5):
        counts.append(0)
        st = ContinuationSettings(ds=0.05, ds_max=0.05, max_steps=30, factor_reuse=reuse)
        runs[reuse] = [(p.kappa, p.scalars["w0"], p.newton_its, p.dkappa_ds)
                       for p in continuation(FoldProblem(), st, kappa_end=3.0)]
    (before, n_before), (after, n_after) = zip(runs.values(), counts, strict=True)
    assert len(after) == len(before) == 31
    for a, b in zip(after, before, strict=True):
        # both on the branch x² + κ - 1 = 0 to the Newton tolerance
        assert abs(a[1] ** 2 + a[0] - 1.0) < 1e-10 and abs(b[1] ** 2 + b[0] - 1.0) < 1e-10
        # the same points: a tangent from a Jacobian at most factor_reuse away moves the
        # predictor, and with it the next point along the branch, by ~1e-8 of a step
        assert a[0] == pytest.approx(b[0], abs=1e-7)
        assert a[2] == b[2]
        assert a[3] == pytest.approx(b[3], rel=1e-5)
    steps = len(after) - 1
    assert n_before >= 4 * steps
    assert n_after <= 3 * steps + 2  # (+ the start's Newton solve and tangent)


def test_the_quadratic_predictor_lands_on_the_same_points_in_fewer_iterations():
    """``predictor="quadratic"``: Newton starts from the quadratic through the last two points
    with the last tangent, on the same hyperplane as the tangent predictor's: on the fold
    problem x² + κ - 1 = 0 at a fixed step, the same points to the Newton tolerance (on the
    branch, and where the tangent predictor's run put them), never more iterations a step, and
    one fewer (2 against 3) on every step of the branch's flatter part x > 0.8 after the first
    (which has no point before it); nearer the fold, where the branch bends faster along its
    arclength, the O(s³) start still needs 3 at this step."""
    runs = {}
    for predictor in ("tangent", "quadratic"):
        st = ContinuationSettings(ds=0.05, ds_max=0.05, max_steps=30, predictor=predictor)
        runs[predictor] = [(p.kappa, p.scalars["w0"], p.newton_its)
                           for p in continuation(FoldProblem(), st, kappa_end=3.0)]
    tangent, quadratic = runs["tangent"], runs["quadratic"]
    assert len(quadratic) == len(tangent) == 31
    assert quadratic[-1][1] < 0  # past the fold
    for a, b in zip(quadratic, tangent, strict=True):
        assert abs(a[1] ** 2 + a[0] - 1.0) < 1e-10
        assert a[0] == pytest.approx(b[0], abs=1e-9) and a[1] == pytest.approx(b[1], abs=1e-9)
    assert quadratic[1][2] == tangent[1][2]
    assert all(a[2] <= b[2] for a, b in zip(quadratic, tangent, strict=True))
    flat = [(a[2], b[2]) for a, b in zip(quadratic[2:], tangent[2:], strict=True) if a[1] > 0.8]
    assert len(flat) >= 6 and all(a < b for a, b in flat), flat
    with pytest.raises(InputError):
        ContinuationSettings(predictor="cubic")
