"""Axisymmetric model (shells.axisym): closed-sphere buckling against the paper's asymptotics,
the exact shrunk sphere, cap snap-through and buckling, axis conditions, bad input.

The 1D problem runs on MPI.COMM_SELF on every rank; each test checks that all ranks got
identical numbers, then asserts on them.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from mpi4py import MPI
from scipy.optimize import brentq

from shells.algorithms.newton import NewtonSolver
from shells.algorithms.settings import ContinuationSettings
from shells.algorithms.stability import Stability
from shells.analyses.axisym_runs import branch, critical, default_settings
from shells.axisym import SNES_OPTIONS, AxisymModel, AxisymParameters
from shells.errors import InputError
from shells.geometry.shapes import Disk, EllipsoidalCap, Sphere, SphericalCap
from shells.theory import sphere_kappa_b_h, sphere_mode_n


def same_on_all_ranks(*values: float) -> None:
    """The computation is replicated per rank: the results must agree bit for bit."""
    arr = np.array([np.nan if v is None else v for v in values], dtype=float)
    lo, hi = np.empty_like(arr), np.empty_like(arr)
    MPI.COMM_WORLD.Allreduce(arr, lo, op=MPI.MIN)
    MPI.COMM_WORLD.Allreduce(arr, hi, op=MPI.MAX)
    assert np.array_equal(lo, hi, equal_nan=True)


@pytest.fixture(scope="module")
def sphere_results() -> dict[tuple[float, float], dict]:
    """Closed-sphere critical points (each a few seconds), shared by the tests below. The 1D
    model is serial: on several ranks each computes its share and all gather the results, as
    the phase diagram distributes its branches."""
    comm = MPI.COMM_WORLD
    cases = ((0.05, 0.5), (0.01, 0.5), (0.002, 0.5), (0.002, 0.3))
    mine = {case: critical(Sphere(1.0), *case, "up")
            for i, case in enumerate(cases) if i % comm.size == comm.rank}
    out = {}
    for part in comm.allgather(mine):
        out.update(part)
    assert set(out) == set(cases)
    return out


@pytest.mark.parametrize("nu", [0.5, 0.3])
def test_sphere_buckling_matches_the_paper(sphere_results, nu):
    """κ_b h within 0.5 % of 4 sqrt(3(1-ν)/((1+ν)(5+4ν))) at h/R = 0.002, a bifurcation whose
    degree is within 1 of the asymptotic n(n+1) = 2/(1+2ν) (R/h) sqrt(3(5+4ν)(1-ν²))."""
    r = sphere_results[0.002, nu]
    expected = sphere_kappa_b_h(nu)
    assert expected == pytest.approx(4 / math.sqrt(7) if nu == 0.5 else 2.042, rel=2e-4)
    assert r["kind"] == "bifurcation" and r["model"] == "axisym"
    assert r["kappa_h"] == pytest.approx(expected, rel=5e-3)
    assert abs(r["mode_n"] - sphere_mode_n(0.002, nu)) <= 1.0
    assert r["kappa_R"] == pytest.approx(r["kappa_h"] / 0.002, rel=1e-12)
    assert r["theta_deg"] is None and r["h_over_R"] == 0.002 and r["nu"] == nu


def test_closed_spheroid_tends_to_the_sphere(sphere_results):
    """A closed spheroid (the 1D locator used to fail on it): as r3 -> R its first critical
    point is the sphere's (same κh to 1e-4 at h/R = 0.05); a prolate one (r3 = 1.5 R) loses
    stability first to a non-axisymmetric mode, as a closed shell's bifurcation."""
    near = critical(EllipsoidalCap(1.0, 1.0001, math.pi), 0.05, 0.5, "up", max_critical=1)
    same_on_all_ranks(near["kappa_h"])
    assert near["kind"] == "bifurcation"
    assert near["kappa_h"] == pytest.approx(sphere_results[0.05, 0.5]["kappa_h"], rel=1e-4)
    prolate = critical(EllipsoidalCap(1.0, 1.5, math.pi), 0.05, 0.5, "up", max_critical=1)
    assert prolate["kind"] == "bifurcation" and prolate["mode_m"] >= 1
    assert len(prolate["critical_points"]) == 1


def test_sphere_buckling_approaches_the_limit_as_h_over_r(sphere_results):
    """The relative error of κ_b h is O(h/R): it shrinks with h/R, by a factor near 5 from
    h/R = 0.01 to 0.002, and error / (h/R) stays of order one."""
    err = {hr: sphere_results[hr, 0.5]["kappa_h"] / sphere_kappa_b_h(0.5) - 1
           for hr in (0.05, 0.01, 0.002)}
    assert abs(err[0.05]) > abs(err[0.01]) > abs(err[0.002])
    assert 2.5 < err[0.01] / err[0.002] < 10
    for hr, e in err.items():
        assert 0.05 < abs(e) / hr < 2.0


def test_sphere_prebuckling_is_the_exact_shrunk_sphere():
    """Ψ3/h along the branch equals (λ-1) R/h, λ(λ²-1) = (h²/6R)((1-λ)/R - κ), to 1e-3 (it
    is the exact nonlinear solution), and the energy is that of the shrunk sphere."""
    h_over_r, nu = 0.01, 0.5
    recs = list(branch(Sphere(1.0), h_over_r, nu, "up", m_max=0, kappa_max=120.0))
    assert len(recs) >= 3 and recs[-1]["kappa_R"] == pytest.approx(120.0)
    for rec in recs[1:]:
        k, h = rec["kappa_R"], h_over_r
        lam = brentq(lambda x, k=k, h=h: x * (x * x - 1) - h * h / 6 * ((1 - x) - k), 0.5, 1.5)
        assert rec["psi3_over_h"] == pytest.approx((lam - 1) / h, rel=1e-3)
        # the energy of the paper's Eq. (1) with the κ² constant, as in shells.surface.model
        e = 4 * math.pi * 2 * (1 + nu) * ((lam**2 - 1) ** 2 + h * h / 3 * ((1 - lam) - k) ** 2)
        assert rec["energy"] == pytest.approx(e, rel=1e-6)
        assert rec["negative_counts"] == [0]
    same_on_all_ranks(*[r["psi3_over_h"] for r in recs])


def test_cap_snaps_at_a_fold_without_breaking_symmetry():
    """θ = 30°, h/R = 0.04, κ > 0: the axisymmetric branch folds (snap-through) at κR ≈ 1.39
    (surface model: 1.39, coarse), with no non-axisymmetric mode (m ≤ 12) unstable before."""
    r = critical(SphericalCap(1.0, math.radians(30)), 0.04, 0.5, "up")
    same_on_all_ranks(r["kappa_R"])
    assert r["kind"] == "fold" and r["mode_m"] == 0 and r["mode_n"] is None
    assert r["kappa_R"] == pytest.approx(1.39, rel=0.02)
    assert [p["kind"] for p in r["critical_points"]] == ["fold"]
    assert r["theta_deg"] == pytest.approx(30.0)


def test_cap_buckles_into_m2_for_negative_curvature():
    """θ = 30°, h/R = 0.04, κ < 0: the first instability is a bifurcation into m = 2."""
    r = critical(SphericalCap(1.0, math.radians(30)), 0.04, 0.5, "down", kappa_max=1.0)
    same_on_all_ranks(r["kappa_R"])
    assert r["kind"] == "bifurcation" and r["mode_m"] == 2
    assert -1.0 < r["kappa_R"] < -0.3
    assert len(r["critical_points"]) == 1


#: the free disk's m = 2 bifurcation at h/r = 0.02, ν = ½ (critical(..., kappa_max=0.5)); the
#: plate limit is κ r²/h = √(10 + 7√2) = 4.46, i.e. κr = 0.0892 (test_critical.py: within 3.5 %)
DISK_M2_KAPPA_R = 0.092077


def test_disk_bifurcation_found_with_the_range_ending_just_beyond_it():
    """Regression: with κ_end just past the disk's m = 2 bifurcation (κr = 0.107, 16 % beyond),
    the bifurcation is found. The continuation's residual bound used to be 1e-5 of the κ-load
    *at κ_end*, below the residual's round-off floor (≈ 3e-5 of the load on a thin disk, whose
    load is O(h²) while the floor comes from the penalty-stiff Jacobian) unless κ_end was a few
    times the current κ: the corrector failed, the step fell below ds_min, the continuation
    ended at κr ≈ 0.04 and ``critical`` reported "none"."""
    r = critical(Disk(1.0), 0.02, 0.5, "up", kappa_max=0.107)
    same_on_all_ranks(r["kappa_R"])
    assert r["kind"] == "bifurcation" and r["mode_m"] == 2
    assert r["kappa_R"] == pytest.approx(DISK_M2_KAPPA_R, rel=3e-4)
    assert len(r["critical_points"]) == 1
    # the branch reaches the end of the range
    recs = list(branch(Disk(1.0), 0.02, 0.5, "up", m_max=2, kappa_max=0.107))
    assert recs[-1]["kappa_R"] == pytest.approx(0.107, rel=1e-12)
    assert recs[-1]["unstable_modes"] == [2]


def test_critical_refuses_to_report_none_for_a_branch_stopped_short():
    """A continuation that gives up before the end of the range (here forced by an absolute
    residual bound below the round-off floor) is an error, not "no critical point"."""
    too_strict = default_settings(Disk(1.0), 0.02, residual_tol=2e-9)
    with pytest.raises(RuntimeError, match="stopped at kappa R"):
        critical(Disk(1.0), 0.02, 0.5, "up", m_max=2, kappa_max=0.107, settings=too_strict)


@pytest.mark.parametrize("kwargs, match", [
    (dict(residual_tol=0.0), "residual_tol"),
    (dict(residual_tol=float("nan")), "residual_tol"),
    (dict(residual_rtol=0.0), "residual_rtol"),
    (dict(residual_rtol=2.0), "residual_rtol"),
    (dict(residual_roundoff=-1.0), "residual_roundoff"),
])
def test_residual_settings_are_validated(kwargs, match):
    with pytest.raises(InputError, match=match):
        ContinuationSettings(**kwargs)
    assert ContinuationSettings().residual_tol is None  # relative bound by default


def test_mesh_convergence_of_the_fold():
    """The fold of the cap moves by less than 0.1 % from 100 to 200 cells (P3 + P2 slopes)."""
    cap = SphericalCap(1.0, math.radians(30))
    k = [critical(cap, 0.04, 0.5, "up", m_max=0, cells=c)["kappa_R"] for c in (100, 200)]
    assert k[0] == pytest.approx(k[1], rel=1e-3)


@pytest.mark.parametrize("shape", [Sphere(1.0), SphericalCap(1.0, math.radians(60)), Disk(1.0)])
def test_unloaded_hessians_are_positive_definite(shape):
    """At κ = 0 every H_m is positive definite: the axis conditions and rigid-motion gauges
    leave no zero or negative pivot, and no spurious soft mode (the lowest eigenvalue of m = 1,
    the tilt/translation family, sits at the physical scale)."""
    model = AxisymModel(shape, AxisymParameters(h=0.02, cells=60))
    stab = Stability(model)
    for m in range(6):
        neg, zero, _ = stab.inertia(m)
        assert (neg, zero) == (0, 0), m
    vals, _ = stab.eigenpairs(2, block=1)  # all positive: the nearest 0 are the lowest
    low = vals[0]
    assert low > 1e-4
    same_on_all_ranks(low)
    stab.destroy()


def test_newton_converges_from_rest_on_a_sphere():
    model = AxisymModel(Sphere(1.0), AxisymParameters(h=0.01, cells=60))
    ns = NewtonSolver(model, options=SNES_OPTIONS)
    model.kappa.value = 50.0
    ok, its = ns.solve()
    assert ok and its <= 6
    ns.destroy()


@pytest.mark.parametrize("kwargs, match", [
    (dict(h_over_r=0.0), "h/R"),
    (dict(h_over_r=1.5), "h/R"),
    (dict(nu=0.7), "nu"),
    (dict(direction="sideways"), "direction"),
    (dict(m_max=-1), "m_max"),
    (dict(kappa_max=-2.0), "kappa_max"),
    (dict(cells=2), "cells"),
    (dict(bogus=1), "unknown numerics"),
])
def test_bad_input_is_an_input_error(kwargs, match):
    args = dict(shape=Sphere(1.0), h_over_r=0.01, nu=0.5)
    args.update(kwargs)
    with pytest.raises(InputError, match=match):
        critical(**args)


def test_bad_shape_is_an_input_error():
    with pytest.raises(InputError, match="shape"):
        critical("sphere", 0.01)
    with pytest.raises(InputError, match="positive"):
        AxisymParameters(h=-1.0)
