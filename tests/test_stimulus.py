"""Natural-curvature fields K = f(x) (f1 e1⊗e1 + f2 e2⊗e2) (shells.geometry.stimulus and both
models): the field language and its refusals, f = 1 against the uniform stimulus, the anisotropic
plate against its closed-form solution, and the two models against each other on a patterned cap."""

from __future__ import annotations

import math

import numpy as np
import pytest
from mpi4py import MPI

from shells.errors import InputError
from shells.geometry.shapes import Disk, SphericalCap
from shells.geometry.stimulus import UNIFORM, CurvatureField

CAP = SphericalCap(radius=1.0, theta=math.radians(30))
H_OVER_R = 0.04
#: f = 1 (exactly) written so that it takes the field's code path in both models (sin² + cos²
#: would be 1 only to round-off, which a fold's location amplifies to about 1e-9)
ONE = "where(theta >= 0, 1, 2)"


# ------------------------------------------------------------------------------------------
# the field language
# ------------------------------------------------------------------------------------------
def test_fields_evaluate_as_written():
    x = np.array([0.3, 0.0, -0.2])
    y = np.array([0.4, 0.5, 0.0])
    z = np.array([0.866, 0.5, -0.9])
    r, th, ph = np.hypot(x, y), np.arctan2(np.hypot(x, y), z), np.arctan2(y, x)
    cases = {
        "1": np.ones(3),
        "-2.5": np.full(3, -2.5),
        "x + 2*y - z**2": x + 2 * y - z**2,
        "where(theta < 1, 1, -0.5)": np.where(th < 1, 1.0, -0.5),
        "step(0.5 - r, 0.1)": 0.5 * (1 + np.tanh((0.5 - r) / 0.1)),
        "cos(3*phi) * exp(-r**2/R**2)": np.cos(3 * ph) * np.exp(-r**2 / 4.0),
        "where(r > 0.1 and z > 0, atan2(y, x), min(x, max(y, z)))":
            np.where((r > 0.1) & (z > 0), ph, np.minimum(x, np.maximum(y, z))),
        "abs(-theta) + sqrt(r) + pi": th + np.sqrt(r) + math.pi,
    }
    for text, expected in cases.items():
        assert np.allclose(CurvatureField(text).values(x, y, z, R=2.0), expected,
                           rtol=1e-14, atol=1e-14), text
    assert CurvatureField().uniform and CurvatureField("1.0").uniform
    assert not CurvatureField("1", (1.0, 0.5)).uniform
    assert not CurvatureField(ONE).uniform  # the general path, though f = 1
    assert CurvatureField("2", (1, 1)).anisotropy == (1.0, 1.0)


@pytest.mark.parametrize("text", [
    "", "  ", "x +", "__import__('os')", "x.real", "lambda: 1", "[x]", "x if y else z",
    "a + 1", "sin", "sin(x, y)", "where(x < 1, 1)", "x(1)", "open('f')", "1 < x < 2",
    "x == 1", "'text'", "True", "(" * 400 + "1" + ")" * 400, "x" * 3000, "sin(x=1)", "1j",
])
def test_bad_field_texts_are_refused(text):
    with pytest.raises(InputError):
        CurvatureField(text).check_on(CAP)


@pytest.mark.parametrize("text, axisym", [
    ("1/0", False), ("log(theta - 1)", False), ("0 * x", False), ("0**-1", False),
    ("10**400", False), ("(-1)**0.5", False), ("cos(phi)", True), ("x", True),
])
def test_fields_not_finite_zero_or_not_axisymmetric_are_refused(text, axisym):
    fld = CurvatureField(text)
    with pytest.raises(InputError):
        fld.check_on(CAP, axisymmetric=axisym)


def test_any_field_text_is_accepted_or_refused_in_one_error():
    """Random texts made of the language's pieces and others: an InputError or a finite,
    nonzero field on the cap, nothing else."""
    rng = np.random.default_rng(17)
    pieces = ["x", "y", "z", "r", "phi", "theta", "pi", "R", "0", "1", "-1", "2.5", "1e308",
              "(", ")", "+", "-", "*", "/", "**", "<", ">=", "and", "or", "not", "sin(",
              "where(", "step(", ",", "min(", "atan2(", "__class__", "os", ".", "[", "=", "'"]
    accepted = 0
    for _ in range(3000):
        text = " ".join(rng.choice(pieces, size=rng.integers(1, 9)))
        try:
            fld = CurvatureField(text)
            fld.check_on(CAP, axisymmetric=bool(rng.integers(2)))
        except InputError:
            continue
        accepted += 1
        t, ph = np.meshgrid(np.linspace(0, CAP.theta, 41), np.linspace(0, 2 * np.pi, 13))
        v = fld.values(np.sin(t) * np.cos(ph), np.sin(t) * np.sin(ph), np.cos(t))
        assert np.all(np.isfinite(v)) and np.any(v != 0), text
    assert accepted > 50  # the sample reaches valid fields, not only refusals


def test_bad_anisotropy_is_refused():
    for an in [(0, 0), (1,), (1, 2, 3), (math.nan, 1), (1, math.inf), ("a", 1), None]:
        with pytest.raises(InputError):
            CurvatureField("1", an)


# ------------------------------------------------------------------------------------------
# the 1D model
# ------------------------------------------------------------------------------------------
def _axisym_state(shape, fld, kappa, h_over_r=H_OVER_R, nu=0.5, cells=None):
    from shells.algorithms.newton import NewtonSolver
    from shells.axisym import SNES_OPTIONS
    from shells.axisym.model import AxisymModel, AxisymParameters

    kw = {} if cells is None else {"cells": cells}
    m = AxisymModel(shape, AxisymParameters(h=h_over_r * shape.characteristic_size(), nu=nu,
                                            kappa_field=fld, **kw))
    ns = NewtonSolver(m, options=SNES_OPTIONS)
    m.set_kappa(kappa)
    ok, _ = ns.solve()
    assert ok
    ns.destroy()
    return m


def test_unit_field_reproduces_the_uniform_model_1d():
    """f = 1 through the field's code path. At one state the residual and the energy equal the
    uniform stimulus's to round-off (1e-12); the 30° cap's located fold to 1e-9: the forms
    differ in the order of their floating-point operations, and the located point moves with
    round-off by up to the Newton tolerance's effect (measured 2.8e-10)."""
    from shells.analyses import axisym_runs

    base = _axisym_state(CAP, UNIFORM, 0.8)
    one = _axisym_state(CAP, CurvatureField(ONE), 0.0)
    base.w.x.petsc_vec.copy(one.w.x.petsc_vec)
    one.set_kappa(0.8)
    one.sync()
    rb, ro = base.create_vector(), one.create_vector()
    base.assemble_residual(rb)
    one.assemble_residual(ro)
    db, do = base.create_vector(), one.create_vector()
    base.assemble_dkappa(db)
    one.assemble_dkappa(do)
    for a, b in ((rb, ro), (db, do)):
        b.axpy(-1.0, a)
        assert b.norm() <= 1e-12 * max(a.norm(), db.norm())
    assert abs(one.scalars()["energy"] - base.scalars()["energy"]) \
        < 1e-12 * abs(base.scalars()["energy"])
    ref = axisym_runs.critical(CAP, H_OVER_R, 0.5, direction="up")
    fld = axisym_runs.critical(CAP, H_OVER_R, 0.5, direction="up", kappa_field=CurvatureField(ONE))
    assert ref["kind"] == fld["kind"] == "fold"
    assert abs(fld["kappa_R"] - ref["kappa_R"]) < 1e-9 * abs(ref["kappa_R"])
    assert abs(ref["kappa_R"] - 1.3934) < 2e-4  # the converged value (docs/paper-comparison)


def test_anisotropic_plate_bends_as_its_closed_form_1d():
    """A free disk of radius a with K = f1 e_r⊗e_r + f2 e_φ⊗e_φ, at a load small enough for the
    linear plate: the slope ψ = w' minimises ∫ (1-ν)[(ψ' - κf1)² + (ψ/r - κf2)²] +
    ν(ψ' + ψ/r - κ(f1+f2))² r dr, whose Euler-Lagrange equation (rψ')' - ψ/r = κ(1-ν)(f1-f2)
    with ψ(0) = 0 and the free edge ψ' + νψ/r = κ(f1 + νf2) give ψ = A r + C r ln r,
    C = κ(1-ν)(f1-f2)/2, (1+ν)(A + C ln a) + C = κ(f1 + νf2). (f1 = f2: ψ = κr, a sphere.)"""
    a, nu, kappa = 1.0, 0.3, 1e-4
    disk = Disk(radius=a)
    for f1, f2 in [(1.0, 0.0), (0.0, 1.0), (1.0, -1.0), (2.0, 0.5)]:
        m = _axisym_state(disk, CurvatureField("1", (f1, f2)), kappa, h_over_r=0.01, nu=nu)
        prof = m.meridian_profile()
        C = kappa * (1 - nu) * (f1 - f2) / 2
        A = (kappa * (f1 + nu * f2) - C) / (1 + nu) - C * math.log(a)
        drop = A * a**2 / 2 + C * (a**2 / 2 * math.log(a) - a**2 / 4)  # w(a) - w(0)
        computed = prof["uz"][-1] - prof["uz"][0]
        assert abs(computed - drop) < 2e-3 * abs(drop), (f1, f2, computed, drop)


def test_patterned_cap_1d_refuses_a_field_of_the_azimuth():
    from shells.axisym.model import AxisymModel, AxisymParameters

    with pytest.raises(InputError, match="azimuth"):
        AxisymModel(CAP, AxisymParameters(h=0.04, kappa_field=CurvatureField("1 + 0.1*y")))
    with pytest.raises(InputError, match="pressure"):
        AxisymParameters(h=0.04, load="pressure", kappa_field=CurvatureField("2"))


# ------------------------------------------------------------------------------------------
# the surface model, against the uniform stimulus and the 1D model
# ------------------------------------------------------------------------------------------
def _surface_state(fld, kappa, shell):
    from shells.algorithms.newton import NewtonSolver
    from shells.surface.model import ModelParameters, ShellModel

    # P3, the default under a field (P2 locks: the curvature potential 2 % off on this mesh)
    m = ShellModel(shell, ModelParameters(h=H_OVER_R, nu=0.5, degree=3, quadrature_degree=6,
                                          kappa_field=fld))
    ns = NewtonSolver(m)
    for k in (0.5 * kappa, kappa):
        m.set_kappa(k)
        ok, _ = ns.solve()
        assert ok
    ns.destroy()
    return m


@pytest.fixture(scope="module")
def cap_mesh():
    from shells.surface.mesh import MeshSpec, generate

    return generate(MeshSpec(CAP, h=H_OVER_R, size=0.1, layer_elements=3.0), MPI.COMM_WORLD)


def test_unit_field_reproduces_the_uniform_state_surface(cap_mesh):
    base = _surface_state(UNIFORM, 0.8, cap_mesh)
    one = _surface_state(CurvatureField(ONE), 0.8, cap_mesh)
    e0, e1 = base.scalars()["energy"], one.scalars()["energy"]
    assert abs(e1 - e0) < 1e-10 * abs(e0)
    diff = base.w.x.petsc_vec.copy()
    diff.axpy(-1.0, one.w.x.petsc_vec)
    assert diff.norm() < 1e-10 * base.w.x.petsc_vec.norm()  # a global norm: every rank agrees


def test_patterned_anisotropic_cap_surface_agrees_with_1d(cap_mesh):
    """A smooth non-uniform, anisotropic stimulus at κR = 0.8 (about 60 % of the uniform fold):
    the models' mean normal displacement Ψ3 and curvature potential agree to the coarse mesh's
    accuracy (measured: 7e-6 and 5.3e-4 with P3; P2 on the same mesh: 0.5 % and 2.3 %)."""
    fld = CurvatureField("1 + 0.5*cos(6*theta)", (1.0, 0.4))
    s = _surface_state(fld, 0.8, cap_mesh).scalars()
    a = _axisym_state(CAP, fld, 0.8).scalars()
    for key, tol in (("psi3_over_h", 1e-4), ("curvature_potential", 2e-3)):
        assert abs(s[key] - a[key]) < tol * abs(a[key]), (key, s[key], a[key])
    # the stimulus is felt: the uniform one gives a different state
    u = _axisym_state(CAP, UNIFORM, 0.8).scalars()
    assert abs(u["psi3_over_h"] - a["psi3_over_h"]) > 0.05 * abs(a["psi3_over_h"])


# ------------------------------------------------------------------------------------------
# the command line
# ------------------------------------------------------------------------------------------
CLI_CAP = ["--shape", "cap", "--theta-deg", "30", "--h-over-r", "0.04"]


@pytest.mark.parametrize("argv, needle", [
    (["critical", *CLI_CAP, "--model", "axisym", "--kappa-field", "cos(phi)"], "azimuth"),
    (["critical", *CLI_CAP, "--kappa-field", "import os"], "not an expression"),
    (["branch", *CLI_CAP, "--kappa-r-max", "1", "--kappa-field", "0*r"], "vanishes"),
    (["postbuckle", *CLI_CAP, "--kappa-field", "foo"], "unknown name 'foo'"),
    (["critical", *CLI_CAP, "--anisotropy", "0", "0"], "not both 0"),
    (["critical", *CLI_CAP, "--anisotropy", "1"], "expected 2 arguments"),
])
def test_cli_refuses_a_bad_field_in_one_line(capsys, argv, needle):
    from shells.cli import main

    assert main(argv) == 2
    err = capsys.readouterr().err
    if MPI.COMM_WORLD.rank == 0:
        lines = [ln for ln in err.splitlines() if ln.strip()]
        assert len(lines) == 1 and needle in lines[0] and "Traceback" not in err, err


def test_cli_critical_with_a_ring_field(capsys):
    """The 1D model's ring-patterned cap from the command line: the fold of the ring
    f = step(θ - 0.2, 0.05) step(0.4 - θ, 0.05) (the surface model's P3 value, 2.288695 at the
    default mesh, agrees to 9e-5: benchmarks/kappa_fields.py), and the field in the JSON."""
    import json

    from shells.cli import main

    ring = "step(theta - 0.2, 0.05) * step(0.4 - theta, 0.05)"
    assert main(["critical", *CLI_CAP, "--model", "axisym", "--kappa-field", ring,
                 "--anisotropy", "1", "1", "--json"]) == 0
    out = capsys.readouterr().out
    d = MPI.COMM_WORLD.bcast(json.loads(out.strip().splitlines()[-1])
                             if MPI.COMM_WORLD.rank == 0 else None)
    assert d["kind"] == "fold" and d["kappa_field"] == ring and d["anisotropy"] == [1.0, 1.0]
    assert abs(d["kappa_R"] - 2.288494) < 2e-5


# ------------------------------------------------------------------------------------------
# dead loads equivalent to a stimulus (the outlook's hypothesis, benchmarks/outlook_hypothesis.py)
# ------------------------------------------------------------------------------------------
SPHERE_H = 0.01
PATCH = CurvatureField(f"step(0.8 - theta, {math.sqrt(SPHERE_H):.6g})")  # width sqrt(R h)


def _smooth_displacement(m):
    """A smooth axisymmetric displacement meeting the axis conditions, its slopes exact."""
    from dolfinx import fem

    w = fem.Function(m.W)
    w.sub(0).interpolate(lambda x: np.vstack([np.sin(x[0]) * np.cos(x[0]) * (1 + 0.3 * np.cos(
        2 * x[0])), np.cos(2 * x[0]) + 0.5 * np.cos(3 * x[0])]))
    w.sub(1).interpolate(lambda x: np.vstack([
        np.cos(2 * x[0]) * (1 + 0.3 * np.cos(2 * x[0])) - 0.3 * np.sin(2 * x[0]) ** 2,
        -2 * np.sin(2 * x[0]) - 1.5 * np.sin(3 * x[0])]))
    return w


def test_equivalent_load_splits_into_normal_and_tangential_forces():
    """On a closed sphere the linearised curvature potential of a field f is, integrated by
    parts, -(2/3)(1+ν) h² κ ∫ [(Δf - 2f/R²) Ψ3 + (2/R) ∇f·Ψ_t] dω: its load vector applied to
    a smooth displacement equals the normal load's plus the tangential term (the normal load
    carries a body force balancing its resultant, accounted for here)."""
    import ufl
    from dolfinx import fem

    from shells.axisym.model import AxisymModel, AxisymParameters

    S = SphericalCap(1.0, math.pi)
    work = {}
    for load in ("equivalent", "equivalent_normal"):
        m = AxisymModel(S, AxisymParameters(h=SPHERE_H, cells=400, load=load, kappa_field=PATCH))
        b = m.create_vector()
        m.assemble_dkappa(b)
        w = _smooth_displacement(m)
        work[load] = b.dot(w.x.petsc_vec)
        u, _ = ufl.split(w)
        c = -2 * (1 + m.nu) / 3 * m.h**2
        us = (u[0] * m.r0t + u[1] * m.z0t) / m.g
        tangential = c * 2 / S.R * m.K[0].dx(0) / m.g * us * m.area_density * m.dx
        relief = -c * m.normal_load()[1] * u[1] * m.area_density * m.dx
        split = [fem.assemble_scalar(fem.form(f)) for f in (tangential, relief)]
        b.destroy()
    diff = work["equivalent"] - work["equivalent_normal"]
    assert abs(diff - (split[0] - split[1])) < 1e-4 * abs(work["equivalent"])
    assert abs(split[0]) > 0.1 * abs(work["equivalent"])  # the tangential part is not small


def test_stimulus_against_its_equivalent_dead_loads():
    """A polar patch of width √(Rh) on the h/R = 0.01 sphere at κh = 0.02: the linearised
    equivalent load gives the stimulus's Ψ3 profile to its nonlinearity (measured 0.19 %); the
    normal forces alone (the outlook's hypothesis) are 18 % off, the local pressure of Eq. (5)
    96 % (it misses Δf) - benchmarks/outlook_hypothesis.py has the widths and thicknesses."""
    from shells.algorithms.newton import NewtonSolver
    from shells.axisym import SNES_OPTIONS
    from shells.axisym.model import AxisymModel, AxisymParameters

    S = SphericalCap(1.0, math.pi)
    prof = {}
    for load in ("curvature", "equivalent", "equivalent_normal", "local_pressure"):
        m = AxisymModel(S, AxisymParameters(h=SPHERE_H, cells=600, penalty=1e6, load=load,
                                            kappa_field=PATCH))
        ns = NewtonSolver(m, options=SNES_OPTIONS)
        m.set_kappa(0.02 / SPHERE_H)
        assert ns.solve()[0]
        p = m.meridian_profile()
        prof[load] = p["ur"] * np.sin(p["t"]) + p["uz"] * np.cos(p["t"])
        ns.destroy()
    ref = prof["curvature"]
    err = {k: np.linalg.norm(v - ref) / np.linalg.norm(ref) for k, v in prof.items()}
    assert err["equivalent"] < 0.005
    assert 0.1 < err["equivalent_normal"] < 0.3
    assert err["local_pressure"] > 0.8


# ------------------------------------------------------------------------------------------
# fields given as tables
# ------------------------------------------------------------------------------------------
RING = "step(theta - 0.2, 0.05) * step(0.4 - theta, 0.05)"
N_POINTS = 4000


def test_tables_reproduce_the_expression(shared_tmp):
    """The ring as a θ profile (2 columns, 300 rows) and as values at 4000 scattered points of
    the cap (4 columns): the 1D model's fold within 1e-4 and 3e-3 of the expression's
    (measured 2.2e-3 with 3000 points: their spacing, 0.017 R, against the ring's edge width
    0.05 R)."""
    from shells.analyses import axisym_runs

    fld = CurvatureField(RING)
    rng = np.random.default_rng(3)
    th = np.linspace(0, CAP.theta + 0.01, 300)
    prof = np.column_stack([th, fld.values(np.sin(th), 0 * th, np.cos(th))])
    t = np.arccos(1 - rng.random(N_POINTS) * (1 - math.cos(CAP.theta + 0.02)))
    ph = rng.random(N_POINTS) * 2 * math.pi
    xyz = np.column_stack([np.sin(t) * np.cos(ph), np.sin(t) * np.sin(ph), np.cos(t)])
    pts = np.column_stack([xyz, fld.values(*xyz.T)])
    files = {}
    if MPI.COMM_WORLD.rank == 0:
        np.savetxt(shared_tmp / "ring_profile.csv", prof, delimiter=",", header="theta, f")
        np.savetxt(shared_tmp / "ring_points.txt", pts)
    MPI.COMM_WORLD.barrier()
    files = {"profile": CurvatureField.from_file(str(shared_tmp / "ring_profile.csv")),
             "points": CurvatureField.from_file(str(shared_tmp / "ring_points.txt"))}
    ref = axisym_runs.critical(CAP, H_OVER_R, 0.5, direction="up", kappa_field=fld)["kappa_R"]
    for name, tol in (("profile", 1e-4), ("points", 3e-3)):
        got = axisym_runs.critical(CAP, H_OVER_R, 0.5, direction="up",
                                   kappa_field=files[name])["kappa_R"]
        assert abs(got / ref - 1) < tol, (name, got, ref)
    # a table travels with a run's description (resume checks, headers)
    again = CurvatureField.from_description({"field": files["profile"].describe()})
    assert again == files["profile"]


@pytest.mark.parametrize("content, needle", [
    ("0 1\n0.1 2 3\n", "all rows alike"),
    ("0.2 1\n0.1 2\n", "must increase"),
    ("0 1\n1 nan\n", "not finite"),
    ("0 a\n1 2\n", "other than numbers"),
    ("0 1\n", "has 1 rows"),
    ("1 2 3 4\n1 2 3 5\n", "two values at one point"),
    ("0 0\n4 0\n", "within [0, pi]"),
])
def test_bad_tables_are_refused(shared_tmp, content, needle):
    import zlib

    path = shared_tmp / f"bad{zlib.crc32(content.encode())}.dat"  # the same name on every rank
    if MPI.COMM_WORLD.rank == 0:
        path.write_text(content)
    MPI.COMM_WORLD.barrier()
    with pytest.raises(InputError, match=needle.replace("[", r"\[").replace("]", r"\]")):
        CurvatureField.from_file(str(path))


def test_cli_refuses_a_missing_table(capsys):
    from shells.cli import main

    assert main(["critical", *CLI_CAP, "--model", "axisym", "--kappa-field",
                 "no-such-field.csv"]) == 2
    err = capsys.readouterr().err
    if MPI.COMM_WORLD.rank == 0:
        assert len(err.strip().splitlines()) == 1 and "no-such-field.csv" in err, err
