"""Surface shell model with natural curvature: closed-sphere laws, pressure analogy, edge works.

All on 1 and 2 ranks (scalars are reduced over the communicator before asserting).
"""

import math

import numpy as np
import pytest
from conftest import fitted_rate
from scipy.optimize import brentq

from shells.algorithms.continuation import continuation
from shells.algorithms.newton import NewtonSolver
from shells.algorithms.settings import ContinuationSettings
from shells.geometry.shapes import Sphere, SphericalCap
from shells.surface.mesh import MeshSpec, generate
from shells.surface.model import ModelParameters, ShellModel

H = 0.05  # h/R of the paper's closed-sphere checks


def exact_sphere_psi3_over_h(kh: float, h: float = H, R: float = 1.0) -> float:
    """Uniformly shrunk sphere: lambda (lambda^2 - 1) = (h^2 / 6R) ((1 - lambda)/R - kappa)."""
    kappa = kh / h
    lam = brentq(lambda x: x * (x * x - 1) - h * h / (6 * R) * ((1 - x) / R - kappa), 0.5, 1.5,
                 xtol=1e-15)
    return (lam - 1) * R / h


@pytest.fixture(scope="module")
def sphere_model():
    sm = generate(MeshSpec(Sphere(1.0), size=0.25))
    return ShellModel(sm, ModelParameters(h=H, nu=0.5))


@pytest.fixture(scope="module")
def sphere_solver(sphere_model):
    return NewtonSolver(sphere_model)


def _solve_at(model, ns, kappa, pressure=0.0):
    model.w.x.array[:] = 0.0
    model.w.x.scatter_forward()
    model.kappa.value = kappa
    model.pressure.value = pressure
    ok, its = ns.solve()
    assert ok
    return model.scalars()


@pytest.mark.parametrize("kh", [0.25, 1.0])
def test_sphere_psi3_matches_uniform_shrink(sphere_model, sphere_solver, kh):
    s = _solve_at(sphere_model, sphere_solver, kh / H)
    exact = exact_sphere_psi3_over_h(kh)
    assert s["psi3_over_h"] == pytest.approx(exact, rel=1e-3)
    # the pole-to-pole measure agrees: the state is uniform, not just on average. It is a
    # pointwise value at the mesh's most distorted triangles (the OCC pole), measured within
    # 2e-4 to 1.1e-3 on sizes 0.2 to 0.3, hence the looser pointwise bound
    assert s["apex_uz_over_h"] == pytest.approx(exact, rel=3e-3)
    # the paper's first-order law, -kappa h / 12, holds to O(kappa h^2 ...) here
    assert s["psi3_over_h"] == pytest.approx(-kh / 12, rel=0.02)


def test_the_pole_functional_is_the_pole_depth(sphere_model):
    """``pole_functional()`` e: e·w = ``psi3_pole_over_h`` for any state (here random, on
    every rank's owned values), the functional the dimple branch is followed with."""
    m = sphere_model
    n = m.state.getLocalSize()
    rng = np.random.default_rng(1 + m.shell.comm.rank)
    m.w.x.array[:n] = rng.standard_normal(n) * H
    m.w.x.scatter_forward()
    e = m.pole_functional()
    value = e.dot(m.state)
    e.destroy()
    assert value == pytest.approx(m.scalars()["psi3_pole_over_h"], rel=1e-10, abs=1e-12)
    m.w.x.array[:] = 0.0
    m.w.x.scatter_forward()


#: the Gaussian dimple about the pole of the unit sphere the orbit tests use: g = -0.05 e^(-r²/σ²)
SIGMA = 0.5


def _pole_dimple(x):
    return -0.05 * np.exp(-(x[0] ** 2 + x[1] ** 2 + (x[2] - 1.0) ** 2) / SIGMA ** 2)


def _normal_field(amplitude):
    """The surface model's (u, θ) = (amplitude(x) n°, 0) on the unit sphere, to interpolate."""
    return lambda x: np.vstack([amplitude(x) * x / np.linalg.norm(x, axis=0),
                                np.zeros((3, x.shape[1]))])


def test_a_dimple_sliding_over_the_sphere_is_its_orbit(sphere_model):
    """On a closed sphere a rotation about any axis through the centre is a symmetry: a dimple
    at the pole (here w = g n°, g a Gaussian of width 0.5 R about the pole) slides over the
    sphere along (a × x)·∇g n°, a = e_x: 2 y g / σ², e_y: -2 x g / σ². A mode along any
    combination of the two, with a rigid translation added (the gauge's), lies along the orbit
    (``orbit_overlap`` ≈ 1, to the interpolation's error); a translation alone, a pattern of
    other symmetry, or any mode of a uniform state (no orbit) does not (0)."""
    from dolfinx import fem

    m = sphere_model
    g = _pole_dimple
    v = fem.Function(m.W)
    shift = np.array([[0.0], [0.3], [0.1]])

    def overlap(amplitude, translation=None):
        """The orbit overlap of the mode amplitude(x) n° (+ a rigid translation)."""
        field = _normal_field(amplitude)
        v.interpolate(field if translation is None else
                      (lambda x: field(x) + np.vstack([translation, np.zeros((3, 1))])))
        v.x.scatter_forward()
        return m.classify_mode(v.x.petsc_vec).rayleigh["orbit"]

    m.w.interpolate(_normal_field(g))
    m.w.x.scatter_forward()
    try:
        assert overlap(lambda x: 2 * x[1] * g(x) / SIGMA ** 2, shift) > 0.999
        assert overlap(lambda x: (1.2 * x[1] - 1.6 * x[0]) * g(x) / SIGMA ** 2) > 0.999
        assert overlap(lambda x: 0.0 * x[0], shift) == 0.0
        assert overlap(lambda x: (x[0] ** 2 - x[1] ** 2) * g(x)) < 1e-8
        m.w.x.array[:] = 0.0
        m.w.x.scatter_forward()
        assert overlap(lambda x: 2 * x[1] * g(x) / SIGMA ** 2) == 0.0
    finally:
        m.w.x.array[:] = 0.0
        m.w.x.scatter_forward()


def test_the_pole_moments_hold_the_dimple_at_the_pole(sphere_model):
    """``pole_moments()`` e_x, e_y: e_a·w = ∫ (u·n°) x_a dA / (A h) for any state (here a
    random one, reduced over the ranks); an axisymmetric dimple at the pole has none, its
    sliding (the orbit tangent about the y axis, -2 x g / σ² n°) has one along x only: they
    fix the dimple's position without constraining its shape."""
    import ufl
    from dolfinx import fem
    from mpi4py import MPI

    m = sphere_model
    comm = m.shell.comm
    es = m.pole_moments()
    try:
        n = m.state.getLocalSize()
        rng = np.random.default_rng(3 + comm.rank)
        m.w.x.array[:n] = rng.standard_normal(n) * H
        m.w.x.scatter_forward()
        m.zero_constrained(m.state)
        m.w.x.scatter_forward()
        u, _ = m.split(m.w)
        area = comm.allreduce(fem.assemble_scalar(fem.form(1.0 * m.dx)), op=MPI.SUM)
        for a, e in enumerate(es):
            direct = comm.allreduce(fem.assemble_scalar(fem.form(
                ufl.dot(u, m.n0) * ufl.SpatialCoordinate(m.shell.mesh)[a] * m.dx)), op=MPI.SUM)
            assert e.dot(m.state) == pytest.approx(direct / (area * H), rel=1e-10, abs=1e-14)
        def load(amplitude):
            m.w.interpolate(_normal_field(amplitude))
            m.w.x.scatter_forward()
            return [e.dot(m.state) for e in es]

        dimple = load(_pole_dimple)
        slide = load(lambda x: -2 * x[0] * _pole_dimple(x) / SIGMA ** 2)
        # (to the mesh's own asymmetry: measured 1e-16 for the dimple, 7e-5 for the slide's
        # cross moment)
        assert max(abs(v) for v in dimple) < 1e-4 * abs(slide[0])
        assert abs(slide[1]) < 1e-3 * abs(slide[0]) and abs(slide[0]) > 1e-3
    finally:
        for e in es:
            e.destroy()
        m.w.x.array[:] = 0.0
        m.w.x.scatter_forward()


def test_sphere_linear_law_small_kappa(sphere_model, sphere_solver):
    """Psi3/h -> -(kappa h/12) / (1 + (h/R)^2/12) as kappa -> 0 (the supplement's Eq. S-Psi3)."""
    slopes = []
    for kh in (1e-3, 1e-2):
        s = _solve_at(sphere_model, sphere_solver, kh / H)
        slopes.append(s["psi3_over_h"] / kh)
    linear = -(1 / 12) / (1 + H**2 / 12)
    assert slopes[0] == pytest.approx(linear, rel=2e-4)
    # the nonlinear correction is first order in kappa h: ten times larger at kappa h = 1e-2
    assert abs(slopes[1] / linear - 1) > abs(slopes[0] / linear - 1)


def test_pressure_analogy_eq5(sphere_model, sphere_solver):
    """Dead pressure p with kappa h = 6 (1 - nu) (R/h)^2 p / E: the same Psi3 to first order."""
    nu = 0.5
    for kh in (1e-3, 1e-2):
        p_over_e = kh / (6 * (1 - nu)) * H**2
        s_p = _solve_at(sphere_model, sphere_solver, 0.0, pressure=p_over_e)
        s_k = _solve_at(sphere_model, sphere_solver, kh / H)
        # identical linear response; the difference is the (different) nonlinear correction
        assert s_p["psi3_over_h"] == pytest.approx(s_k["psi3_over_h"], rel=5 * kh)
        assert s_p["psi3_over_h"] < 0  # external pressure compresses, like kappa > 0


def test_energy_split_and_curvature_potential(sphere_model, sphere_solver):
    """Energy = U_s + (h^2/3) U_b + P_kappa + (h^2/3) 2 (1 + nu) kappa^2 A (a dropped constant)."""
    kappa = 0.5 / H
    s = _solve_at(sphere_model, sphere_solver, kappa)
    area = sphere_model.assemble("area")  # the discrete surface area
    const = H**2 / 3 * 2 * 1.5 * kappa**2 * area
    total = s["stretching"] + s["bending"] + s["curvature_potential"] + s["shear"] + const
    assert s["energy"] == pytest.approx(total, rel=1e-6)
    assert s["curvature_potential"] < 0  # the stimulus does work


def test_energy_density_fields_integrate_to_the_energies(sphere_model, sphere_solver):
    """The fields written for ParaView: e_b (the last two terms of Eq. (S-energy)) and the
    stretching density, interpolated on the mesh's P2 space, integrate to the model's own
    energies (interpolation error only: the shrunk sphere's densities are nearly uniform)."""
    import ufl
    from dolfinx import fem
    from mpi4py import MPI

    from shells.surface.fields import FieldWriter

    s = _solve_at(sphere_model, sphere_solver, 1.0 / H)
    funcs = FieldWriter(sphere_model, None).update()
    dx = ufl.Measure("dx", domain=sphere_model.shell.mesh)
    comm = sphere_model.shell.comm
    for name, expected in (("bending_energy_density", s["bending"] + s["curvature_potential"]),
                           ("stretching_energy_density", s["stretching"])):
        got = comm.allreduce(fem.assemble_scalar(fem.form(funcs[name] * dx)), op=MPI.SUM)
        assert got == pytest.approx(expected, rel=1e-3), name
    assert s["bending"] + s["curvature_potential"] < 0 < s["stretching"]


def _cap_works(h, theta_deg=30.0, kappa_R=0.05):
    cap = SphericalCap(1.0, math.radians(theta_deg))
    sm = generate(MeshSpec(cap, h=h, size=0.2, layer_elements=3))
    model = ShellModel(sm, ModelParameters(h=h, nu=0.5))
    ns = NewtonSolver(model)
    model.kappa.value = kappa_R
    ok, _ = ns.solve()
    assert ok
    s = model.scalars()
    ns.destroy()
    return s


def test_edge_work_dominates_and_scales():
    """Eqs. (2a, 2b): |W_edge| >> |W_bulk|, ratio ~ (R/h)^(3/2) / tan(theta/2).

    Measured (benchmarks/edge_bulk_scaling.py, mesh-converged): the ratio is ~1.0 times the
    paper's scale; its local exponent rises with thetabar (1.19, 1.30, 1.35, 1.39 from h/R = 0.04
    to 0.0025 at 30 deg), approaching 3/2 from below. The works are evaluated on u minus its mean
    translation: separately they are not translation invariant on an open cap.
    """
    theta = math.radians(30.0)
    hs = [0.02, 0.01, 0.005]
    ratios = []
    for h in hs:
        s = _cap_works(h)
        # first order: P_kappa = -(W_bulk + W_edge) in the linear regime
        assert s["curvature_potential"] == pytest.approx(-(s["W_bulk"] + s["W_edge"]), rel=2e-3)
        ratio = abs(s["W_edge"] / s["W_bulk"])
        assert 0.5 < ratio / ((1 / h) ** 1.5 / math.tan(theta / 2)) < 2.0  # O(1) prefactor
        ratios.append(ratio)
    exponent = -fitted_rate(hs, ratios)  # ratio ~ h^-exponent
    assert 1.2 < exponent < 1.6, (ratios, exponent)
    local = [math.log(ratios[i + 1] / ratios[i]) / math.log(2) for i in range(2)]
    assert local[1] > local[0]  # pre-asymptotic: the exponent grows towards 3/2


def test_cap_snaps_through_a_fold():
    """A cap with thetabar > 2.09 snaps: the arclength branch turns back in kappa (a fold)."""
    h, theta = 0.04, math.radians(30.0)  # thetabar = 2.62
    sm = generate(MeshSpec(SphericalCap(1.0, theta), h=h, size=0.2, layer_elements=3))
    model = ShellModel(sm, ModelParameters(h=h, nu=0.5))
    st = ContinuationSettings(ds=0.3, ds_max=0.6)
    pts = []
    for p in continuation(model, st, kappa_end=3.0):
        pts.append(p)
        if len(pts) > 2 and pts[-3].dkappa_ds < 0:  # two points past the fold
            break
    i = next(i for i, (a, b) in enumerate(zip(pts, pts[1:], strict=False))
             if a.dkappa_ds > 0 > b.dkappa_ds)
    kappa_fold = max(pts[i].kappa_L, pts[i + 1].kappa_L)
    # paper: kappa_s R = 0.85 thetabar - 0.67 = 1.555; independent codes find ~7 % lower, and
    # this coarse mesh is lower still (benchmarks quantify it): a broad but failing-capable window
    assert 1.2 < kappa_fold < 1.7
    # kappa rises monotonically up to the fold and falls after it: the branch turned around
    ks = [p.kappa_L for p in pts]
    assert np.all(np.diff(ks[: i + 1]) > 0) and ks[-1] < kappa_fold
    # the apex keeps moving down through the fold (snap-through direction)
    apex = [p.scalars["apex_uz_over_h"] for p in pts]
    assert np.all(np.diff(apex) < 0)


def test_modes_are_named_by_their_azimuthal_spectrum():
    """f(t) cos(m φ + 0.3) normal modes are named m (every m up to 3, radial sign changes
    included); a mixture of m = 0 (55 % of the power) and m = 2, whose Rayleigh quotient
    m² = ∫(∂_φ w)²/∫w² ≈ 1.15 would name a phantom m = 1, is named m = 0."""
    import ufl
    from dolfinx import fem

    cap = SphericalCap(1.0, math.radians(60))
    model = ShellModel(generate(MeshSpec(cap, h=0.04, size=0.3, layer_elements=2.0)),
                       ModelParameters(h=0.04, nu=0.5))
    x = ufl.SpatialCoordinate(model.shell.mesh)
    phi, t = ufl.atan2(x[1], x[0]), ufl.acos(x[2] / ufl.sqrt(ufl.dot(x, x)))
    v = fem.Function(model.W)

    def named(amp):
        n0 = model.n0
        e = ufl.as_vector([amp * n0[0], amp * n0[1], amp * n0[2], 0.0, 0.0, 0.0])
        v.interpolate(fem.Expression(e, model.W.element.interpolation_points()))
        return model.classify_mode(v.x.petsc_vec)

    for m, f in ((0, ufl.sin(3 * t)), (1, t), (2, ufl.sin(3 * t)), (3, ufl.cos(5 * t))):
        info = named(f * ufl.cos(m * phi + 0.3))
        assert info.m == m and info.rayleigh["m_power"] > 0.99, (m, info)
    mix = named(ufl.sin(3 * t) * (1.0 + 0.9 * ufl.cos(2 * phi)))
    assert round(math.sqrt(mix.rayleigh["m2"])) == 1  # the Rayleigh quotient's phantom
    assert mix.m == 0 and 0.5 < mix.rayleigh["m_power"] < 0.6
