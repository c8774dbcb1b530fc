"""Dynamics (``shells.algorithms.dynamics``): with no damping and ρ∞ = 1 (TSALPHA2 is then the
trapezoidal rule) a free vibration conserves elastic + kinetic energy, and its period is that
of the natural frequency (``shells.algorithms.frequencies``) up to the trapezoidal rule's
exact period elongation T_h = T (ω Δt/2) / arctan(ω Δt/2).

Every problem runs on MPI.COMM_SELF on every rank (results reduced before asserting): a
parallel factorisation per step of a few unknowns costs seconds on shared cores."""

from __future__ import annotations

import math

import numpy as np
import pytest
from mpi4py import MPI

from shells.algorithms.dynamics import integrate
from shells.algorithms.frequencies import KineticStability
from shells.algorithms.settings import DynamicsSettings
from shells.errors import InputError
from shells.problem.algebraic import FoldProblem


def world_max(x: float) -> float:
    return MPI.COMM_WORLD.allreduce(float(x), op=MPI.MAX)


def peak_times(t: np.ndarray, k: np.ndarray) -> np.ndarray:
    """The times of the local maxima of k (parabola through three samples)."""
    out = []
    for i in range(1, len(k) - 1):
        if k[i] >= k[i - 1] and k[i] > k[i + 1]:
            a, b, c = k[i - 1], k[i], k[i + 1]
            out.append(t[i] + 0.5 * (a - c) / (a - 2 * b + c) * (t[i + 1] - t[i]))
    return np.array(out)


def test_algebraic_energy_conserved():
    """The fold problem (unit mass) about its stable state, ten periods of its slowest mode
    (ω² = 0.575; on MPI.COMM_SELF: a parallel factorisation per step costs more than the
    test's point)."""
    p = FoldProblem(comm=MPI.COMM_SELF)
    p.state.array_w[:] += 1e-3 * (np.arange(p.lo, p.hi) == 0)
    r = integrate(p, DynamicsSettings(t_end=85.0, dt=0.05))
    e = np.array(r.kinetic) + np.array(r.elastic)
    assert r.reason == "time" and r.steps == 1700
    assert world_max(np.max(np.abs(e - e[0])) / max(r.kinetic)) < 1e-4


def test_an_integration_advanced_in_pieces_is_one_run():
    """``Integrator.advance`` continues the same time stepper: the fold problem's damped
    motion with adaptive steps, advanced 7 steps at a time, takes the steps of one advance to
    the end (the same times and energies to round-off); one restarted from a piece's end (a
    fresh ``integrate`` from its state, velocity and time: the start acceleration estimated
    afresh) takes other steps (``shells.analyses.snap`` checkpoints without restarting for
    that reason)."""
    from shells.algorithms.dynamics import Integrator

    s = DynamicsSettings(t_end=30.0, dt=0.1, rho_inf=0.5, mass_damping=0.3, adaptive=True,
                         step_tol=1e-4)

    def start():
        p = FoldProblem(comm=MPI.COMM_SELF)
        p.state.array_w[:] += 0.3 * (np.arange(p.lo, p.hi) == 0)
        return p

    one = integrate(start(), s)
    p = start()
    run = Integrator(p, s)
    pieces = []
    try:
        while not pieces or pieces[-1] == "steps":
            r = run.advance(7)
            pieces.append(r.reason)
            if len(pieces) == 2:
                t_mid, u_mid, v_mid = r.times[-1], p.state.copy(), r.velocity.copy()
    finally:
        run.destroy()
    assert pieces[-1] == "time" and len(pieces) > 3 and r.steps == one.steps
    np.testing.assert_allclose(r.times, one.times, rtol=1e-13, atol=1e-14)
    np.testing.assert_allclose(r.kinetic, one.kinetic, rtol=1e-10, atol=1e-16)
    q = start()
    u_mid.copy(q.state)
    q.sync()
    again = integrate(q, s, velocity=v_mid, t0=t_mid)
    assert again.times[0] == one.times[14] and again.times[-1] == pytest.approx(30.0)
    assert abs(again.times[1] - one.times[15]) > 1e-6 * one.times[15]


def test_sphere_vibration_energy_and_period():
    """The 1D model's free sphere (h/R = 0.05) started on its n = 2 mode: energy conserved to
    1e-4 of the kinetic peak over ten periods, the period that of ω² (elongation removed) to
    2e-4."""
    from shells.axisym import AxisymModel, AxisymParameters
    from shells.geometry.shapes import Sphere

    model = AxisymModel(Sphere(1.0), AxisymParameters(h=0.05, nu=0.5, cells=20),
                        comm=MPI.COMM_SELF)
    st = KineticStability(model)
    vals, vecs = st.eigenpairs(1, modes=True, block=None)
    st.destroy()
    w = math.sqrt(vals[0])
    T = 2 * math.pi / w
    dt = T / 40
    v = vecs[0]
    v.scale(5e-5 / (v.norm() / math.sqrt(v.getSize())))
    v.copy(model.state)
    model.sync()
    r = integrate(model, DynamicsSettings(t_end=10 * T, dt=dt))
    k, t = np.array(r.kinetic), np.array(r.times)
    e = k + np.array(r.elastic)
    measured = 2 * np.mean(np.diff(peak_times(t, k)))
    elongated = T * (w * dt / 2) / math.atan(w * dt / 2)
    assert world_max(np.max(np.abs(e - e[0])) / k.max()) < 1e-4
    assert world_max(abs(measured / elongated - 1)) < 2e-4


def test_rest_stops_a_damped_vibration():
    """Mass-proportional damping, ρ∞ = 0.5, adaptive steps: the run stops at rest."""
    p = FoldProblem(comm=MPI.COMM_SELF)
    p.state.array_w[:] += 1e-2 * (np.arange(p.lo, p.hi) == 0)
    r = integrate(p, DynamicsSettings(t_end=200.0, dt=0.05, rho_inf=0.5, mass_damping=1.0,
                                      adaptive=True, rest_tol=1e-12))
    assert r.reason == "rest" and r.times[-1] < 200.0 and r.kinetic[-1] < 1e-12


def damped_steps(**settings) -> np.ndarray:
    """The adaptive steps of the fold problem's damped vibration (ρ∞ = 0.5, α = 1) to rest."""
    p = FoldProblem(comm=MPI.COMM_SELF)
    p.state.array_w[:] += 1e-2 * (np.arange(p.lo, p.hi) == 0)
    r = integrate(p, DynamicsSettings(t_end=200.0, dt=0.05, rho_inf=0.5, mass_damping=1.0,
                                      adaptive=True, **settings))
    assert r.reason == "rest"
    return np.diff(r.times)


def test_adaptive_steps_keep_to_dt_min():
    """A tight tolerance shortens the adaptive steps below the first one; ``dt_min`` bounds
    them (the steps at it are accepted), and the run still comes to rest."""
    assert damped_steps(step_tol=1e-6, rest_tol=1e-8).min() < 0.02
    assert damped_steps(step_tol=1e-6, rest_tol=1e-8, dt_min=0.05).min() >= 0.05 * (1 - 1e-9)


def test_adaptive_steps_keep_to_dt_max():
    """A loose tolerance lets the adaptive steps of a damped vibration grow well past the first
    one as it dies out; ``dt_max`` bounds them, and the run still comes to rest."""
    assert damped_steps(step_tol=1e-4, rest_tol=1e-12).max() > 1.0
    assert damped_steps(step_tol=1e-4, rest_tol=1e-12, dt_max=0.5).max() <= 0.5 * (1 + 1e-9)


@pytest.mark.parametrize("alpha", [1.0, 0.1])
def test_a_damped_saddle_is_left_at_the_root_of_its_characteristic_equation(alpha):
    """The fold problem's unstable equilibrium near its fold (κ = 0.999, x = -√0.001; unit
    mass; μ = -0.0212 the Hessian's negative eigenvalue), perturbed by 1e-9 along its
    eigenvector: the departure grows as e^(s t), s² + α s + μ = 0, the rate at which a damped
    shell leaves a saddle (docs/model.md, "Damping and the saddles a snap passes"). At α = 1
    (α/(2√|μ|) = 3.4, overdamped) s is within 3 % of |μ|/α, at α = 0.1 five times that.
    Trapezoidal steps of 0.1 (s Δt ≤ 0.01); the log-linear fit over the run's last half (the
    decaying root's share below 1e-6) to a departure of 1e-5 (linear: 1/6000 of the distance
    to the stable state)."""
    p = FoldProblem(comm=MPI.COMM_SELF)
    kappa = 0.999
    p.set_kappa(kappa)
    w0 = -math.sqrt(1 - kappa) * np.ones(p.n)
    mu, vecs = np.linalg.eigh(p.hessian(w0, kappa))
    assert mu[0] == pytest.approx(-0.02118, rel=1e-3) and mu[1] > 0
    s = 0.5 * (-alpha + math.sqrt(alpha**2 - 4 * mu[0]))
    t_end = math.log(1e4) / s
    p.state.array_w[:] = (w0 + 1e-9 * vecs[:, 0])[p.lo:p.hi]
    times, dist = [], []

    def monitor(t, problem, kinetic):
        times.append(t)
        dist.append(float(np.linalg.norm(problem.gathered() - w0)))

    integrate(p, DynamicsSettings(t_end=t_end, dt=0.1, mass_damping=alpha), monitor=monitor)
    t, d = np.array(times), np.array(dist)
    late = t >= t_end / 2
    rate = np.polyfit(t[late], np.log(d[late]), 1)[0]
    assert world_max(d.max()) < 2e-5
    assert world_max(abs(rate / s - 1)) < 1e-4
    if alpha == 1.0:  # overdamped: s near |μ|/α
        assert abs(s / -mu[0] - 1) < 0.03
    else:  # five times the rate at α = 1
        assert s > 4.5 * -mu[0]


def test_settings_are_checked():
    for bad in ({"dt": 0.0}, {"rho_inf": 1.5}, {"mass_damping": -1.0}, {"rest_tol": 0.0},
                {"t_end": -1.0}, {"dt_min": 0.0}, {"dt_min": 0.5}, {"step_tol": 0.0},
                {"dt_max": 0.001}, {"dt_max": float("inf")}):
        with pytest.raises(InputError):
            DynamicsSettings(**bad)
