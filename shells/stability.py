"""Stability of an equilibrium: inertia (MUMPS LDLᵀ) and eigenpairs nearest 0 (SLEPc) of a
problem's stability blocks (algorithm layer, on ``shells.problem.Problem``).

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
works), see ``shells.solvers``.
"""

from __future__ import annotations

import logging
from collections.abc import Hashable, Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from shells.solvers import (
    EIGEN_PREFIX,
    INERTIA_PREFIX,
    apply_options,
    configure_factor,
    setup_factor,
)

__all__ = ["StabilityResult", "Stability"]

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
        return {"stable": self.stable, "negative_count": self.negative_count,
                "zero_count": self.zero_count, "eigenvalues": list(self.eigenvalues)}


class _Block:
    """The matrix and LDLᵀ factor of one block layout."""

    def __init__(self, problem: Any, block: Hashable, options: dict[str, Any]) -> None:
        from petsc4py import PETSc

        self.H = problem.create_hessian(block)
        self.ksp = PETSc.KSP().create(problem.comm)
        self.options = apply_options(self.ksp, INERTIA_PREFIX, options)
        configure_factor(self.ksp, self.H, self.options)
        self.M: dict[Hashable, Any] = {}

    def destroy(self) -> None:
        for o in (self.ksp, self.H, *self.M.values()):
            o.destroy()


class Stability:
    """Inertia and eigenpairs of a problem's stability blocks at its current state."""

    def __init__(self, problem: Any, options: dict[str, Any] | None = None) -> None:
        self.problem = problem
        self.options = {**INERTIA_OPTIONS, **(options or {})}
        self._blocks: dict[Hashable, _Block] = {}

    def blocks(self) -> tuple[Hashable, ...]:
        return tuple(self.problem.stability_blocks())

    def _block(self, block: Hashable) -> _Block:
        key = self.problem.block_layout(block)
        if key not in self._blocks:
            self._blocks[key] = _Block(self.problem, block, self.options)
        return self._blocks[key]

    def assemble(self, block: Hashable = None) -> Any:
        """The block's Hessian at the current state (the shared matrix of its layout)."""
        b = self._block(block)
        self.problem.assemble_hessian(block, b.H)
        return b.H

    def inertia(self, block: Hashable = None) -> tuple[int, int, int]:
        """(negative, zero, positive) eigenvalue counts of the block's Hessian."""
        b = self._block(block)
        self.problem.assemble_hessian(block, b.H)
        b.ksp.setOperators(b.H)  # same object as configured: keeps the MUMPS controls
        if not setup_factor(b.ksp, b.H, b.options):
            raise RuntimeError(f"the Hessian's LDL^T factorisation failed (block {block}): "
                               "no inertia")
        neg, zero, pos = b.ksp.getPC().getFactorMatrix().getInertia()
        return int(neg), int(zero), int(pos)

    def negative_count(self, block: Hashable = None) -> int:
        return self.inertia(block)[0]

    def negative_counts(self, blocks: Iterable[Hashable] | None = None) -> dict[Hashable, int]:
        """The negative count of every block (default: all of the problem's blocks)."""
        return {b: self.negative_count(b) for b in (self.blocks() if blocks is None else blocks)}

    def mass(self, block: Hashable = None) -> Any:
        b = self._block(block)
        if block not in b.M:
            b.M[block] = self.problem.assemble_mass(block)
        return b.M[block]

    def eigenpairs(self, nev: int = 6, *, modes: bool = False, assemble: bool = True,
                   block: Hashable = None) -> tuple[list[float], list[Any]]:
        """The ``nev`` eigenvalues of H v = μ M v nearest 0 of a block (M: its mass),
        ascending, and with ``modes`` their eigenvectors. ``assemble=False``: the block's
        matrix as last assembled (by ``inertia``)."""
        from slepc4py import SLEPc

        H = self.assemble(block) if assemble else self._block(block).H
        eps = SLEPc.EPS().create(self.problem.comm)
        eps.setOperators(H, self.mass(block))
        eps.setProblemType(SLEPc.EPS.ProblemType.GHEP)
        size = H.getSize()[0]  # a tiny problem cannot have more than its size
        nev = min(nev, size)
        eps.setDimensions(nev=nev, ncv=min(max(2 * nev + 10, 24), size))
        eps.setTarget(0.0)
        eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_REAL)
        st = eps.getST()
        st.setType(SLEPc.ST.Type.SINVERT)
        st.setShift(0.0)
        ksp = st.getKSP()
        ksp.setType("preonly")
        pc = ksp.getPC()
        pc.setType("lu")
        pc.setFactorSolverType("mumps")
        eps.setTolerances(1e-10, 200)
        eps.setOptionsPrefix(EIGEN_PREFIX)
        eps.setFromOptions()  # the user's -shells_eigen_... options
        eps.solve()
        if eps.getConverged() < nev:
            # the callers go on without the missing pairs (a critical point is then bracketed
            # by the inertia alone, its mode unnamed): say so
            log.warning("SLEPc: %d of the %d eigenpairs nearest 0 converged (reason %d, %d "
                        "iterations)", eps.getConverged(), nev, int(eps.getConvergedReason()),
                        eps.getIterationNumber())
        vals, vecs = [], []
        for i in range(eps.getConverged()):
            vals.append(eps.getEigenvalue(i).real)
            if modes:
                v = H.createVecRight()
                eps.getEigenvector(i, v)
                vecs.append(v)
        order = np.argsort(vals)
        eps.destroy()
        vals = [vals[i] for i in order][:nev]
        vecs = [vecs[i] for i in order][:nev] if modes else []
        return vals, vecs

    def negative_count_modulo_orbit(self, block: Hashable = None, threshold: float = 0.7
                                    ) -> tuple[int, int]:
        """(negative count, how many of those eigenvectors lie along the state's symmetry
        orbit): ``classify_mode(v).rayleigh["orbit"]`` ≥ ``threshold``, the problem's overlap
        with the orbit tangent (a pattern's rotation about the axis of a shell of revolution,
        neutral in the continuum, of either sign on a mesh). The second is 0 for problems that
        report no orbit; eigenpairs are computed only when the count is positive. (Measured on
        the 30° cap's m = 2 branch, h/R = 0.04, size 0.25: the orientation mode's overlap falls
        from 0.92 next to the bifurcation to 0.82 at κR = -1.15, as the discrete orbit tangent
        departs from the continuum one; the next two modes stay below 0.38.)"""
        n = self.negative_count(block)
        if n == 0:
            return 0, 0
        vals, vecs = self.eigenpairs(n + 1, modes=True, assemble=False, block=block)
        orbit = 0
        try:
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
        """Inertia (always) and, with ``nev`` > 0, the eigenpairs nearest 0, of one block."""
        neg, zero, _ = self.inertia(block)
        vals, vecs = (self.eigenpairs(nev, modes=modes, assemble=False, block=block)
                      if nev > 0 else ([], []))
        return StabilityResult(stable=neg == 0 and zero == 0, negative_count=neg,
                               zero_count=zero, eigenvalues=vals, modes=vecs if modes else None)

    def destroy(self) -> None:
        for b in self._blocks.values():
            b.destroy()
        self._blocks.clear()
