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

from shells.algorithms.newton import NewtonSolver
from shells.algorithms.stability import Stability
from shells.axisym import SNES_OPTIONS, AxisymModel, AxisymParameters
from shells.geometry.shapes import Sphere, SphericalCap
from shells.theory import sphere_kappa_b_h

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
    for r in mf.constrained_rows(m).getIndices():
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
    """m = 0 (on one process from C_0's element matrices by a change of unknowns, in parallel
    its own form with the phases put in as numbers), 1, 2, 3, 5, 20, 60: relative Frobenius
    (and max-row-sum) difference ≤ 1e-10 (measured ≤ 7e-16), the constrained rows (zero, 1
    on the diagonal) identical, both flagged symmetric."""
    model = loaded(shape, h, kappas)
    H = model.create_hessian(1)  # one matrix for every m, as Stability's
    for m in MODES:
        for d in (differences(model, m, H), differences(model, m)):
            d = {k: world_max(v) for k, v in d.items()}
            assert d["frobenius"] <= 1e-10 and d["max"] <= 1e-10, (m, d)
            assert d["rows_differ"] == 0 and d["not_symmetric"] == 0, (m, d)
    H.destroy()


def test_coefficient_matrices_follow_the_state():
    """The C_k (in parallel; on one process the element matrices they come from) are made
    once per state and again after any change of it: κ alone (``set_kappa``), a Newton solve,
    the state vector written directly."""
    model = loaded(Sphere(1.0), 0.01, (50.0,))
    mf = model.mode_forms
    key = "coefficient_inputs" if mf.chain_setup() is None else "element_inputs"
    assert world_max(differences(model, 5)["frobenius"]) <= 1e-10
    inputs = getattr(mf, key)
    assert inputs is not None
    assert world_max(differences(model, 20)["frobenius"]) <= 1e-10
    assert everywhere(getattr(mf, key) is inputs)  # same state: not made again
    model.set_kappa(80.0)  # no solve: only κ changed
    assert world_max(differences(model, 5)["frobenius"]) <= 1e-10
    assert everywhere(getattr(mf, key) is not inputs)
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
    model.assemble_hessian = (  # the instance's blocks from the direct form, all by MUMPS
        lambda b, H: model.mode_forms.assemble_hessian(b, H, direct=True))
    stab.banded_test = False
    direct = stab.negative_counts(blocks)
    stab.destroy()
    counts = np.array([poly[b] for b in blocks], dtype=float)
    hi = np.empty_like(counts)
    MPI.COMM_WORLD.Allreduce(counts, hi, op=MPI.MAX)
    assert everywhere(poly == direct)
    assert np.array_equal(hi, counts)  # every rank got the same counts
    assert counts.sum() > 0


@pytest.mark.parametrize("shape, h, kappas", [
    (Sphere(1.0), 0.01, tuple(f * sphere_kappa_b_h(0.5) / 0.01 for f in (0.5, 1.0, 1.1))),
    (SphericalCap(1.0, math.radians(60)), 0.02, (1.0, 2.0)),
], ids=["sphere past its bifurcation", "cap"])
def test_definiteness_from_element_matrices_is_that_of_the_assembled_blocks(shape, h, kappas):
    """``ModeForms.definite`` (element matrices condensed on the chain of cells,
    ``shells.axisym.chain``) answers as the banded Cholesky of the assembled H_m
    (``shells.algorithms.stability``) for m = 0, 1, 2, 3, 5, 20, 60, at margins on both sides of
    each block's own threshold: the largest margin τ* at which the assembled test still says
    "definite" (bisection, to a factor 1.02) is found again within a factor 1.1 (both sides
    tested), so both test the same number, the lowest eigenvalue of the diagonally scaled
    block; an indefinite block is refused by both at every margin."""
    from shells.algorithms.stability import BlockSolvers

    model = loaded(shape, h, kappas)
    mf = model.mode_forms
    block = BlockSolvers(model, 1, {})

    def assembled(m: int, tau: float) -> bool:
        model.assemble_hessian(m, block.H)
        return block.definite(tau)

    def chain(m: int, tau: float) -> bool:
        out = mf.definite([m], tau)
        assert out is not None  # one process (COMM_SELF): the chain test is available
        return out[m]

    seen = {"definite": 0, "indefinite": 0}
    for m in MODES:
        if not assembled(m, 1e-16):
            assert not chain(m, 1e-16) and not chain(m, 0.0), m
            seen["indefinite"] += 1
            continue
        seen["definite"] += 1
        lo, hi = 1e-16, 1.0  # assembled: definite at lo, not at hi
        while hi / lo > 1.02:
            mid = math.sqrt(lo * hi)
            lo, hi = (mid, hi) if assembled(m, mid) else (lo, mid)
        assert chain(m, lo / 1.1) and not chain(m, hi * 1.1), (m, lo)
    block.destroy()
    # the cap below its critical points: all definite; the sphere past κ_b: some not
    assert everywhere(seen["definite"] >= (1 if shape.closed else len(MODES)))
    assert everywhere(seen["indefinite"] >= (1 if shape.closed else 0))


@pytest.mark.parametrize("shape, h, kappas", [
    (Sphere(1.0), 0.01, tuple(f * sphere_kappa_b_h(0.5) / 0.01 for f in (0.5, 1.0, 1.1))),
    (SphericalCap(1.0, math.radians(60)), 0.02, (1.0, 2.0)),
], ids=["sphere past its bifurcation", "cap"])
def test_eigenpairs_with_the_chain_factorisation_are_those_with_mumps(shape, h, kappas):
    """The shift-invert eigensolves with the model's own factorisation (``block_factor``:
    ``shells.axisym.chain.ChainLU``) find the 4 eigenvalues nearest 0 of blocks m = 0, 1, 2,
    3, 5, 20 that MUMPS' find (the reference mode, ``banded_test`` False), to 1e-7: their
    round-off, as between any two direct solvers of these stiff blocks (measured at most
    2.4e-8, eigenvalues from -0.03 to 4; on the sphere, of its 14 (m = 20: 9) negative ones
    per block, the three nearest 0 among the 4 of blocks m ≤ 5 and two of block 20's)."""
    model = loaded(shape, h, kappas)
    fast, ref = Stability(model), Stability(model)
    ref.banded_test = False
    negative = 0
    for m in (0, 1, 2, 3, 5, 20):
        a, _ = fast.eigenpairs(4, block=m)
        b, _ = ref.eigenpairs(4, block=m)
        assert len(a) == len(b) == 4
        assert np.max(np.abs(np.array(a) - np.array(b))) < 1e-7, (m, a, b)
        negative += sum(mu < 0 for mu in b)
        # the fast path ran on one process (the model's COMM_SELF), the reference never
        assert fast.block_solvers(m).shell_eps is not None
        assert ref.block_solvers(m).shell_eps is None
    assert negative >= (17 if shape.closed else 0)
    for s in (fast, ref):
        s.destroy()


def test_residual_and_dkappa_in_one_pass_are_the_separate_assemblies():
    """On one process R and dR/dκ come from one kernel on W x W (``AxisymModel._paired``):
    both equal the separate assemblies of their own forms to the last bit, dR/dκ served from
    the last residual's pass only at the same state (after a change of κ or of the state it
    is assembled again: the same values as its own form's)."""
    from shells.problem.forms import FormProblem

    model = loaded(SphericalCap(1.0, math.radians(60)), 0.02, (1.0, 2.0))
    a, b = model.create_vector(), model.create_vector()

    def same(x, y):
        return everywhere(np.array_equal(x.array, y.array) and x.norm() > 0)

    model.assemble_residual(a)
    FormProblem.assemble_residual(model, b)
    assert same(a, b)
    model.assemble_dkappa(a)
    FormProblem.assemble_dkappa(model, b)
    assert same(a, b)
    assert model.comm.size > 1 or model.dkappa_kept is not None  # the pass's dR/dκ
    model.state.scale(1.01)  # another state: the kept dR/dκ is not that of this state
    model.sync()
    model.assemble_dkappa(a)
    FormProblem.assemble_dkappa(model, b)
    assert same(a, b)


def test_jacobian_from_element_matrices_is_dolfinx_assembly():
    """The Jacobian assembled from its element matrices into a matrix whose values are written
    in place (one process) is dolfinx's assembly of the same form to the last bit, on a
    loaded cap and a loaded sphere; dolfinx can still assemble into that matrix."""
    from shells.problem.forms import FormProblem

    for shape, h, kappas in ((SphericalCap(1.0, math.radians(60)), 0.02, (1.0, 2.0)),
                             (Sphere(1.0), 0.01, (20.0, 60.0))):
        model = loaded(shape, h, kappas)
        assert model.jacobian_elements() is not None  # one process (COMM_SELF): the fast path
        A, B, C = model.create_jacobian(), FormProblem.create_jacobian(model), \
            model.create_jacobian()
        model.assemble_jacobian(A)
        FormProblem.assemble_jacobian(model, B)
        FormProblem.assemble_jacobian(model, C)  # dolfinx into the in-place matrix
        for X in (A, C):
            (ia, ja, va), (ib, jb, vb) = X.getValuesCSR(), B.getValuesCSR()
            assert np.array_equal(ia, ib) and np.array_equal(ja, jb)
            assert np.array_equal(va, vb)
        assert B.norm() > 0
        for X in (A, B, C):
            X.destroy()


def test_eigenvalues_are_rayleigh_quotients_free_of_the_factorisations_round_off():
    """Next to a slow crossing (the θ̄ = 15.11 cap going down, h/R = 0.01, κR = -0.4231, block
    m = 2, ‖H‖_F ~ 5e9: ε ‖H‖ ~ 1e-6 against μ ~ 1e-7), the state solved again at
    κ (1 + k 1e-10), k = -3..3, moves μ physically by ~1e-13 a step. The shift-invert's own
    eigenvalue (``refine=False``) scatters about the line through the seven by ~6e-8 (measured),
    the round-off of the assembled block and its factorisation; the Rayleigh quotient of
    ``Stability.eigenpairs`` (vᵀHv by quadrature of d²E(v, v)) lies on it to 2.5e-14. At one
    state, the chain LU's and MUMPS' quotients agree to 1e-15 (their own eigenvalues: 1.3e-8
    apart; both are MUMPS' in parallel)."""
    K = -0.4231
    model = loaded(SphericalCap(1.0, 15.1142857 * 0.1), 0.01, tuple(np.linspace(0, K, 9)[1:]),
                   cells=200)
    ns = NewtonSolver(model, options=SNES_OPTIONS)
    stab, mumps = Stability(model), Stability(model)
    mumps.banded_test = False
    w0 = model.state.array_r.copy()
    raw, quotient = [], []
    ks = np.arange(-3, 4)
    for k in ks:
        model.state.array_w[:] = w0
        model.sync()
        model.set_kappa(K * (1.0 + k * 1e-10))
        ok, _ = ns.solve()
        assert everywhere(ok)
        raw.append(stab.eigenpairs(1, block=2, refine=False)[0][0])
        quotient.append(stab.eigenpairs(1, block=2)[0][0])

    def scatter(y):
        return float(np.max(np.abs(np.polyval(np.polyfit(ks, y, 1), ks) - y)))

    assert 1.0e-7 < quotient[3] < 1.3e-7  # locator_noise: 1.155e-7 on the phase diagram's mesh
    assert scatter(quotient) < 1e-12
    assert scatter(raw) > 1e-9  # the floor the quotients remove
    a, b = stab.eigenpairs(1, block=2)[0][0], mumps.eigenpairs(1, block=2)[0][0]
    assert abs(a - b) < 1e-13
    if MPI.COMM_WORLD.size == 1:  # two factorisations (in parallel both are MUMPS)
        a = stab.eigenpairs(1, block=2, refine=False)[0][0]
        b = mumps.eigenpairs(1, block=2, refine=False)[0][0]
        assert abs(a - b) > 1e-10
    for s in (stab, mumps, ns):
        s.destroy()


def test_counts_together_and_with_the_last_count_as_hint_are_the_counts_alone():
    """``Stability.negative_counts`` skips the definiteness test of the blocks negative at its
    last count and condenses the exact counts of the failing blocks together
    (``block_inertias``); the counts are those of a ``Stability`` that tests and counts each
    block alone (a fresh one at each state), along the sphere past its bifurcation, where
    blocks turn negative one after the other."""
    kb = sphere_kappa_b_h(0.5) / 0.01
    model = loaded(Sphere(1.0), 0.01, (0.5 * kb,))
    ns = NewtonSolver(model, options=SNES_OPTIONS)
    hinted = Stability(model)
    blocks = tuple(range(0, 24, 2))
    agree, negative = True, 0
    for f in (0.9, 1.0, 1.05, 1.1, 1.0, 0.9):
        model.set_kappa(f * kb)
        ok, _ = ns.solve()
        assert everywhere(ok)
        alone = Stability(model)
        ref = {b: alone.negative_count(b) for b in blocks}
        agree = agree and hinted.negative_counts(blocks) == ref
        negative = max(negative, sum(c > 0 for c in ref.values()))
        alone.destroy()
    if MPI.COMM_WORLD.size == 1:
        assert model.mode_forms.inertias([2, 4, 6], 100.0) == {
            m: model.mode_forms.inertia(m, 100.0) for m in (2, 4, 6)}
    assert everywhere(agree) and negative >= 2
    hinted.destroy()
    ns.destroy()
