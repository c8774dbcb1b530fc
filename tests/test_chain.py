"""The chain test of definiteness and the chain's inertia (shells.axisym.chain) on synthetic
chains of cells, against the dense eigenvalues of the assembled matrix: cells in any order and
of either orientation, constrained vertex DOFs, margins on both sides of the threshold.
Milliseconds; every rank runs the same (sequential) check."""

from __future__ import annotations

import numpy as np
import pytest

from shells.axisym.chain import ChainCholesky

# a cell's element rows: vertex a (rows 0, 4), interior (1, 2, 3), vertex b (rows 5, 6)
VERTEX_A, VERTEX_B, INTERIOR = [0, 4], [5, 6], [1, 2, 3]
ONE = np.ones((1, 1))  # one block, the (only) form times 1


def _chain(ncells: int, seed: int, shift: float):
    """Element matrices (random, symmetric) of a chain with cells shuffled and half of them
    reversed; the global DOFs: 2 per vertex, 3 interior per cell. Returns the cell DOFs, the
    elements, the assembled dense matrix."""
    rng = np.random.default_rng(seed)
    nv = ncells + 1
    n = 2 * nv + 3 * ncells
    vertex = rng.permutation(2 * nv).reshape(nv, 2)  # global DOFs of each chain vertex
    interior = 2 * nv + rng.permutation(3 * ncells).reshape(ncells, 3)
    dofs = np.zeros((ncells, 7), dtype=np.int64)
    for p in range(ncells):
        a, b = (vertex[p + 1], vertex[p]) if rng.random() < 0.5 else (vertex[p], vertex[p + 1])
        dofs[p, VERTEX_A], dofs[p, VERTEX_B], dofs[p, INTERIOR] = a, b, interior[p]
    order = rng.permutation(ncells)
    dofs = dofs[order]
    E = np.empty((ncells, 7, 7))
    for c in range(ncells):
        B = rng.standard_normal((7, 7))
        E[c] = B @ B.T / 7 + shift * np.eye(7)
    H = np.zeros((n, n))
    for c in range(ncells):
        H[np.ix_(dofs[c], dofs[c])] += E[c]
    return dofs, E, H


def _scaled_lowest(H: np.ndarray, constrained: np.ndarray) -> float:
    H = H.copy()
    H[constrained, :] = 0.0
    H[:, constrained] = 0.0
    H[constrained, constrained] = 1.0
    d = 1.0 / np.sqrt(np.diag(H))
    return float(np.linalg.eigvalsh(d[:, None] * H * d[None, :])[0])


@pytest.mark.parametrize("seed", range(6))
def test_chain_test_decides_as_the_scaled_lowest_eigenvalue(seed):
    """Definite by margin τ iff the lowest eigenvalue of D^-1/2 H D^-1/2 exceeds τ (D the
    diagonal), tested at τ = 0.8 and 1.25 times that eigenvalue, with and without two
    constrained vertex DOFs; an indefinite matrix (negative shift) is refused at τ = 0."""
    dofs, E, H = _chain(40, seed, shift=-0.05 if seed % 3 == 0 else 0.02)
    chain = ChainCholesky(dofs, (VERTEX_A, VERTEX_B), INTERIOR)
    assert chain.size == 2 * 41 and chain.kd == 3
    rng = np.random.default_rng(seed)
    for constrained in (np.zeros(0, dtype=np.int64), np.sort(rng.choice(dofs[:, VERTEX_A].ravel(),
                                                                        2, replace=False))):
        low = _scaled_lowest(H, constrained)
        if low <= 0:
            assert chain.definite(E[None], ONE, [-1], [constrained], 0.0) == [False]
            continue
        assert chain.definite(E[None], ONE, [-1], [constrained], 0.8 * low) == [True]
        assert chain.definite(E[None], ONE, [-1], [constrained], 1.25 * low) == [False]


def test_blocks_in_one_call_decide_each_as_its_dense_eigenvalue():
    """Seven blocks in one call (the C loop takes four at a time, one per SIMD lane), each
    with its own constrained DOFs and a shift on either side of definiteness: each answers as
    the lowest eigenvalue of its own scaled, constrained matrix says, the lanes do not mix."""
    dofs, E0, H0 = _chain(30, 21, shift=0.02)
    chain = ChainCholesky(dofs, (VERTEX_A, VERTEX_B), INTERIOR)
    rng = np.random.default_rng(21)
    shifts = [0.0, -0.03, 0.01, -0.002, 0.05, -0.06, 0.004]
    E = np.stack([E0 + s * np.eye(7) for s in shifts])
    cons = [np.sort(rng.choice(dofs[:, VERTEX_A].ravel(), k, replace=False)) for k in
            (0, 2, 1, 3, 0, 2, 1)]
    Hs = [H0 + s * np.where(np.eye(len(H0)) > 0, _multiplicity(dofs, len(H0)), 0.0)
          for s in shifts]
    lows = [_scaled_lowest(H, c) for H, c in zip(Hs, cons, strict=True)]
    got = chain.definite(E, np.ones((7, 1)), list(range(7)), cons, 0.0)
    assert got == [low > 0 for low in lows], (got, lows)
    assert True in got and False in got
    pos = sorted(low for low in lows if low > 0)
    margin = 0.5 * (pos[1] + pos[2])  # between two of them: both answers among the definite
    got = chain.definite(E, np.ones((7, 1)), list(range(7)), cons, margin)
    assert got == [low > margin for low in lows], (got, lows)
    assert got.count(True) == len(pos) - 2


def _multiplicity(dofs: np.ndarray, n: int) -> np.ndarray:
    """How many cells hold each DOF (a shift of every element's diagonal adds that many)."""
    out = np.zeros(n)
    np.add.at(out, dofs.ravel(), 1.0)
    return out


def test_chain_refuses_what_it_cannot_test():
    """Cells that do not form one chain (a vertex shared by three cells), a constrained
    interior DOF, a NaN: refused (ValueError), or answered False."""
    dofs, E, _ = _chain(10, 1, shift=0.5)
    bad = dofs.copy()
    bad[3, VERTEX_A] = bad[7, VERTEX_A]  # cells 3 and 7 now share a vertex with others
    with pytest.raises(ValueError):
        ChainCholesky(bad, (VERTEX_A, VERTEX_B), INTERIOR)
    chain = ChainCholesky(dofs, (VERTEX_A, VERTEX_B), INTERIOR)
    with pytest.raises(ValueError):
        chain.definite(E[None], ONE, [-1], [dofs[0, INTERIOR][:1]], 0.0)
    E[4, 1, 1] = np.nan
    assert chain.definite(E[None], ONE, [-1], [np.zeros(0, dtype=np.int64)], 0.0) == [False]


def _constrained_dense(H: np.ndarray, constrained: np.ndarray) -> np.ndarray:
    H = H.copy()
    H[constrained, :] = 0.0
    H[:, constrained] = 0.0
    H[constrained, constrained] = 1.0
    return H


def test_inertia_is_that_of_the_dense_eigenvalues():
    """Indefinite chains (positive definite interiors, vertex diagonals shifted down: from 1
    to about 20 negative eigenvalues), with and without constrained vertex DOFs: where
    ``inertia`` vouches for its count, (negative, zero, positive) is the dense eigenvalues'
    (none lies within 1e-4 of 0: the count is not round-off's); it vouches for every chain
    with few negative eigenvalues (as the 1D model's blocks have) and for most others. An
    unpivoted LDLᵀ of a random matrix with many negative eigenvalues meets a small pivot now
    and then: refused, for MUMPS."""
    vouched, total = 0, 0
    for seed in range(12):
        for shift in (0.4, 0.5, 0.6):
            dofs, E, _ = _chain(40, 100 + seed, shift=0.3)
            E = E.copy()
            vertex = VERTEX_A + VERTEX_B
            E[:, vertex, vertex] -= shift
            H = np.zeros((dofs.max() + 1,) * 2)
            for c in range(len(dofs)):
                H[np.ix_(dofs[c], dofs[c])] += E[c]
            chain = ChainCholesky(dofs, (VERTEX_A, VERTEX_B), INTERIOR)
            rng = np.random.default_rng(seed)
            for constrained in (np.zeros(0, dtype=np.int64),
                                np.sort(rng.choice(dofs[:, VERTEX_B].ravel(), 3, replace=False))):
                lam = np.linalg.eigvalsh(_constrained_dense(H, constrained))
                assert np.min(np.abs(lam)) > 1e-4
                want = (int(np.sum(lam < 0)), 0, int(np.sum(lam > 0)))
                got = chain.inertia(E[None], ONE, -1, constrained, 100.0)
                assert got in (want, None), (seed, shift, got, want)
                if shift == 0.4:
                    assert got == want
                total += 1
                vouched += got is not None
    assert vouched >= 0.6 * total


@pytest.mark.parametrize("delta, vouched", [(0.5, True), (1e-3, False), (1e-8, False)])
def test_inertia_refuses_growth(delta, vouched):
    """A chain whose vertex blocks are [[δ, 1], [1, δ]] (interiors the identity): each has one
    negative eigenvalue, and the unpivoted LDLᵀ's first pivot δ makes |L||D||Lᵀ| grow as
    1/δ². Vouched for (the exact count) at δ = 1/2, where the growth is 7; refused (None:
    MUMPS decides) at δ = 1e-3 and 1e-8; a NaN is refused too."""
    ncells = 12
    dofs, _, _ = _chain(ncells, 3, shift=1.0)
    pair = np.array([[delta, 1.0], [1.0, delta]])
    E = np.zeros((ncells, 7, 7))
    E[:, INTERIOR, INTERIOR] = 1.0
    for c in range(ncells):  # each vertex gets half from each of its cells
        for rows in (VERTEX_A, VERTEX_B):
            E[c][np.ix_(rows, rows)] = 0.5 * pair
    H = np.zeros((dofs.max() + 1,) * 2)
    for c in range(ncells):
        H[np.ix_(dofs[c], dofs[c])] += E[c]
    lam = np.linalg.eigvalsh(H)
    want = (int(np.sum(lam < 0)), 0, int(np.sum(lam > 0)))
    assert want[0] == ncells + 1  # one per chain vertex
    chain = ChainCholesky(dofs, (VERTEX_A, VERTEX_B), INTERIOR)
    none = np.zeros(0, dtype=np.int64)
    got = chain.inertia(E[None], ONE, -1, none, 100.0)
    assert got == (want if vouched else None)
    E[5, 0, 0] = np.nan
    assert chain.inertia(E[None], ONE, -1, none, 100.0) is None


def test_solves_are_those_of_the_dense_matrix():
    """``ChainCholesky.factor`` (interior Cholesky, vertex banded LU): x = H^-1 b of an
    indefinite chain (10 negative eigenvalues), with and without constrained vertex DOFs
    (unit rows and columns: x = b there), to 1e-13 of the dense solve."""
    dofs, E, _ = _chain(40, 5, shift=0.3)
    E = E.copy()
    vertex = VERTEX_A + VERTEX_B
    E[:, vertex, vertex] -= 0.5
    H = np.zeros((dofs.max() + 1,) * 2)
    for c in range(len(dofs)):
        H[np.ix_(dofs[c], dofs[c])] += E[c]
    chain = ChainCholesky(dofs, (VERTEX_A, VERTEX_B), INTERIOR)
    rng = np.random.default_rng(0)
    for constrained in (np.zeros(0, dtype=np.int64),
                        np.sort(rng.choice(dofs[:, VERTEX_B].ravel(), 3, replace=False))):
        Hc = _constrained_dense(H, constrained)
        assert np.sum(np.linalg.eigvalsh(Hc) < 0) >= 5
        f = chain.factor(E[None], ONE, -1, constrained)
        assert f is not None and f.ok
        b = rng.standard_normal(len(H))
        x = np.zeros_like(b)
        f.solve(b, x)
        want = np.linalg.solve(Hc, b)
        assert np.linalg.norm(x - want) < 1e-13 * np.linalg.norm(want) * np.linalg.cond(Hc)
        assert np.linalg.norm(x - want) < 1e-12 * np.linalg.norm(want)
        assert np.array_equal(x[constrained], b[constrained])


def test_blocks_combined_from_several_forms_are_those_combined_beforehand():
    """Blocks Σ_k w_k E_k and a form of their own, in one call, answer as each matrix
    combined beforehand: the combination in the C loop is the sum it should be."""
    dofs, E0, _ = _chain(30, 11, shift=0.03)
    E1 = _chain(30, 12, shift=-0.02)[1]  # element values only (any symmetric matrices)
    chain = ChainCholesky(dofs, (VERTEX_A, VERTEX_B), INTERIOR)
    E = np.stack([E0, E1, E0 - 3.0 * E1])
    none = np.zeros(0, dtype=np.int64)
    weights = np.array([[1.0, 0.0], [1.0, 0.5], [1.0, -3.0], [0.0, 1.0], [0.0, 0.0]])
    own = [-1, -1, -1, -1, 2]
    for margin in (0.0, 1e-3, 1e-2):
        got = chain.definite(E, weights, own, [none] * 5, margin)
        want = [chain.definite((w[0] * E0 + w[1] * E1)[None], ONE, [-1], [none], margin)[0]
                for w in weights[:4]]
        want.append(chain.definite(E[2][None], ONE, [-1], [none], margin)[0])
        assert got == want, (margin, got, want)
    assert True in got and False in got  # both answers occur


def test_without_the_compiled_loop_the_assembled_path_finds_the_same_point(monkeypatch):
    """Where the C loop cannot be built (here: an unwritable cache folder), the 1D model keeps
    the assembled blocks (banded Cholesky, MUMPS) and finds the same critical point: the 30°
    cap's m = 2 bifurcation going down (h/R = 0.04) within its reported accuracy."""
    import math
    from pathlib import Path

    from shells.analyses import axisym_runs
    from shells.axisym import chain
    from shells.geometry.shapes import SphericalCap

    cap = SphericalCap(1.0, math.radians(30))
    fast = axisym_runs.critical(cap, 0.04, 0.5, direction="down", max_critical=1)
    chain.unload()
    monkeypatch.setattr(chain, "cache_dir", lambda: Path("/proc/no-such-folder/shells"))
    with pytest.raises(OSError):
        chain.library()
    slow = axisym_runs.critical(cap, 0.04, 0.5, direction="down", max_critical=1)
    assert not chain.loaded()  # the run never had the loop: the assembled path
    a, b = fast["critical_points"][0], slow["critical_points"][0]
    assert (a["kind"], a["mode_m"]) == (b["kind"], b["mode_m"]) == ("bifurcation", 2)
    assert abs(a["kappa_R"] - b["kappa_R"]) <= max(a["accuracy"], b["accuracy"], 1e-9)
    assert abs(a["kappa_R"] / -0.6622 - 1) < 1e-3
