"""The axisymmetric model's mode Hessians (shells.axisym.modes): H_m of m ≥ 1 as the polynomial
Σ m^k C_k equals the direct assembly of the one mode form, conditions included, at non-trivial
states; the coefficient matrices follow every change of the state; the inertia is unchanged.

The 1D problem runs on MPI.COMM_SELF on every rank; the measured differences are reduced over
MPI.COMM_WORLD (their maximum) before asserting, so all ranks take the same branch.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

from shells.axisym import SNES_OPTIONS, AxisymModel, AxisymParameters, sphere_kappa_b_h
from shells.geometry import Sphere, SphericalCap
from shells.solvers import NewtonSolver
from shells.stability import Stability

MODES = (0, 1, 2, 3, 5, 20, 60)


def world_max(x: float) -> float:
    return MPI.COMM_WORLD.allreduce(float(x), op=MPI.MAX)


def everywhere(flag: bool) -> bool:
    return MPI.COMM_WORLD.allreduce(bool(flag), op=MPI.LAND)


def loaded(shape, h: float, kappas: tuple[float, ...], cells: int = 60) -> AxisymModel:
    """A model at a non-trivial state: Newton at each κ in turn (a few load steps)."""
    model = AxisymModel(shape, AxisymParameters(h=h, cells=cells))
    ns = NewtonSolver(model, options=SNES_OPTIONS)
    for k in kappas:
        model.set_kappa(k)
        ok, _ = ns.solve()
        assert everywhere(ok)
    ns.destroy()
    return model


def differences(model: AxisymModel, m: int, H=None) -> dict[str, float]:
    """Polynomial (``assemble_hessian`` into ``H``, reused as by ``Stability``, or a new matrix)
    against direct assembly of H_m: relative Frobenius and max-row-sum differences, the number
    of constrained rows that differ at all, whether both are flagged symmetric."""
    mf = model.mode_forms
    new = H is None
    H, D = model.create_hessian(m) if new else H, model.create_hessian(m)
    model.assemble_hessian(m, H)
    mf.assemble_hessian(m, D, direct=True)
    E = H.copy()
    E.axpy(-1.0, D)
    inf = PETSc.NormType.INFINITY
    rows_differ = 0
    for r in mf._constrained_rows(m).getIndices():
        (c1, v1), (c2, v2) = H.getRow(int(r)), D.getRow(int(r))
        rows_differ += not (np.array_equal(c1, c2) and np.array_equal(v1, v2))
    out = {"frobenius": E.norm() / D.norm(), "max": E.norm(inf) / D.norm(inf),
           "rows_differ": float(rows_differ),
           "not_symmetric": float(H.isSymmetricKnown() != (True, True)
                                  or D.isSymmetricKnown() != (True, True))}
    for A in (H, D, E) if new else (D, E):
        A.destroy()
    return out


@pytest.mark.parametrize("shape, h, kappas", [
    (Sphere(1.0), 0.01, (50.0, 100.0)),
    (SphericalCap(1.0, math.radians(60)), 0.02, (1.0, 2.0)),
], ids=["sphere", "cap"])
def test_polynomial_mode_hessians_equal_direct_assembly(shape, h, kappas):
    """m = 0 (its own form, the phases put in as numbers), 1, 2, 3, 5, 20, 60: relative
    Frobenius (and max-row-sum) difference ≤ 1e-10 (measured ≤ 7e-16; m = 0: 0), the
    constrained rows (zero, 1 on the diagonal) identical, both flagged symmetric."""
    model = loaded(shape, h, kappas)
    H = model.create_hessian(1)  # one matrix for every m, as Stability's
    for m in MODES:
        for d in (differences(model, m, H), differences(model, m)):
            d = {k: world_max(v) for k, v in d.items()}
            assert d["frobenius"] <= 1e-10 and d["max"] <= 1e-10, (m, d)
            assert d["rows_differ"] == 0 and d["not_symmetric"] == 0, (m, d)
    H.destroy()


def test_coefficient_matrices_follow_the_state():
    """The C_k are assembled once per state and again after any change of it: κ alone
    (``set_kappa``), a Newton solve, the state vector written directly."""
    model = loaded(Sphere(1.0), 0.01, (50.0,))
    mf = model.mode_forms
    assert world_max(differences(model, 5)["frobenius"]) <= 1e-10
    inputs = mf._C_inputs
    assert world_max(differences(model, 20)["frobenius"]) <= 1e-10
    assert everywhere(mf._C_inputs is inputs)  # same state: not reassembled
    model.set_kappa(80.0)  # no solve: only κ changed
    assert world_max(differences(model, 5)["frobenius"]) <= 1e-10
    assert everywhere(mf._C_inputs is not inputs)
    ns = NewtonSolver(model, options=SNES_OPTIONS)
    assert everywhere(ns.solve()[0])
    ns.destroy()
    assert world_max(differences(model, 3)["frobenius"]) <= 1e-10
    model.state.scale(1.5)  # written through the PETSc vector, no solve
    model.sync()
    assert world_max(differences(model, 60)["frobenius"]) <= 1e-10


def test_inertia_is_that_of_the_direct_assembly():
    """Past the sphere's bifurcation (κ = 1.1 κ_b, h/R = 0.01) the negative count of every
    block m = 0..30 is the direct assembly's, and some are positive."""
    h = 0.01
    kb = sphere_kappa_b_h(0.5) / h
    model = loaded(Sphere(1.0), h, tuple(f * kb for f in (0.4, 0.8, 1.0, 1.1)), cells=120)
    blocks = tuple(range(31))
    stab = Stability(model)
    poly = stab.negative_counts(blocks)
    model.assemble_hessian = (  # the instance's blocks from the direct form
        lambda b, H: model.mode_forms.assemble_hessian(b, H, direct=True))
    direct = stab.negative_counts(blocks)
    stab.destroy()
    counts = np.array([poly[b] for b in blocks], dtype=float)
    hi = np.empty_like(counts)
    MPI.COMM_WORLD.Allreduce(counts, hi, op=MPI.MAX)
    assert everywhere(poly == direct)
    assert np.array_equal(hi, counts)  # every rank got the same counts
    assert counts.sum() > 0


def test_hessian_values_are_those_of_the_assembled_blocks():
    """``hessian_values`` (Σ m^k c_k on the CSR values, conditions by masks) equals the
    assembled H_m entry by entry to round-off (relative 1e-13 of the largest entry; its
    constrained rows and columns exactly) for m = 1, 2, 3, 5, 20, 60; m = 0 is left out."""
    model = loaded(SphericalCap(1.0, math.radians(60)), 0.02, (1.0, 2.0))
    values = model.hessian_values((None, *MODES))
    assert set(values) == set(MODES) - {0}
    H = model.create_hessian(1)
    worst = 0.0
    for m in values:
        model.assemble_hessian(m, H)
        _, _, ref = H.getValuesCSR()
        zero, diagonal = model.mode_forms._value_masks(m)
        assert np.array_equal(values[m][zero] != 0, ref[zero] != 0)
        assert np.all(values[m][diagonal] == 1.0) and np.all(ref[diagonal] == 1.0)
        worst = max(worst, np.max(np.abs(values[m] - ref)) / np.max(np.abs(ref)))
    H.destroy()
    assert world_max(worst) <= 1e-13, worst
