"""Energy minimisation with TAO (``shells.algorithms.minimise``) on problems with exact answers:
a pitchfork past its bifurcation (the fundamental state a saddle, the bifurcated pair the
minima), on every rank count (the few unknowns distributed over the ranks), and the energy's
consistency with the residual on the surface model (TAO's line search relies on it)."""

import math

import numpy as np
import pytest
from mpi4py import MPI

from shells.algorithms.minimise import minimise, minimise_to_stable, perturb_unstable, perturbed
from shells.algorithms.orbit import newton_modulo_orbit
from shells.algorithms.settings import MinimiseSettings
from shells.algorithms.stability import Stability
from shells.errors import InputError
from shells.problem.algebraic import PitchforkProblem, RingValleyProblem


def _saddle(lam: float) -> PitchforkProblem:
    """The pitchfork (one further mode z at c = 3) on its fundamental state x = z = 0, y = λ:
    past λ = 1 a saddle whose one unstable direction is x."""
    p = PitchforkProblem(c=(3.0,), comm=MPI.COMM_WORLD)
    p.set_kappa(lam)
    w = np.array([lam, 0.0, 0.0])
    p.state.array_w[:] = w[p.lo:p.hi]
    return p


@pytest.mark.parametrize("method", ["nls", "ntr"])
@pytest.mark.parametrize("lam", [1.3, 1.8])
def test_lands_on_the_bifurcated_minimum(method, lam):
    """From the saddle perturbed along x: x² = 2(λ - 1), y = 2λ - 1, E = -(λ - 1)²/2, stable."""
    p = _saddle(lam)
    left = perturb_unstable(p, 1e-3)
    assert len(left) == 1 and left[0]["eigenvalue"] == pytest.approx(1 - lam, rel=1e-10)
    res = minimise(p, MinimiseSettings(method=method, gatol=1e-12))
    w = p.gathered()
    assert res.converged and res.gradient_norm <= 1e-12
    assert abs(w[1]) == pytest.approx(math.sqrt(2 * (lam - 1)), rel=1e-10)
    assert w[0] == pytest.approx(2 * lam - 1, rel=1e-10)
    assert w[2] == pytest.approx(0.0, abs=1e-10)
    assert res.energy == pytest.approx(-(lam - 1) ** 2 / 2, rel=1e-10)
    assert res.energy < res.energy_start
    stab = Stability(p)
    assert stab.inertia()[0] == 0
    stab.destroy()


def test_a_perturbation_with_stable_parts_still_lands_on_the_minimum():
    """Perturbed along x and along the stable z: a plain Newton step with a line search goes
    back to the saddle here (the stable z dominates gᵀd); the shifted factorisation's step
    is a descent direction that follows the negative curvature."""
    p = _saddle(1.3)
    d = np.array([0.0, 1.0, 0.5])
    perturbed(p, [d[p.lo:p.hi]], 1e-3)
    res = minimise(p, MinimiseSettings(gatol=1e-12))
    assert res.converged and abs(p.gathered()[1]) == pytest.approx(math.sqrt(0.6), rel=1e-10)


def test_a_saddle_reached_is_left_until_the_end_is_stable():
    """From the exact saddle ``minimise`` stops at once; ``minimise_to_stable`` finds the
    saddle by its inertia, leaves it along x and lands on the minimum."""
    p = _saddle(1.3)
    res = minimise_to_stable(p, MinimiseSettings(gatol=1e-12), amplitude=1e-3)
    assert res.rounds == 2 and res.negative_count == 0 and res.orbit_modes == 0
    assert abs(p.gathered()[1]) == pytest.approx(math.sqrt(0.6), rel=1e-10)
    assert res.energy == pytest.approx(-0.045, rel=1e-10)
    assert res.energy_start == pytest.approx(0.0, abs=1e-15)


def test_a_saddle_returned_to_is_left_twice_as_far():
    """A step off the saddle too small for the minimiser to move (its gradient under
    ``gatol``: the minimiser ends where it started) is doubled each round: from the exact
    saddle with a first step of 1e-13, the steps add up to 3.1e-12 before round 6, which
    lands on the minimum (steps of 1e-13 would add up to 5e-13, still on the saddle)."""
    p = _saddle(1.3)
    res = minimise_to_stable(p, MinimiseSettings(gatol=1e-12), amplitude=1e-13, rounds=6)
    assert res.rounds == 6 and res.negative_count == 0 and res.converged
    assert res.energy == pytest.approx(-0.045, rel=1e-10)


def test_the_last_round_ends_where_its_result_says():
    """Out of rounds at a saddle (``rounds`` = 1 from the exact saddle), the problem holds the
    saddle the result describes, not the saddle left along its unstable direction."""
    p = _saddle(1.3)
    res = minimise_to_stable(p, MinimiseSettings(gatol=1e-12), amplitude=1e-3, rounds=1)
    assert res.rounds == 1 and res.negative_count == 1 and res.converged
    np.testing.assert_allclose(p.gathered(), [1.3, 0.0, 0.0], atol=1e-15)
    assert res.energy == pytest.approx(0.0, abs=1e-15)


def test_an_unperturbed_saddle_stays_a_saddle():
    """The contract's reason for ``perturbed``: from the exact saddle the gradient is zero and
    the minimiser stops there; the inertia says it is unstable."""
    p = _saddle(1.5)
    res = minimise(p, MinimiseSettings(gatol=1e-12))
    assert res.converged and res.iterations == 0
    assert res.energy == pytest.approx(0.0, abs=1e-15)
    stab = Stability(p)
    assert stab.inertia()[0] == 1
    stab.destroy()


def _ring(w: RingValleyProblem) -> tuple[float, float, float]:
    """(r², φ, z) of the ring valley's state."""
    x, y, z = w.gathered()
    return x * x + y * y, math.atan2(y, x), z


@pytest.mark.parametrize("eps", [1.0e-6, 0.0])
def test_a_pinned_orbit_is_converged_modulo_the_orbit(eps):
    """The ring valley: the minimiser hands over to Newton modulo the orbit, which ends where
    the gradient lies along the orbit: r² = 1 / (1 + 4ε cos 4φ), z = r², and the gradient
    left is the pinning force 4ε r³ |sin 4φ|, both exact at the angle reached. Stable modulo
    the orbit (a negative eigenvalue there is the pinning's, counted as an orbit mode)."""
    p = RingValleyProblem(eps=eps, comm=MPI.COMM_WORLD)
    res = minimise_to_stable(p)
    r2, phi, z = _ring(p)
    assert res.converged and res.reason == "CONVERGED_MODULO_ORBIT" and res.rounds == 1
    assert res.iterations < 100
    assert r2 == pytest.approx(1 / (1 + 4 * eps * math.cos(4 * phi)), rel=1e-12)
    assert z == pytest.approx(r2, rel=1e-12)
    force = 4 * eps * r2**1.5 * abs(math.sin(4 * phi))
    assert res.orbit_gradient == pytest.approx(force, rel=1e-9, abs=1e-15)
    assert res.negative_count == res.orbit_modes


def test_without_the_hand_over_the_minimiser_creeps_along_the_orbit():
    """The reason for Newton modulo the orbit: TAO alone walks the weakly pinned orbit to the
    pinning's minimum (φ = π/4) in over ten times the iterations."""
    p = RingValleyProblem(eps=1.0e-6, comm=MPI.COMM_WORLD)
    res = minimise(p, MinimiseSettings(newton_below=0.0))
    assert res.converged and res.reason == "CONVERGED_GATOL"
    assert _ring(p)[1] == pytest.approx(math.pi / 4, abs=1e-6)
    q = RingValleyProblem(eps=1.0e-6, comm=MPI.COMM_WORLD)
    assert minimise(q).iterations * 10 < res.iterations


def test_newton_modulo_the_orbit_holds_the_orientation():
    """From near the circle (its stiff unknown off by 0.02): converged within a dozen
    line-searched steps with the angle held (each step is orthogonal to the orbit's tangent,
    so φ moves at second order only); from far, a failed solve leaves the state as it was."""
    p = RingValleyProblem(eps=1.0e-6, initial=(1.02, 0.3, 1.15), comm=MPI.COMM_WORLD)
    phi0 = _ring(p)[1]
    res = newton_modulo_orbit(p, atol=1e-10)
    r2, phi, _ = _ring(p)
    assert res.converged and res.iterations <= 12 and res.gradient_off_orbit <= 1e-10
    assert abs(phi - phi0) < 5e-3
    assert r2 == pytest.approx(1 / (1 + 4e-6 * math.cos(4 * phi)), rel=1e-12)
    far = RingValleyProblem(eps=1.0e-6, initial=(40.0, 3.0, -50.0), comm=MPI.COMM_WORLD)
    res = newton_modulo_orbit(far, atol=1e-10, max_it=2)
    assert not res.converged and res.iterations == 2
    assert np.array_equal(far.gathered(), [40.0, 3.0, -50.0])


def test_settings_are_checked():
    for bad in ({"method": "lbfgs"}, {"gatol": 0.0}, {"max_it": 0}, {"grtol": -1.0}):
        with pytest.raises(InputError):
            MinimiseSettings(**bad)


def test_surface_energy_is_consistent_with_its_residual():
    """dE/dε along a direction v at a strained state = R·v (central differences, O(ε²)),
    so TAO minimises the energy whose stationary points Newton and continuation compute."""
    from shells.geometry.shapes import SphericalCap
    from shells.surface.mesh import MeshSpec, generate
    from shells.surface.model import ModelParameters, ShellModel

    shape = SphericalCap(1.0, 0.6)
    sm = generate(MeshSpec(shape, h=0.04, size=0.35, layer_elements=2.0), MPI.COMM_WORLD)
    model = ShellModel(sm, ModelParameters(h=0.04, nu=0.5, degree=2, quadrature_degree=4))
    model.set_kappa(2.0)
    rng = np.random.default_rng(7 + MPI.COMM_WORLD.rank)
    n = model.state.getLocalSize()
    model.state.array_w[:] = 0.01 * rng.standard_normal(n)
    model.zero_constrained(model.state)
    model.sync()
    v = model.create_vector()
    v.array_w[:] = 0.01 * rng.standard_normal(n)
    model.zero_constrained(v)
    R = model.create_vector()
    model.assemble_residual(R)
    slope = R.dot(v)
    w0 = model.state.array_r.copy()
    energies = []
    for eps in (1e-4, -1e-4):
        model.state.array_w[:] = w0 + eps * v.array_r
        model.sync()
        energies.append(model.total_energy())
    fd = (energies[0] - energies[1]) / 2e-4
    assert fd == pytest.approx(slope, rel=1e-6)


def _small_cap():
    from shells.geometry.shapes import SphericalCap
    from shells.surface.mesh import MeshSpec, generate
    from shells.surface.model import ModelParameters, ShellModel

    sm = generate(MeshSpec(SphericalCap(1.0, 0.6), h=0.04, size=0.35, layer_elements=2.0),
                  MPI.COMM_WORLD)
    return ShellModel(sm, ModelParameters(h=0.04, nu=0.5, degree=2, quadrature_degree=4))


def test_surface_orbit_tangent_is_the_turn_about_the_axis():
    """The surface model's orbit tangent of u = (x² - y²) e_z (an m = 2 pattern) is
    -∂u/∂φ = 4xy e_z at every node, zero on the gauge's DOFs, to the error of the P2
    interpolant's gradient on the curved cells (measured 0.6 % of its largest value at size
    0.35); the axisymmetric u = (x² + y²) e_z + 0.1 (x, y, 0) has none (its tangent
    vanishes to that error, far below ``ORBIT_MIN``)."""
    model = _small_cap()
    xyz = model.owned_dof_coordinates()
    x, y = xyz[:, 0], xyz[:, 1]

    def tangent_of(values: np.ndarray) -> list:
        model.state.array_w[:] = values.ravel()
        model.sync()
        return model.orbit_tangents()

    w = np.zeros((xyz.shape[0], 6))
    w[:, 2] = x * x - y * y
    (t,) = tangent_of(w)
    expected = np.zeros_like(w)
    expected[:, 2] = 4 * x * y
    e = model.create_vector()
    e.array_w[:] = expected.ravel()
    model.zero_constrained(e)
    err = MPI.COMM_WORLD.allreduce(float(np.abs(t.array_r - e.array_r).max(initial=0.0)),
                                   op=MPI.MAX)
    peak = MPI.COMM_WORLD.allreduce(float(np.abs(e.array_r).max(initial=0.0)), op=MPI.MAX)
    assert peak > 0.3 and err < 0.02 * peak
    w[:, 2] = x * x + y * y
    w[:, 0], w[:, 1] = 0.1 * x, 0.1 * y
    assert tangent_of(w) == []


def test_surface_buckled_cap_converges_modulo_the_orbit():
    """A 30° cap (h/R = 0.04) at κR = -0.9, past its m = 2 bifurcation (κR = -0.662): from the
    symmetric state, perturbed along its two unstable m = 2 eigenvectors, the minimiser lands
    on the buckled m = 2 state, below the symmetric one, stable, and converged modulo its
    orbit (the pattern's turn about the axis, which the coarse mesh pins by a force far below
    the gradient it started from)."""
    from shells.algorithms.continuation import continuation
    from shells.algorithms.settings import ContinuationSettings
    from shells.geometry.shapes import SphericalCap
    from shells.surface.mesh import MeshSpec, generate
    from shells.surface.model import ModelParameters, ShellModel

    sm = generate(MeshSpec(SphericalCap(1.0, math.radians(30)), h=0.04, size=0.3,
                           layer_elements=2.0), MPI.COMM_WORLD)
    model = ShellModel(sm, ModelParameters(h=0.04, nu=0.5, degree=2, quadrature_degree=4))
    st = ContinuationSettings(method="natural", ds=0.1, ds_max=0.1, ds_min=1e-4)
    for _ in continuation(model, st, kappa_start=0.0, kappa_end=-0.9, scalars=False):
        pass
    symmetric, e_sym = model.state.copy(), model.total_energy()
    left = perturb_unstable(model, 0.1)
    assert [d["mode_m"] for d in left] == [2, 2]
    res = minimise_to_stable(model)
    # one round, or two where the first end's orientation mode, nearly degenerate with its
    # neighbour, comes out of the eigensolver mixed with it (its overlap with the orbit under
    # the threshold) and is left once more: seen once in the 2-rank pass of the whole suite
    assert res.converged and res.reason == "CONVERGED_MODULO_ORBIT" and res.rounds <= 2
    assert res.negative_count == res.orbit_modes and res.iterations < 150
    assert res.energy < e_sym - 1e-5  # 2.6e-5 below (measured), of 6.7e-4
    # all the gradient left lies along the orbit: the mesh's pinning force (9.4e-8 measured)
    assert res.orbit_gradient < 1e-6
    assert res.gradient_norm == pytest.approx(res.orbit_gradient, rel=1e-3)
    d = model.state.copy()
    d.axpy(-1.0, symmetric)
    assert model.classify_mode(d, None).m == 2
