"""Stability layer: inertia, eigenvalues, and the guard against Naghdi's loss of ellipticity."""

import math

import pytest

from shells.algorithms.newton import NewtonSolver
from shells.algorithms.stability import Stability
from shells.geometry.shapes import Sphere
from shells.surface.mesh import MeshSpec, generate
from shells.surface.model import ModelParameters, ShellModel

H = 0.05


@pytest.fixture(scope="module")
def meshes():
    return {s: generate(MeshSpec(Sphere(1.0), size=s)) for s in (0.3, 0.2)}


def _negative_counts(sm, penalty, kh):
    model = ShellModel(sm, ModelParameters(h=H, nu=0.5, shear_penalty=penalty))
    ns, stab = NewtonSolver(model), Stability(model)
    model.kappa.value = kh / H
    ok, _ = ns.solve()
    assert ok
    r = stab.check(nev=3)
    ns.destroy()
    stab.destroy()
    return r


def test_stable_and_eigenvalues_consistent(meshes):
    """Stable iff no negative eigenvalue; the SLEPc eigenvalues agree with the inertia sign."""
    r = _negative_counts(meshes[0.3], 1e3, 0.5)
    assert r.stable and r.negative_count == 0 and r.zero_count == 0
    assert len(r.eigenvalues) == 3 and min(r.eigenvalues) > 0
    # the lowest physical modes sit at the bending/membrane scale (~0.1), not near zero: the
    # rigid-motion gauge leaves no spurious soft modes
    assert min(r.eigenvalues) > 0.02


def test_naghdi_loses_ellipticity_koiter_limit_does_not(meshes):
    """Shear-flexible Naghdi (penalty 1) with natural curvature: mesh-scale negative modes whose
    number grows under refinement; the stiff Kirchhoff-Love penalty (1e3) has none."""
    kh = 1.4  # above sqrt(3)(1 - nu)/(1 + nu) = 0.58, below the sphere's buckling ~1.5
    naghdi = [_negative_counts(meshes[s], 1.0, kh).negative_count for s in (0.3, 0.2)]
    koiter = [_negative_counts(meshes[s], 1e3, kh) for s in (0.3, 0.2)]
    assert naghdi[0] > 0 and naghdi[1] > 10 * naghdi[0]
    assert all(r.stable for r in koiter)
    # the lowest Koiter eigenvalue is a converging physical quantity, not a mesh artefact:
    # it changes by a bounded amount under refinement and stays positive
    e0, e1 = (min(r.eigenvalues) for r in koiter)
    assert 0 < e1 < e0 < 2.5 * e1


# ------------------------------------------------------------------------------------------------
# the banded Cholesky test of definiteness (stability.BandedCholesky) against eigenvalues
# and MUMPS
# ------------------------------------------------------------------------------------------------
def _scaled_band_matrix(n: int, kd: int, lowest: float, seed: int):
    """A symmetric matrix D B D: B banded (half-bandwidth ``kd``) with unit diagonal and lowest
    eigenvalue ``lowest``, D diagonal over 8 decades (the 1D model's blocks span 1e-2..1e8 on
    their diagonal), rows and columns in a random order. Returns the PETSc SeqAIJ matrix, its
    dense B and the original half-bandwidth."""
    import numpy as np
    from petsc4py import PETSc

    rng = np.random.default_rng(seed)
    B0 = np.zeros((n, n))
    for k in range(1, kd + 1):
        v = rng.standard_normal(n - k)
        B0 += np.diag(v, k) + np.diag(v, -k)
    t = (1.0 - lowest) / -np.linalg.eigvalsh(B0)[0]
    B = np.eye(n) + t * B0
    d = 10.0 ** rng.uniform(-4, 4, n)
    perm = rng.permutation(n)
    A = (d[:, None] * B * d[None, :])[np.ix_(perm, perm)]
    M = PETSc.Mat().createAIJ((n, n), comm=PETSc.COMM_SELF)
    M.setPreallocationNNZ(2 * kd + 1)
    rows, cols = np.nonzero(B[np.ix_(perm, perm)])
    for r in range(n):
        c = cols[rows == r]
        M.setValues(r, c.astype(PETSc.IntType), A[r, c])
    M.assemble()
    return M, B


@pytest.mark.parametrize("lowest, definite", [
    (0.3, True), (1e-6, True), (1e-11, True),      # definite by more than the margin
    (1e-16, False), (-1e-11, False), (-0.4, False),  # within it (near singular), indefinite
])
def test_banded_cholesky_decides_definiteness_by_the_scaled_eigenvalue(lowest, definite):
    """The test answers "definite" iff the lowest eigenvalue of the diagonally scaled matrix
    exceeds the margin (1e-13), whatever the scaling and the order of the rows: badly scaled
    (8 decades), shuffled; its ordering recovers the band (half-bandwidth 4, at most 4 found
    again)."""
    import numpy as np

    from shells.algorithms.stability import DEFINITE_MARGIN, BandedCholesky

    M, B = _scaled_band_matrix(300, 4, lowest, seed=int(1e6 * abs(lowest)) % 1000 + 7)
    assert abs(np.linalg.eigvalsh(B)[0] - lowest) < 1e-14 + 1e-9 * abs(lowest)
    ai, aj, values = M.getValuesCSR()
    test = BandedCholesky(ai, aj)
    assert test.kd <= 4
    assert test.definite(values, DEFINITE_MARGIN) is definite
    bad = values.copy()
    bad[len(bad) // 2] = np.nan  # a NaN anywhere is never definite
    assert test.definite(bad, DEFINITE_MARGIN) is False
    M.destroy()


def test_banded_inertia_is_that_of_mumps_on_the_deep_cap():
    """The θ̄ = 8 cap (h/R = 0.01, θ = 46.2°) at states before, between and right at its
    bifurcations (m = 5 at κR = 5.12315, m = 4 at 5.14014, m = 3 at 5.34935): the negative
    count of every block m = 0..12 with the banded test (and, where it fails, the exact count of
    the condensed block: the model's LDLᵀ, or MUMPS where that does not vouch for it) equals
    MUMPS' alone on the whole block, except where the block's eigenvalue nearest 0 lies within
    round-off of 0 (|μ| < 1e-7, measured -5.9e-9 at 5.12315: its sign is then the
    factorisation's); the test decides most blocks and leaves the indefinite and the nearly
    singular ones to the exact counts."""
    from shells.axisym import SNES_OPTIONS, AxisymModel, AxisymParameters
    from shells.geometry.shapes import SphericalCap

    model = AxisymModel(SphericalCap(1.0, math.radians(46.2)), AxisymParameters(h=0.01))
    ns = NewtonSolver(model, options=SNES_OPTIONS)
    fast, ref = Stability(model), Stability(model)
    ref.banded_test = False
    blocks = tuple(range(13))
    seen, rounded = [], []
    for k in (1.0, 2.5, 4.0, 4.8, 5.0, 5.1, 5.12315, 5.14014, 5.2, 5.34935, 5.45):
        model.set_kappa(k)
        ok, _ = ns.solve()
        assert ok
        counts = fast.negative_counts(blocks)
        exact = ref.negative_counts(blocks)
        for m in blocks:
            if counts[m] != exact[m]:
                mu = ref.eigenpairs(1, block=m)[0][0]
                assert abs(counts[m] - exact[m]) == 1 and abs(mu) < 1e-7, (k, m, mu)
                rounded.append((k, m))
        seen.append(sum(exact.values()))
    assert seen[0] == 0 and seen[-1] >= 3  # m = 3, 4, 5 (and 6 crosses at 5.439)
    assert len(rounded) <= 3  # only right at a crossing
    assert fast.calls["banded"] > 0.8 * len(blocks) * len(seen)
    # every negative count came from an exact factorisation: mostly the model's own LDLᵀ of
    # the condensed block (``block_inertia``), MUMPS where that does not vouch for it
    assert fast.calls["ldlt"] + fast.calls["mumps"] >= sum(seen)
    assert fast.calls["ldlt"] >= 0.8 * sum(seen)
    for s in (fast, ref):
        s.destroy()
    ns.destroy()


def test_orbit_cosine_measures_the_orbit_modulo_rigid_motions():
    """``orbit_cosine`` on vectors of R^40 (the L² inner products of the models replaced by
    the Euclidean one): a tangent plus any rigid motion is along the orbit (1); a rigid motion
    alone, a vector orthogonal to both, or a state without orbit (vanishing tangent) is not
    (0); without rigid motions it is the plain |cos| with the tangent."""
    import numpy as np

    from shells.problem.interface import orbit_cosine

    rng = np.random.default_rng(7)
    t1, t2, r1, r2 = rng.standard_normal((4, 40))

    def cos(v, basis, tangents):
        gram = [basis[i] @ basis[j] for i in range(len(basis)) for j in range(i, len(basis))]
        return orbit_cosine(np.array([v @ b for b in basis]), np.array(gram), v @ v, 1.0,
                            tangents)

    basis = [t1, t2, r1, r2]
    assert cos(0.3 * t1 - 2.0 * t2 + 5.0 * r1 - r2, basis, 2) == pytest.approx(1.0, abs=1e-12)
    assert cos(t2 + 0.1 * r2, basis, 2) == pytest.approx(1.0, abs=1e-12)
    assert cos(2.0 * r1 - r2, basis, 2) == 0.0
    q, _ = np.linalg.qr(np.array(basis).T, mode="complete")
    assert cos(q[:, 10], basis, 2) == pytest.approx(0.0, abs=1e-12)
    assert cos(t1 + r1, [0.0 * t1, r1], 1) == 0.0  # no orbit: the tangent vanishes
    v = rng.standard_normal(40)
    assert cos(v, [t1], 1) == pytest.approx(abs(v @ t1) / math.sqrt((v @ v) * (t1 @ t1)),
                                            rel=1e-12)
    # a mode partly along the orbit: its share of the quotient by the rigid motions
    w = q[:, 10]
    w = w / np.linalg.norm(w)
    tp = t1 - np.array([r1, r2]).T @ np.linalg.lstsq(np.array([r1, r2]).T, t1, rcond=None)[0]
    tp = tp / np.linalg.norm(tp)
    assert cos(0.6 * tp + 0.8 * w + 3.0 * r2, [t1, r1, r2], 1) == pytest.approx(0.6, rel=1e-12)


def test_a_larger_eigensolve_after_a_smaller_one_on_the_same_block(meshes):
    """The block's EPS is reused: a solve for 30 pairs after one for 2 (the orbit count asks
    n + 1 after the stability check's few) works and agrees with it (SLEPc had kept the first
    set-up's mpd: 'ncv must not be larger than nev + mpd')."""
    model = ShellModel(meshes[0.3], ModelParameters(h=H, nu=0.5))
    ns, stab = NewtonSolver(model), Stability(model)
    try:
        model.kappa.value = 0.5 / H
        ok, _ = ns.solve()
        assert ok
        few, _ = stab.eigenpairs(2)
        many, _ = stab.eigenpairs(30)
        assert len(many) == 30
        assert sorted(many, key=abs)[:2] == pytest.approx(sorted(few, key=abs), rel=1e-6)
    finally:
        ns.destroy()
        stab.destroy()
