"""Stability of an equilibrium: inertia (MUMPS LDLᵀ) and eigenpairs nearest 0 (SLEPc) of a
problem's stability blocks (algorithm layer, on ``shells.problem.interface.Problem``).

A block is the Hessian (the surface model: one block, ``None``) or one of its Fourier blocks H_m
(the axisymmetric model: block m); the problem assembles it at its current state, with unit rows
on its constrained DOFs, and its mass matrix with a tiny diagonal there, so the constrained DOFs'
eigenvalues sit far above the spectrum of interest and add only positive pivots to the inertia.
Blocks of equal ``block_layout`` share one matrix and one factor (the symbolic factorisation is
reused between them).

Facts used (petsc4py 3.22): ``getInertia`` needs MUMPS ICNTL(24) = 1 (null pivot detection);
ICNTL(13) = 1 keeps the inertia correct in parallel (no ScaLAPACK root); indefinite matrices want
ICNTL(14) (workspace) near 200; ``Mat.getInfo`` is collective. Options prefixes:
``shells_inertia_`` (the factorisation), ``shells_eigen_`` (the EPS; ``-shells_eigen_eps_view``
works), see ``shells.algorithms.newton``.

A positive definite block needs no LDLᵀ: on one process, a block whose matrix is banded after a
band-reducing ordering (``_band_ordering``; the 1D model's Fourier blocks: half-bandwidth 20)
is first tested by LAPACK's banded Cholesky (``dpbtrf``) of H - τ diag(H), τ =
``DEFINITE_MARGIN``. Success proves the inertia (0, 0, n): Cholesky is backward stable, so it
succeeds only if the diagonally scaled matrix D^-1/2 H D^-1/2 has no eigenvalue below τ minus
a round-off of order kd ε (kd the half-bandwidth, ε the unit round-off; 2e-15 at kd = 20),
well inside the margin, while MUMPS' own inertia is decided by round-off only far below it.
Any block that fails the test (indefinite, singular, or merely within τ of singular: the
crossing block next to a critical point) gets an exact count: MUMPS', or the problem's own
where it vouches for it (``block_inertia``: the 1D model's unpivoted LDLᵀ of the condensed
block within a growth bound, ``LDLT_GROWTH``), so every count reported is that of a backward
stable factorisation or of a block definite by a margin. The test is cheaper than the
factorisation it replaces and leaves every count as MUMPS gives it (tests/test_stability.py
compares them block by block; docs/design-notes.md, "Definiteness before inertia").
A problem may decide the same test itself without assembling its blocks
(``definite_blocks``, ``shells.problem.interface``): the 1D model on one process factors its
element matrices condensed on the meridian's chain of cells (``shells.axisym.chain``; docs/model.md,
"Stability and critical points"). The eigensolves' shift-invert likewise applies the
problem's own factorisation where it has one (``block_factor``, through a python PC).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Hashable, Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from shells.algorithms.newton import (
    EIGEN_PREFIX,
    INERTIA_PREFIX,
    apply_options,
    configure_factor,
    setup_factor,
)
from shells.problem.interface import (
    BlockFactor,
    BlockInertia,
    BlockInertias,
    CondensedHessian,
    DefiniteBlocks,
    HessianQuadratic,
)

__all__ = ["Stability", "StabilityResult", "rayleigh_quotient"]

log = logging.getLogger("shells")

INERTIA_OPTIONS: dict[str, Any] = {
    "ksp_type": "preonly",
    "pc_type": "cholesky",
    "pc_factor_mat_solver_type": "mumps",
    "mat_mumps_icntl_24": 1,
    "mat_mumps_icntl_13": 1,
    "mat_mumps_icntl_14": 200,
}


@dataclass
class StabilityResult:
    """Stability of one state: stable iff the Hessian has no negative eigenvalue."""

    stable: bool
    negative_count: int
    zero_count: int
    eigenvalues: list[float] = field(default_factory=list)
    modes: list[Any] | None = None
    #: the negative count of each block (``critical.follow``); None where not computed
    counts: dict[Hashable, int] | None = None

    def as_dict(self) -> dict[str, Any]:
        """The scalars and eigenvalues (JSON-ready); modes and counts are left out."""
        return {"stable": self.stable, "negative_count": self.negative_count,
                "zero_count": self.zero_count, "eigenvalues": list(self.eigenvalues)}


#: a block is positive definite without an LDLᵀ when the banded Cholesky of H - τ diag(H)
#: succeeds, τ this margin (relative: the lowest eigenvalue of the diagonally scaled H), which
#: lies between the Cholesky's round-off (~1e-15) and the lowest scaled eigenvalues of definite
#: blocks on a loaded branch (1e-12 and above on the 1D model)
DEFINITE_MARGIN = 1.0e-13
#: a problem's own LDLᵀ without pivoting (``block_inertia``) decides a count only if the
#: diagonal of |L||D||Lᵀ| stays below this many times the matrix's: its backward error is then
#: below (kd + 1) ε times this of the diagonally scaled matrix (3e-13 at kd = 11), no larger
#: than the perturbation the banded test's margin allows (``DEFINITE_MARGIN``) times a few
LDLT_GROWTH = 100.0
#: the banded test is used up to this half-bandwidth (after ordering): its cost grows as n kd², a
#: surface model's mesh has hundreds
MAX_BANDWIDTH = 64


class BandedCholesky:
    """Positive definiteness (by a margin) of a sequential sparse symmetric matrix of a fixed
    nonzero pattern: its lower triangle in the ordering of ``_band_ordering``, written into
    LAPACK's band storage, factored by ``dpbtrf``."""

    def __init__(self, ai: np.ndarray, aj: np.ndarray) -> None:
        n = len(ai) - 1
        self.ai, self.aj = ai.copy(), aj.copy()
        rows = np.repeat(np.arange(n), np.diff(ai))
        inv = _band_ordering(n, rows, ai, aj)
        i, j = inv[rows], inv[aj]
        self.lower = np.nonzero(i >= j)[0]  # the entries read (one triangle)
        i, j = i[self.lower], j[self.lower]
        self.kd = int(np.max(i - j)) if len(i) else 0
        self.n = n
        # band storage ab[i - j, j] (lower), Fortran order: flat index (i - j) + j (kd + 1)
        self.index = (i - j) + j * (self.kd + 1)
        self.diagonal = np.nonzero(rows == aj)[0]
        self.has_diagonal = len(self.diagonal) == n

    def matches(self, ai: np.ndarray, aj: np.ndarray) -> bool:
        """Whether the CSR pattern (``ai``, ``aj``) is the one this test was built for."""
        return (len(ai) == len(self.ai) and len(aj) == len(self.aj)
                and np.array_equal(ai, self.ai) and np.array_equal(aj, self.aj))

    def definite(self, values: np.ndarray, margin: float) -> bool:
        """True if H - ``margin`` diag(H) has a Cholesky factor (then H is positive
        definite); False if not, or if a diagonal entry is not positive."""
        from scipy.linalg import lapack

        d = values[self.diagonal]
        if not (self.has_diagonal and np.all(d > 0) and np.isfinite(values).all()):
            return False
        buf = np.zeros((self.kd + 1) * self.n)  # dpbtrf overwrites the whole band: a new one
        buf[self.index] = values[self.lower]
        buf[:: self.kd + 1] *= 1.0 - margin  # the diagonal: band row 0 (the same product)
        ab = buf.reshape(self.n, self.kd + 1).T  # (kd + 1, n), Fortran-contiguous
        _, info = lapack.dpbtrf(ab, lower=1, overwrite_ab=1)
        return int(info) == 0


def _band_ordering(n: int, rows: np.ndarray, ai: np.ndarray, aj: np.ndarray) -> np.ndarray:
    """The new index of each row: of the natural order, reverse Cuthill-McKee and a level
    ordering, the one of least half-bandwidth. The level ordering sorts each connected
    component by the distance (in the matrix graph) from a far node, then by the mean distance
    of the row's neighbours: on a 1D mesh's chain of element cliques (the 1D model's cells:
    two vertices' DOFs and the interior DOFs between them) it puts each cell's interior DOFs
    between its vertices' and reaches the element's width, half-bandwidth 20 for P3³ x P2³,
    where RCM gives 35 and the natural order 32 (a banded Cholesky costs n kd²)."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import (
        connected_components,
        reverse_cuthill_mckee,
        shortest_path,
    )

    graph = csr_matrix((np.ones(len(aj)), aj, ai), shape=(n, n))
    _, comp = connected_components(graph, directed=False)
    level = np.zeros(n)
    for c in np.unique(comp):
        first = int(np.nonzero(comp == c)[0][0])
        d = shortest_path(graph, unweighted=True, directed=False, indices=first)
        far = int(np.argmax(np.where(np.isfinite(d), d, -1.0)))
        d = shortest_path(graph, unweighted=True, directed=False, indices=far)
        level[comp == c] = d[comp == c]
    near = np.zeros(n)
    np.add.at(near, rows, level[aj])
    near /= np.maximum(np.diff(ai), 1)
    candidates = [np.arange(n), np.asarray(reverse_cuthill_mckee(graph, symmetric_mode=True)),
                  np.lexsort((near, level, comp))]
    best, best_kd = None, None
    for perm in candidates:
        inv = np.empty(n, dtype=np.int64)
        inv[perm] = np.arange(n)
        kd = int(np.max(np.abs(inv[rows] - inv[aj]))) if len(aj) else 0
        if best_kd is None or kd < best_kd:
            best, best_kd = inv, kd
    return best


def rayleigh_quotient(q: float | None, M: Any, v: Any, mu: float) -> float:
    """The Rayleigh quotient q / vᵀ M v (q = vᵀ H v); ``mu`` where q is None or the quotient
    is not finite. M's tiny diagonal on constrained DOFs, where the eigenvector vanishes to
    round-off, adds at most 1e-12 of their squares."""
    if q is None:
        return mu
    Mv = M.createVecLeft()
    try:
        M.mult(v, Mv)
        norm = v.dot(Mv)
    finally:
        Mv.destroy()
    out = q / norm if norm > 0 else math.nan
    return out if math.isfinite(out) else mu


class _Inertia:
    """MUMPS' LDLᵀ of one matrix object (under the inertia prefix, configured once): its
    inertia after each change of values, the symbolic factorisation kept."""

    def __init__(self, A: Any, options: dict[str, Any]) -> None:
        from petsc4py import PETSc

        self.ksp = PETSc.KSP().create(A.getComm())
        self.options = apply_options(self.ksp, INERTIA_PREFIX, options)
        configure_factor(self.ksp, A, self.options)

    def of(self, A: Any) -> tuple[int, int, int] | None:
        """(negative, zero, positive) of A (the configured object), None if it cannot be
        factored."""
        self.ksp.setOperators(A)  # same object as configured: keeps the MUMPS controls
        if not setup_factor(self.ksp, A, self.options):
            return None
        neg, zero, pos = self.ksp.getPC().getFactorMatrix().getInertia()
        return int(neg), int(zero), int(pos)

    def destroy(self) -> None:
        self.ksp.destroy()


class _ProblemSolve:
    """The PC (petsc4py's python type) of the eigensolves that use a problem's own
    factorisation (``block_factor``): applies ``solver``, set before each solve."""

    def __init__(self) -> None:
        self.solver: Any = None

    def setUp(self, pc: Any) -> None:  # noqa: N802 - petsc4py's name
        pass

    def apply(self, pc: Any, x: Any, y: Any) -> None:
        self.solver.solve(x.array_r, y.array_w)


class BlockSolvers:
    """The matrix and LDLᵀ factor of one block layout, and its banded Cholesky test."""

    def __init__(self, problem: Any, block: Hashable, options: dict[str, Any]) -> None:
        self.H = problem.create_hessian(block)
        self.factor = _Inertia(self.H, options)
        self.M: dict[Hashable, Any] = {}
        # the banded test applies: on one process, and (once H's pattern is seen) to a band
        # no wider than MAX_BANDWIDTH
        self.testable = problem.comm.size == 1
        self.banded: BandedCholesky | None = None
        self.eps: Any = None  # the layout's eigensolver (``eigensolver``), made on first use
        self.shell_eps: Any = None  # the one with the problem's factorisation (``_ProblemSolve``)
        self.shell = _ProblemSolve()
        self._seed = 0
        self.user_options = False

    def eigensolver(self, shell: bool = False) -> Any:
        """The layout's SLEPc EPS: shift-invert about 0 with MUMPS, for H v = μ M v (GHEP).

        Made once and reused by every eigensolve of the layout's blocks: reuse keeps the
        factorisation's symbolic analysis and the EPS's set-up between solves (docs/model.md,
        "Stability and critical points"); its random start vector is reseeded before each
        solve (``eigenpairs``), so a solve does not depend on the solves before it.

        Args:
            shell: the layout's second EPS, whose shift-invert applies ``self.shell`` (a
                problem's own factorisation) instead of MUMPS; the same settings otherwise.

        Returns:
            The EPS, created on first use.
        """
        from petsc4py import PETSc

        if shell:
            if self.shell_eps is None:
                self.shell_eps = self._new_eps(shell=True)
            return self.shell_eps
        if self.eps is None:
            eps = self._new_eps(shell=False)
            eps.setOptionsPrefix(EIGEN_PREFIX)
            eps.setFromOptions()  # the user's -shells_eigen_... options
            self._seed = eps.getBV().getRandomContext().getSeed()
            # a user's options, if any, override the dimensions set per solve (as on a new EPS)
            self.user_options = any(k.startswith(EIGEN_PREFIX)
                                    for k in PETSc.Options().getAll())
            self.eps = eps
        return self.eps

    def _new_eps(self, shell: bool) -> Any:
        from slepc4py import SLEPc

        eps = SLEPc.EPS().create(self.H.getComm())
        eps.setProblemType(SLEPc.EPS.ProblemType.GHEP)
        eps.setTarget(0.0)
        eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_REAL)
        st = eps.getST()
        st.setType(SLEPc.ST.Type.SINVERT)
        st.setShift(0.0)
        ksp = st.getKSP()
        ksp.setType("preonly")
        pc = ksp.getPC()
        if shell:
            pc.setType("python")
            pc.setPythonContext(self.shell)
        else:
            pc.setType("lu")
            pc.setFactorSolverType("mumps")
        eps.setTolerances(1e-10, 200)
        return eps

    def definite(self, margin: float) -> bool:
        """Whether H as assembled is positive definite by ``margin`` (``BandedCholesky``).

        Args:
            margin: τ of the test H - τ diag(H).

        Returns:
            The test's answer; False where the test does not apply (in parallel, a wide
            band).
        """
        if not self.testable:
            return False
        ai, aj, values = self.H.getValuesCSR()
        if self.banded is None or not self.banded.matches(ai, aj):
            self.banded = BandedCholesky(ai, aj)
            # a wide band stays wide: the layout's matrix keeps its pattern
            self.testable = self.banded.kd <= MAX_BANDWIDTH
        return self.testable and self.banded.definite(values, margin)

    def destroy(self) -> None:
        for o in (self.eps, self.shell_eps, self.factor, self.H, *self.M.values()):
            if o is not None:
                o.destroy()


class Stability:
    """Inertia and eigenpairs of a problem's stability blocks at its current state.

    Args:
        problem: the problem whose blocks are analysed.
        options: options of the LDLᵀ factorisation over ``INERTIA_OPTIONS`` (prefix
            ``shells_inertia_``).
    """

    #: test blocks for definiteness by banded Cholesky before any LDLᵀ (module docstring);
    #: False: MUMPS for every block (the reference the benchmark compares with)
    banded_test: bool = True

    def __init__(self, problem: Any, options: dict[str, Any] | None = None) -> None:
        self.problem = problem
        self.options = {**INERTIA_OPTIONS, **(options or {})}
        self._blocks: dict[Hashable, BlockSolvers] = {}
        self._condensed: dict[int, _Inertia] = {}  # ``exact_inertia``'s, by matrix
        #: how many inertias the banded test decided, the problem's own LDLᵀ, and MUMPS
        self.calls = {"banded": 0, "ldlt": 0, "mumps": 0}
        #: the blocks with a negative eigenvalue at the last ``negative_counts`` of all
        self._negative: set[Hashable] = set()

    def blocks(self) -> tuple[Hashable, ...]:
        """All of the problem's stability blocks."""
        return tuple(self.problem.stability_blocks())

    @property
    def rayleigh_quotients(self) -> bool:
        """Whether ``eigenpairs`` (``refine`` True) gives Rayleigh quotients by quadrature: the
        problem has ``hessian_quadratic``."""
        return isinstance(self.problem, HessianQuadratic)

    def block_solvers(self, block: Hashable) -> BlockSolvers:
        """The solvers (matrix, factorisation, eigensolver) shared by ``block``'s layout,
        created on first use."""
        key = self.problem.block_layout(block)
        if key not in self._blocks:
            self._blocks[key] = BlockSolvers(self.problem, block, self.options)
        return self._blocks[key]

    def assemble(self, block: Hashable = None) -> Any:
        """The block's Hessian at the current state (the shared matrix of its layout)."""
        b = self.block_solvers(block)
        self.problem.assemble_hessian(block, b.H)
        return b.H

    def inertia(self, block: Hashable = None, test: bool = True) -> tuple[int, int, int]:
        """The inertia of the block's Hessian, assembled at the current state.

        Args:
            block: the block.
            test: try the banded definiteness test first; False: MUMPS' count without it
                (the caller's test failed on these values already).

        Returns:
            (negative, zero, positive) eigenvalue counts.

        Raises:
            RuntimeError: if the LDLᵀ factorisation fails.
        """
        b = self.block_solvers(block)
        self.problem.assemble_hessian(block, b.H)
        if test and self.banded_test and b.definite(DEFINITE_MARGIN):
            self.calls["banded"] += 1
            return 0, 0, int(b.H.getSize()[0])
        self.calls["mumps"] += 1
        counts = b.factor.of(b.H)
        if counts is None:
            raise RuntimeError(f"the Hessian's LDL^T factorisation failed (block {block}): "
                               "no inertia")
        return counts

    def exact_inertia(self, block: Hashable) -> tuple[int, int, int]:
        """The exact inertia of a block known not to be definite by the margin.

        The problem's own where it vouches for it (``block_inertia``: the 1D model's unpivoted
        LDLᵀ of the condensed block, growth below ``LDLT_GROWTH``), else MUMPS' of the
        problem's condensed matrix where it offers one (``condensed_hessian``: a Schur
        complement, the same inertia but for the positive eigenvalues of the eliminated DOFs,
        and a smaller matrix), else of the assembled block.

        Args:
            block: the block.

        Returns:
            (negative, zero, positive) eigenvalue counts.

        Raises:
            RuntimeError: if every factorisation fails.
        """
        if isinstance(self.problem, BlockInertia):
            counts = self.problem.block_inertia(block, LDLT_GROWTH)
            if counts is not None:
                self.calls["ldlt"] += 1
                return counts
        cond = (self.problem.condensed_hessian(block)
                if isinstance(self.problem, CondensedHessian) else None)
        if cond is None:
            return self.inertia(block, test=False)
        S, eliminated = cond
        if id(S) not in self._condensed:  # the problem keeps S: one factor per matrix object
            self._condensed[id(S)] = _Inertia(S, self.options)
        self.calls["mumps"] += 1
        counts = self._condensed[id(S)].of(S)
        if counts is None:
            return self.inertia(block, test=False)
        neg, zero, pos = counts
        return neg, zero, pos + int(eliminated)

    def negative_count(self, block: Hashable = None) -> int:
        """The block's number of negative eigenvalues (``inertia``)."""
        return self.inertia(block)[0]

    def negative_counts(self, blocks: Iterable[Hashable] | None = None,
                        base: dict[Hashable, int] | None = None) -> dict[Hashable, int]:
        """The negative count of every block.

        A problem that tests its blocks' definiteness without assembling them
        (``definite_blocks(blocks, margin)``: {block: bool}, the same test as the banded
        Cholesky's; the 1D model on one process) has that answer used first: a block definite
        by the margin is not assembled at all (its matrix is then not the block's: call
        ``inertia`` before ``eigenpairs(assemble=False)``), one that is not goes straight to
        MUMPS (or to the problem's own exact count, ``block_inertia``; several at once with
        ``block_inertias``). A block negative at the last count of all (``base`` None) skips
        the test. The counts do not depend on either shortcut.

        Args:
            blocks: the blocks (default: all of the problem's).
            base: stop after the first block (in the given order) whose count differs from
                ``base[block]``.

        Returns:
            {block: negative count}, up to that block with ``base``.
        """
        blocks = self.blocks() if blocks is None else tuple(blocks)
        test = self.banded_test and isinstance(self.problem, DefiniteBlocks)
        # a block that had a negative eigenvalue at the last count is not tested for
        # definiteness (the test would fail and cost time): its exact count straight away,
        # which is 0 if it has become definite
        decided: dict[Hashable, bool] = {}
        if test:
            negative = [b for b in blocks if b in self._negative]
            rest = [b for b in blocks if b not in negative]
            tested = self.problem.definite_blocks(rest, DEFINITE_MARGIN) if rest else {}
            if tested or (tested is not None and not rest):  # the test applies (one process)
                decided = {**tested, **dict.fromkeys(negative, False)}
        exact: dict[Hashable, int] = {}
        failing = [b for b in blocks if b in decided and not decided[b]]
        if base is None and len(failing) > 1 and isinstance(self.problem, BlockInertias):
            # their exact counts together (the 1D model: condensed four at a time)
            for b, counts in (self.problem.block_inertias(failing, LDLT_GROWTH) or {}).items():
                if counts is not None:
                    self.calls["ldlt"] += 1
                    exact[b] = counts[0]
        out = {}
        for blk in blocks:
            if decided.get(blk):
                self.calls["banded"] += 1
                out[blk] = 0
            elif blk in decided:  # not definite by the margin: the exact count
                out[blk] = exact[blk] if blk in exact else self.exact_inertia(blk)[0]
            else:  # not decided: the banded test first
                out[blk] = self.inertia(blk)[0]
            if base is not None and out[blk] != base[blk]:
                break
        if base is None:
            self._negative = {b for b, c in out.items() if c > 0}
        return out

    def mass(self, block: Hashable = None) -> Any:
        """The block's mass matrix (assembled once, kept)."""
        b = self.block_solvers(block)
        if block not in b.M:
            b.M[block] = self.problem.assemble_mass(block)
        return b.M[block]

    def eigenpairs(self, nev: int = 6, *, modes: bool = False, assemble: bool = True,
                   block: Hashable = None, ncv: int | None = None, refine: bool = True
                   ) -> tuple[list[float], list[Any]]:
        """The eigenvalues of H v = μ M v nearest 0 of a block (M: its mass).

        Where the problem evaluates vᵀ H v by quadrature (``hessian_quadratic``), each
        eigenvalue is its eigenvector's Rayleigh quotient vᵀ H v / vᵀ M v (``refine``): the
        shift-invert's μ carries the round-off of the assembled matrix and of its
        factorisation, ε ‖H‖ (large on the 1D model's stiff blocks), the quotient only that
        of the mode's own energy, and its error in the vector is of second order
        (docs/model.md, "Stability and critical points"; ``benchmarks/locator_noise.py``).
        Where the shift-invert applies the problem's own factorisation (``block_factor``),
        which reads no value of the block's matrix, that matrix is not assembled at all (it
        keeps its last values).

        Args:
            nev: how many eigenvalues (at most the block's size).
            modes: also return the eigenvectors.
            assemble: False: use the block's matrix as last assembled (by ``inertia``).
            block: the block.
            ncv: the Krylov subspace's size (default max(2 nev + 10, 24); its cost grows with
                it, and a solve converges in one restart at the default).
            refine: Rayleigh quotients where the problem has ``hessian_quadratic``.

        Returns:
            (eigenvalues ascending, their eigenvectors or []). Fewer than ``nev`` if SLEPc
            converged fewer (logged as a warning).

        Raises:
            petsc4py.PETSc.Error: if the solve fails (an exactly singular block); the
                layout's EPS is then replaced at the next solve.
        """
        eps, H, nev = self._solve_eigenproblem(block, nev, ncv, assemble)
        return self._eigenpairs_of(eps, H, nev, block, modes, refine)

    def _solve_eigenproblem(self, block: Hashable, nev: int, ncv: int | None,
                            assemble: bool) -> tuple[Any, Any, int]:
        """The shift-invert solve of ``eigenpairs`` (its arguments).

        Returns:
            (the solved EPS, the block's matrix H, nev bounded by the block's size).

        Raises:
            petsc4py.PETSc.Error: as ``eigenpairs``.
        """
        b = self.block_solvers(block)
        eps = b.eigensolver()
        # the problem's own factorisation where it has one (``block_factor``; not with a
        # user's eigensolver options, nor in the reference mode without the banded test)
        solver = (self.problem.block_factor(block)
                  if self.banded_test and not b.user_options
                  and isinstance(self.problem, BlockFactor) else None)
        # the shift-invert about 0 with the problem's factorisation reads no value of H (SLEPc
        # takes A - 0 B as A, and the KSP applies the shell alone): H is assembled for MUMPS
        # only, or where it never was (its layout and vectors); eigenvalues bit for bit the
        # same. ``b.H`` then keeps the values last assembled (``BlockSolvers``)
        H = (self.assemble(block) if assemble and (solver is None or not b.H.assembled)
             else b.H)
        if solver is not None:
            b.shell.solver = solver
            eps = b.eigensolver(shell=True)
        eps.setOperators(H, self.mass(block))  # new values: a numeric refactorisation
        size = H.getSize()[0]  # a tiny problem cannot have more than its size
        nev = min(nev, size)
        ncv = max(2 * nev + 10, 24) if ncv is None else max(int(ncv), nev + 1)
        # mpd too: a reused EPS keeps the mpd its first set-up derived from that call's ncv,
        # and a later, larger nev then fails SLEPc's check ncv <= nev + mpd (as the orbit
        # count's n + 1 pairs after a smaller solve did)
        eps.setDimensions(nev=nev, ncv=min(ncv, size), mpd=min(ncv, size))
        if b.user_options:
            eps.setFromOptions()
        rand = eps.getBV().getRandomContext()
        rand.setSeed(b._seed)  # the start vector of a new EPS, whatever was solved before
        try:
            eps.solve()
        except Exception:
            # a failed factorisation (an exactly singular block) leaves MUMPS unusable for the
            # next solve ("invalid JOB"): the next one starts from a new EPS
            if solver is None:
                b.eps = None
            else:
                b.shell_eps = None
            eps.destroy()
            raise
        if eps.getConverged() < nev:
            # the callers go on without the missing pairs (a critical point is then bracketed
            # by the inertia alone, its mode unnamed): say so
            log.warning("SLEPc: %d of the %d eigenpairs nearest 0 converged (reason %d, %d "
                        "iterations)", eps.getConverged(), nev, int(eps.getConvergedReason()),
                        eps.getIterationNumber())
        return eps, H, nev

    def _eigenpairs_of(self, eps: Any, H: Any, nev: int, block: Hashable, modes: bool,
                       refine: bool) -> tuple[list[float], list[Any]]:
        """The first ``nev`` converged pairs of the solved ``eps``, as ``eigenpairs`` returns
        them (Rayleigh quotients with ``refine``, eigenvectors with ``modes``)."""
        quadratic = (self.problem.hessian_quadratic if refine and self.rayleigh_quotients
                     else None)
        M = self.mass(block) if quadratic is not None else None
        vals, vecs = [], []
        # SLEPc orders the converged pairs by their distance to the target: the first nev
        # are those nearest 0 (it may converge more, which are neither wanted nor refined)
        for i in range(min(eps.getConverged(), nev)):
            mu = eps.getEigenvalue(i).real
            if modes or quadratic is not None:
                v = H.createVecRight()
                eps.getEigenvector(i, v)
                if quadratic is not None:
                    mu = rayleigh_quotient(quadratic(block, v), M, v, mu)
                if modes:
                    vecs.append(v)
                else:
                    v.destroy()
            vals.append(mu)
        order = np.argsort(vals, kind="stable")
        vals = [vals[i] for i in order]
        vecs = [vecs[i] for i in order] if modes else []
        return vals, vecs

    def negative_count_modulo_orbit(self, block: Hashable = None, threshold: float = 0.7,
                                    count: int | None = None) -> tuple[int, int]:
        """The negative count, and how many of those eigenvectors lie along the state's orbit.

        The orbit is the state's symmetry orbit: a pattern's rotation about the axis of a
        shell of revolution, a dimple's sliding over a closed sphere, neutral in the
        continuum and of either sign on a mesh. An eigenvector lies along it when the
        problem's overlap ``classify_mode(v).rayleigh["orbit"]`` is at least ``threshold``;
        the n + 1 eigenpairs nearest 0 are examined, n the negative count. The default
        threshold separates the orientation mode from the next modes along a buckled cap's
        branch (docs/model.md, "Symmetric meshes: perfect bifurcations").

        Args:
            block: the block.
            threshold: the least overlap of an orbit mode.
            count: the block's negative count where the caller has it already
                (``negative_counts``): a neutral mode's sign is round-off, and another
                factorisation may decide it otherwise.

        Returns:
            (negative count, orbit modes among them); the second is 0 for problems that
            report no orbit. Eigenpairs are computed only when the count is positive.
        """
        n = self.negative_count(block) if count is None else int(count)
        if n == 0:
            return 0, 0
        vals, vecs = self.eigenpairs(n + 1, modes=True, assemble=count is not None, block=block)
        orbit = 0
        try:
            # (the eigenvalues nearest 0 need not hold the negative ones the inertia counts:
            # a pair of positive orbit modes nearer 0 than the one negative eigenvalue, as on
            # the surface model's dimple branch, must not count)
            for val, v in zip(vals, vecs, strict=True):
                info = self.problem.classify_mode(v, block)
                if val < 0 and (info.rayleigh or {}).get("orbit", 0.0) >= threshold:
                    orbit += 1
        finally:
            for v in vecs:
                v.destroy()
        return n, orbit

    def check(self, nev: int = 0, modes: bool = False, block: Hashable = None
              ) -> StabilityResult:
        """Inertia (always) and eigenpairs nearest 0 of one block.

        Args:
            nev: how many eigenpairs (0: none).
            modes: keep the eigenvectors.
            block: the block.

        Returns:
            The ``StabilityResult``: stable iff no negative and no zero eigenvalue.
        """
        neg, zero, _ = self.inertia(block)
        vals, vecs = (self.eigenpairs(nev, modes=modes, assemble=False, block=block)
                      if nev > 0 else ([], []))
        return StabilityResult(stable=neg == 0 and zero == 0, negative_count=neg,
                               zero_count=zero, eigenvalues=vals, modes=vecs if modes else None)

    def destroy(self) -> None:
        """Free every layout's matrices, factors and eigensolvers."""
        for b in self._blocks.values():
            b.destroy()
        self._blocks.clear()
        for f in self._condensed.values():
            f.destroy()
        self._condensed.clear()
