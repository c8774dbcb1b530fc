"""Natural frequencies (``shells.algorithms.frequencies``) of the free closed sphere against
the classical values, on both models.

Classical values (thin elastic sphere, Ω² = ρ R² ω² (1-ν²)/E, λ = n(n+1)): the membrane
equations give, for the spheroidal modes of degree n, Ω⁴ - (1 + 3ν + λ) Ω² + (λ - 2)(1 - ν²) = 0
(Baker, J. Acoust. Soc. Am. 33, 1749, 1961; Kraus, Thin Elastic Shells, 1967, ch. 8), whose
n = 0 root is Lamb's breathing mode (1882) Ω² = 2(1 + ν), i.e. ω² = 2E/(ρR²(1 - ν)). The
model's own energy adds bending: for the breathing mode (u = w n°, b - b° = (w/R²) a° against
a - a° = (2w/R) a°) exactly the factor 1 + h²/(12R²), so ω² R² ρ/E = 2(1 + h²/(12R²))/(1 - ν);
for n ≥ 2 a relative O((h/R)² λ²) above the membrane value (2e-4 at n = 2, h/R = 0.01).

The free spherical cap (radius R, θ̄ = θ/√(h/R)) tends, as it flattens, to the free circular
Kirchhoff plate of radius a = R sin θ: Ω² = ω² a⁴ ρh/D → λ⁴ (``shells.theory.free_plate_lambda2``,
the roots of the free edge's characteristic equation), approached as Ω² = λ⁴ (1 - G (h/a)²/12)
+ q 12 (1 - ν²) θ̄⁴: the rotary inertia of the models' kinetic mass (Rayleigh's, first order,
``free_plate_rotary_inertia``) and the shallow shell's stretching q E/(ρR²)
(``free_cap_membrane_factor``: Reissner's q = 1 for the axisymmetric modes, q = 1.07e-3 and
4.5e-3 for the nearly inextensional m = 2, 3 modes).

The 1D problem runs on MPI.COMM_SELF on every rank (differences reduced before asserting); the
surface model is distributed over MPI.COMM_WORLD.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from mpi4py import MPI

from shells.algorithms.frequencies import KineticStability, natural_frequencies
from shells.axisym import AxisymModel, AxisymParameters
from shells.errors import InputError
from shells.geometry.shapes import Disk, Sphere, SphericalCap
from shells.problem.kinetic import sparse_part
from shells.theory import (
    free_cap_membrane_factor,
    free_cap_omega2,
    free_plate_lambda2,
    free_plate_rotary_inertia,
)

NU = 0.5


def world_max(x: float) -> float:
    return MPI.COMM_WORLD.allreduce(float(x), op=MPI.MAX)


def membrane(n: int, nu: float = NU) -> float:
    """The lower membrane root ω² R² ρ/E of degree n."""
    lam = n * (n + 1)
    b, c = 1 + 3 * nu + lam, (lam - 2) * (1 - nu**2)
    return (b - math.sqrt(b * b - 4 * c)) / 2 / (1 - nu**2)


def breathing(h: float, nu: float = NU) -> float:
    return 2 * (1 + h * h / 12) / (1 - nu)


def sphere_1d(h: float, cells: int = 40) -> AxisymModel:
    return AxisymModel(Sphere(1.0), AxisymParameters(h=h, nu=NU, cells=cells), comm=MPI.COMM_SELF)


def test_breathing_mode_is_lambs_and_the_gauge_is_no_support():
    """The n = 0 mode of the free sphere (1D model, block None) at ω² = 2(1 + h²/12)/(1 - ν)
    to 1e-8, the lowest mode n = 2. With the gauged mass alone (the pole's u_z held, no
    free-body correction) the gauge acts as a point support: a spurious near-rigid mode far
    below n = 2 (block None: the translation along the axis; block 1: across it), and no mode
    at the breathing frequency."""
    model = sphere_1d(0.1)
    f = natural_frequencies(model, count=8, blocks=(None,))
    w0 = [x.omega2 for x in f if x.mode_n == 0]
    err = abs(w0[0] / breathing(0.1) - 1) if len(w0) == 1 else 1.0
    assert world_max(err) < 1e-8
    assert world_max(float(not (f[0].mode_n == 2 and f[0].omega2 > 0.5))) == 0.0

    class Pinned(KineticStability):
        def mass(self, block=None):
            return sparse_part(super().mass(block))

    for block in (None, 1):
        stab = Pinned(model)
        vals, _ = stab.eigenpairs(8, block=block)
        stab.destroy()
        assert world_max(vals[0]) < 0.1
        assert world_max(-min(abs(v / breathing(0.1) - 1) for v in vals)) < -1e-3


def test_sphere_n2_n3_against_the_membrane_values_in_every_block():
    """h/R = 0.01: the lowest mode of blocks m = 0, 1, 2 is n = 2 at the membrane value (bending
    adds 2e-4), n = 3 next (1e-3); the (2n + 1)-fold degeneracy holds across the blocks."""
    model = sphere_1d(0.01)
    f = natural_frequencies(model, count=2, blocks=(0, 1, 2))
    by = {(x.block, x.mode_n): x.omega2 for x in f}
    errs = [abs(by.get((m, 2), 0.0) / membrane(2) - 1) for m in (0, 1, 2)]
    errs += [abs(by.get((m, 3), 0.0) / membrane(3) - 1) / 4 for m in (0, 1, 2)]
    spread = max(abs(by.get((m, 2), 0.0) / by.get((0, 2), 1.0) - 1) for m in (1, 2))
    assert world_max(max(errs)) < 5e-4
    assert world_max(spread) < 1e-7


def test_surface_sphere_agrees_with_the_1d_model():
    """Surface model (P3, size 0.5, h/R = 0.05, distributed): the five lowest modes are n = 2
    within 5e-4 of the 1D model's, then n = 3 (the same)."""
    from shells.surface.mesh import MeshSpec, generate
    from shells.surface.model import ModelParameters, ShellModel

    ref, ref3 = (x.omega2 for x in natural_frequencies(sphere_1d(0.05), count=2, blocks=(0,)))
    sm = generate(MeshSpec(Sphere(1.0), size=0.5), MPI.COMM_WORLD)
    model = ShellModel(sm, ModelParameters(h=0.05, nu=NU, degree=3))
    f = natural_frequencies(model, count=6)
    assert [x.mode_n for x in f] == [2] * 5 + [3]
    assert max(abs(x.omega2 / ref - 1) for x in f[:5]) < 5e-4
    assert f[5].omega2 == pytest.approx(ref3, rel=5e-4)


def test_free_plate_roots_are_the_flat_disks():
    """The characteristic equation's λ² at ν = 0.33 (5.26204, 9.06890, 12.2439; Leissa's table
    has 5.253, 9.084, 12.23, 0.1-0.2 % off) and ν = 1/2 (4.64037, 9.41367, 10.9405); the 1D
    model's free disk (h/a = 0.01, 40 cells) gives the lowest ω of m = 2, 0, 3 at ν = 1/2 as
    λ² √(1 - G (h/a)²/12) to 1e-7 (measured 1.4e-8; without the rotary inertia G they are
    5e-5 to 9e-5 below λ²)."""
    nu33 = [free_plate_lambda2(n, 0.33) for n in (2, 0, 3)]
    assert nu33 == pytest.approx([5.26204, 9.06890, 12.2439], abs=1e-4)
    assert free_plate_lambda2(1, 0.33, 2) == pytest.approx(59.859, abs=1e-3)
    for bad in ((-1, NU, 1), (2, NU, 0), (2, 0.6, 1)):
        with pytest.raises(InputError):
            free_plate_lambda2(*bad)
    h = 0.01
    model = AxisymModel(Disk(1.0), AxisymParameters(h=h, nu=NU, cells=40), comm=MPI.COMM_SELF)
    f = {x.block: x.omega2 for x in natural_frequencies(model, count=1, blocks=(0, 2, 3))}
    errs = []
    for m in (2, 0, 3):
        big = math.sqrt(f[m] * 12 * (1 - NU**2)) / h  # ω a² √(ρh/D), a = L = 1
        ref = free_plate_lambda2(m, NU) * math.sqrt(1 - free_plate_rotary_inertia(m, NU)
                                                    * h * h / 12)
        errs.append(abs(big / ref - 1))
    assert world_max(max(errs)) < 1e-7


#: the flattening caps: h/R = 1e-5 (the smallest the analyses accept; at θ̄ = 0.6 the cap's
#: θ = 0.109°, near the smallest cap, 0.1°), θ̄ = 0.6 to 1.2, a/h = 190 to 380
CAP_H = 1e-5
CAP_THETABARS = (0.6, 0.8, 1.0, 1.2)


def test_free_cap_tends_to_the_free_plate():
    """The lowest ω of m = 0, 2, 3 of free caps (1D model, ``frequencies.run``, 40 cells)
    flattening at h/R = 1e-5, in plate units Ω² = ω² a⁴ρh/D (a = R sin θ), the rotary inertia's
    first-order share added back (λ⁴ G (h/a)²/12), against the free plate's λ⁴:

    * Ω² - λ⁴ ∝ θ̄^p: p = 4.0004 (m = 0), 4.005 (m = 2), 4.013 (m = 3) measured, held to 2e-3
      and 0.03. The m = 2, 3 modes stretch little (q ~ 1e-3: nearly the inextensional
      rⁿ cos nφ), so the non-shallow O(θ̄² h/R) term is a percent of theirs: with a = R θ
      instead of R sin θ the same fit gives p = 3.96, 3.95.
    * Ω² = A + B θ̄⁴ fitted: √A = λ² to 2.3e-6 measured (either a), held to 1e-5; B against
      12 (1-ν²) q: 8e-5 (m = 0, Reissner's q = 1), 2.0 % and 1.1 % (m = 2, 3, q = 1.0698e-3,
      4.5073e-3; the same non-shallow term), held to 1e-3 and 0.05.

    At 40 cells and the default penalty 1e4, ω is converged to 3e-8 (against 80 cells, and
    against penalty 1e3); a penalty of 100 lowers it by 5e-7, of 1 by up to 4e-5."""
    from shells.analyses import frequencies

    c = 12 * (1 - NU**2)
    big = {0: [], 2: [], 3: []}
    for tb in CAP_THETABARS:
        theta = tb * math.sqrt(CAP_H)
        res = frequencies.run(SphericalCap(1.0, theta), CAP_H, NU, m_max=3, count=1, cells=40)
        a = math.sin(theta)
        for m in big:
            w2 = next(f["omega2"] for f in res["frequencies"] if f["mode_m"] == m)
            lam4 = free_plate_lambda2(m, NU) ** 2
            rot = lam4 * free_plate_rotary_inertia(m, NU) * (CAP_H / a) ** 2 / 12
            big[m].append(w2 * c * a**4 / CAP_H**2 + rot)
    tb = np.array(CAP_THETABARS)
    errs = {}
    for m, tol_p, tol_b in ((0, 2e-3, 1e-3), (2, 0.03, 0.05), (3, 0.03, 0.05)):
        lam4 = free_plate_lambda2(m, NU) ** 2
        p = np.polyfit(np.log(tb), np.log(np.array(big[m]) - lam4), 1)[0]
        B, A = np.polyfit(tb**4, big[m], 1)
        errs[m] = (abs(p - 4) / tol_p, abs(math.sqrt(A / lam4) - 1) / 1e-5,
                   abs(B / (c * free_cap_membrane_factor(m, NU)) - 1) / tol_b)
    worst = world_max(max(max(e) for e in errs.values()))
    assert worst < 1.0, errs


def test_surface_cap_agrees_with_the_1d_model():
    """The θ̄ = 0.8 cap at h/R = 1e-5 (a/h = 253) on the surface model (P3, size θ/10 = a/10,
    23k DOFs, distributed): the five lowest modes are m = 2, 2, 0, 3, 3 within 2e-4 of the 1D
    model's (measured -4.7e-5, 1.5e-5, -7.3e-5 at the default quadrature degree 4, which the
    sphere's test compiles; 2.7e-5, 5.1e-5, 9.6e-5 at degree 6), and the 1D model's are
    ``free_cap_omega2``'s to 3e-5 (measured 8e-6)."""
    from shells.surface.mesh import MeshSpec, generate
    from shells.surface.model import ModelParameters, ShellModel

    theta = 0.8 * math.sqrt(CAP_H)
    cap = SphericalCap(1.0, theta)
    one_d = AxisymModel(cap, AxisymParameters(h=CAP_H, nu=NU, cells=40), comm=MPI.COMM_SELF)
    ref = {x.block: x.omega2 for x in natural_frequencies(one_d, count=1, blocks=(0, 2, 3))}
    classical = max(abs(ref[m] / free_cap_omega2(0.8, CAP_H, m, NU) - 1) for m in ref)
    sm = generate(MeshSpec(cap, size=theta / 10), MPI.COMM_WORLD)
    model = ShellModel(sm, ModelParameters(h=CAP_H, nu=NU, degree=3))
    f = natural_frequencies(model, count=5)
    modes = [x.mode_m for x in f]
    err = max(abs(x.omega2 / ref[x.mode_m] - 1) for x in f) if modes == [2, 2, 0, 3, 3] else 1.0
    assert world_max(err) < 2e-4, modes
    assert world_max(classical) < 3e-5


def test_cli_json(capsys):
    """``shells frequencies --json``: the contract's keys, ω ascending, on rank 0."""
    import json

    from shells.cli import main

    assert main(["frequencies", "--shape", "sphere", "--h-over-r", "0.05", "--count", "1",
                 "--m-max", "2", "--cells", "40", "--json"]) == 0
    if MPI.COMM_WORLD.rank == 0:
        out = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
        assert out["kappa_R"] == 0.0
        fs = out["frequencies"]
        assert {"omega", "mode_m", "mode_n"} <= set(fs[0])
        assert [f["mode_n"] for f in fs] == [2, 2, 2]
        # h/R = 0.05: bending adds 0.6 % to the membrane ω² at n = 2
        assert fs[0]["omega2"] == pytest.approx(membrane(2), rel=1e-2)


def test_frequencies_fall_to_zero_at_the_critical_point(shared_tmp, capsys):
    """The vibration-correlation technique: the sphere's (h/R = 0.05) frequencies followed to
    κR = 27, 28, 29, the first mode's ω² extrapolated to zero, predict its buckling at
    κ_b h = 1.482659 (``shells critical --model axisym``) to 1e-3; the CLI gives the same
    from ``--kappa-R 27 28 29`` and draws ω² against κR."""
    import json

    from shells.analyses import frequencies
    from shells.cli import main
    from shells.geometry.shapes import Sphere

    res = frequencies.along(Sphere(1.0), 0.05, 0.5, kappa_R=[27, 28, 29], m_max=0, count=4)
    est = res["critical_estimate"]
    assert est["kappa_R"] * 0.05 == pytest.approx(1.482659, rel=1e-3)
    assert est["mode_n"] == 9 and len(res["points"]) == 3 and res["kappa_R"] == 29
    # the critical mode's ω² falls with κ, nearly linearly
    w2 = frequencies.modes_along(res["points"])[(0, 9)]
    assert w2[0] > w2[1] > w2[2] > 0
    png = shared_tmp / "omega2.png"
    assert main(["frequencies", "--shape", "sphere", "--h-over-r", "0.05", "--m-max", "0",
                 "--kappa-R", "27", "28", "29", "--plot", str(png), "--json"]) == 0
    if MPI.COMM_WORLD.rank == 0:
        out = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
        assert out["critical_estimate"]["kappa_R"] == pytest.approx(est["kappa_R"], rel=1e-12)
        assert png.stat().st_size > 0
    assert main(["frequencies", "--shape", "sphere", "--h-over-r", "0.05", "--kappa-R",
                 "27", "--plot", str(png)]) == 2
