"""Branch switching at a bifurcation (shells.algorithms.switching.switch_branch), on the surface
model.

A spherical cap (θ = 30°, h/R = 0.04, ν = ½) under κ < 0 loses its rotational symmetry in a
supercritical pitchfork into the m = 2 mode, a (cos 2φ, sin 2φ) pair: exactly double on the
8-sector mesh (exactly invariant under rotations by 45°; only the gauge splits it, by ~1e-6),
and the bifurcation is perfect. Along the new branch the pattern's rotation about the axis is a
nearly neutral direction, of either sign on the mesh, counted apart
(``Stability.negative_count_modulo_orbit``). The critical point comes from ``follow``
(located coarsely: the accuracy is reported and used), the new branch from ``switch_branch``;
the checks are
physical: equilibrium, m = 2 content, lower energy and stability where the fundamental branch is
unstable, and the pitchfork law a² ∝ |κ - κ_c| whose extrapolated κ_c must agree with the
eigenvalue crossing located on the fundamental branch and with the axisymmetric model. Valid
on any number of ranks: every quantity is a collective (reduced) value, and every rank asserts.
"""

import math

import numpy as np
import pytest
from mpi4py import MPI

from shells.algorithms.continuation import continuation
from shells.algorithms.following import follow
from shells.algorithms.newton import NewtonSolver
from shells.algorithms.settings import ContinuationSettings, CriticalSettings
from shells.algorithms.stability import Stability
from shells.algorithms.switching import switch_branch
from shells.analyses import axisym_runs
from shells.geometry.shapes import SphericalCap
from shells.surface.mesh import MeshSpec, generate
from shells.surface.model import ModelParameters, ShellModel


def test_switch_onto_the_buckled_branch_of_a_cap():
    comm = MPI.COMM_WORLD
    h = 0.04
    shape = SphericalCap(1.0, math.radians(30))
    sm = generate(MeshSpec(shape, h=h, size=0.2, layer_elements=3), comm)
    model = ShellModel(sm, ModelParameters(h=h, nu=0.5))
    # the fundamental branch to its first critical point, located coarsely (2 trial solves)
    st = ContinuationSettings(ds=0.2, ds_max=0.2, ds_unit="kappa")
    crit = CriticalSettings(stop_at_first=True, rel_tol=0.05, max_evaluations=2)
    fundamental = list(follow(model, st, -2.0, crit))
    p_past, r_past, found = fundamental[-1]
    assert len(found) == 1
    cp = found[0]
    assert cp.kind == "bifurcation" and cp.mode_m == 2 and cp.multiplicity == 2
    assert cp.negative_before == 0 and r_past.negative_count == 2  # unstable past κ_c
    assert p_past.kappa < cp.kappa
    w_past = model.w.x.array.copy()  # the fundamental (unstable) state past κ_c
    # the new branch, a little past κ_c
    kappa_end = cp.kappa - 0.06 * abs(cp.kappa)
    stab, ns = Stability(model), NewtonSolver(model)
    settings = ContinuationSettings(ds=0.25, ds_max=0.5, target_newton_its=6)
    new = []
    # first amplitude 0.125 h (RMS): the default 0.25 fails here and is retried at half
    orientation = []
    for p in switch_branch(model, cp, settings, kappa_end, ds=0.125):
        n, orbit = stab.negative_count_modulo_orbit()
        orientation.append(orbit)
        new.append((p, n - orbit, model.w.x.array.copy()))
    # the fundamental branch at the κ of the new points past the bracket of κ_c, by natural
    # continuation from the state past κ_c (the symmetric state stays exactly symmetric on the
    # sectored mesh: Newton from it stays on the fundamental branch)
    L = shape.characteristic_size()
    at = {p.kappa: (p.scalars["energy"], w) for p, _, w in new if p.kappa < cp.kappa_lo}
    assert len(at) >= 2, [p.kappa for p, _, _ in new]
    model.w.x.array[:] = w_past
    model.w.x.scatter_forward()
    far = max(at) if max(at) > p_past.kappa else min(at)
    nat = ContinuationSettings(method="natural", ds=0.05, ds_max=0.05,
                               kappa_stops=tuple(k * L for k in at))
    diff = model.w.x.petsc_vec.duplicate()
    compared = []
    for q in continuation(model, nat, kappa_start=p_past.kappa, kappa_end=far, solver=ns,
                          skip_first=True):
        k = min(at, key=lambda k: abs(k - q.kappa))
        if abs(k - q.kappa) <= 1e-12:
            e_new, w = at[k]
            diff.array_w[:] = w[: diff.getLocalSize()]
            diff.axpy(-1.0, model.w.x.petsc_vec)  # the symmetry-breaking part of the new state
            compared.append((k, e_new, q.scalars["energy"], stab.inertia()[0],
                             model.classify_mode(diff).m))
    diff.destroy()
    stab.destroy()
    ns.destroy()

    kappas = np.array([p.kappa for p, _, _ in new])
    amps = np.array([p.scalars["mode_amplitude"] for p, _, _ in new])
    counts = [c for _, c, _ in new]
    # enough points, all past κ_c, ending exactly on kappa_end
    assert len(new) >= 5
    assert np.all(kappas < cp.kappa_hi) and kappas[-1] == pytest.approx(kappa_end, rel=1e-12)
    # equilibria: the only residual is the force that holds the pattern's orientation (the
    # mesh's broken rotational symmetry), below 1e-4 of the κ-load (10x the corrector's 1e-5)
    for p, _, _ in new:
        assert p.scalars["residual"] <= 10 * p.scalars["residual_bound"], p.scalars
    # off the fundamental branch: a finite amplitude along the critical mode, growing with |κ|
    assert abs(amps[0]) > 0 and np.all(np.diff(np.abs(amps)) > 0), amps
    # stable once past κ_c, but for the pattern's orientation (at most that one direction)
    assert counts[-1] == 0 and counts[-2] == 0 and counts[-3] == 0, counts
    assert max(orientation) <= 1, orientation
    assert all(b <= a for a, b in zip(counts, counts[1:], strict=False)), counts
    # the pitchfork law a² = S (κ_0 - κ), fitted over the points past the first (which lies
    # within the imperfection scale of κ_c): linear, κ_0 the κ_c located on the fundamental branch
    a2, kk = amps[1:] ** 2, kappas[1:]
    assert len(a2) >= 3
    slope, icpt = np.polyfit(kk, a2, 1)
    fit_rms = float(np.sqrt(np.mean((a2 - (slope * kk + icpt)) ** 2)))
    kappa0 = -icpt / slope
    assert slope < 0 and fit_rms <= 0.05 * float(a2.max()), (slope, fit_rms, a2)
    assert cp.kappa_lo <= kappa0 <= cp.kappa_hi, (kappa0, cp.kappa_lo, cp.kappa_hi)
    assert abs(kappa0 - cp.kappa) <= cp.accuracy * abs(cp.kappa), (kappa0, cp.kappa)
    # against the fundamental branch at the same κ: the difference is an m = 2 pattern, the
    # fundamental state is unstable (2 negative eigenvalues) and the new one has a lower
    # energy, by ΔE = -C (κ - κ_0)² (Landau: a² ∝ κ_0 - κ gives E ∝ -(κ - κ_0)²)
    assert len(compared) >= 2, compared
    c_landau = []
    for k, e_new, e_fund, count_fund, m in compared:
        assert m == 2 and count_fund == 2, compared
        assert e_new < e_fund, compared
        c_landau.append((e_fund - e_new) / (k - kappa0) ** 2)
    assert max(c_landau) <= 1.1 * min(c_landau), c_landau
    # cross-validation (this cap is the θ = 30°, κ < 0 case of tests/test_cross_validation*.py):
    # the 1D model's first critical point is the same m = 2 bifurcation, within 2 % of both the
    # located κ_c and the pitchfork's κ_0 (measured: -0.6622, located -0.6625, κ_0 -0.6630)
    one_d = axisym_runs.critical(shape, h, 0.5, direction="down", m_max=6, kappa_max=2.0)
    assert one_d["kind"] == "bifurcation" and one_d["mode_m"] == 2
    assert cp.kappa == pytest.approx(one_d["kappa_R"], rel=0.02)
    assert kappa0 == pytest.approx(one_d["kappa_R"], rel=0.02)
