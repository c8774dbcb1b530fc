"""Stability of an equilibrium: Hessian inertia (MUMPS LDLᵀ) and lowest eigenpairs (SLEPc).

The Hessian is the same ``ufl.derivative`` of the energy that Newton uses. Gauge DOFs (the six
rigid-motion constraints) get unit rows in H and a tiny mass, so their eigenvalues sit far above
the spectrum of interest and add only positive pivots to the inertia.

Facts used (petsc4py 3.22): ``getInertia`` needs MUMPS ICNTL(24) = 1 (null pivot detection);
ICNTL(13) = 1 keeps the inertia correct in parallel (no ScaLAPACK root); indefinite matrices want
ICNTL(14) (workspace) near 200; ``Mat.getInfo`` is collective.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from shells.solvers import apply_options, configure_factor, setup_factor

__all__ = ["StabilityResult", "Stability"]

_counter = itertools.count()

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

    def as_dict(self) -> dict[str, Any]:
        return {"stable": self.stable, "negative_count": self.negative_count,
                "zero_count": self.zero_count, "eigenvalues": list(self.eigenvalues)}


class Stability:
    """Inertia and eigenpairs of the model's Hessian at its current state."""

    def __init__(self, model: Any, options: dict[str, Any] | None = None) -> None:
        from dolfinx.fem.petsc import assemble_matrix, create_matrix
        from petsc4py import PETSc

        self.model = model
        comm = model.shell.comm
        self.prefix = f"shells_stab_{next(_counter)}_"
        self.H = create_matrix(model.hessian)
        self.M = assemble_matrix(model.mass, bcs=model.bcs, diagonal=1.0e-12)
        self.M.assemble()
        self.ksp = PETSc.KSP().create(comm)
        self.options = {**INERTIA_OPTIONS, **(options or {})}
        apply_options(self.ksp, self.prefix, self.options)
        configure_factor(self.ksp, self.H, self.options)

    def assemble(self) -> Any:
        from dolfinx.fem.petsc import assemble_matrix

        self.H.zeroEntries()
        assemble_matrix(self.H, self.model.hessian, bcs=self.model.bcs, diagonal=1.0)
        self.H.assemble()
        self.H.setOption(self.H.Option.SYMMETRIC, True)
        return self.H

    def inertia(self) -> tuple[int, int, int]:
        """(negative, zero, positive) eigenvalue counts of the Hessian."""
        self.assemble()
        self.ksp.setOperators(self.H)  # same object as configured: keeps the MUMPS controls
        if not setup_factor(self.ksp, self.H, self.options):
            raise RuntimeError("the Hessian's LDL^T factorisation failed: no inertia")
        F = self.ksp.getPC().getFactorMatrix()
        neg, zero, pos = F.getInertia()
        return int(neg), int(zero), int(pos)

    def eigenpairs(self, nev: int = 6, *, modes: bool = False, assemble: bool = True
                   ) -> tuple[list[float], list[Any]]:
        """The ``nev`` eigenvalues of H v = λ M v nearest 0 (M: L² mass of u and θ), ascending."""
        from petsc4py import PETSc
        from slepc4py import SLEPc

        if assemble:
            self.assemble()
        eps = SLEPc.EPS().create(self.model.shell.comm)
        eps.setOperators(self.H, self.M)
        eps.setProblemType(SLEPc.EPS.ProblemType.GHEP)
        eps.setDimensions(nev=nev, ncv=max(2 * nev + 10, 24))
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
        eps.setOptionsPrefix(self.prefix + "eps_")
        eps.solve()
        vals, vecs = [], []
        for i in range(eps.getConverged()):
            vals.append(eps.getEigenvalue(i).real)
            if modes:
                v = self.H.createVecRight()
                eps.getEigenvector(i, v)
                vecs.append(v)
        order = np.argsort(vals)
        eps.destroy()
        vals = [vals[i] for i in order][:nev]
        vecs = [vecs[i] for i in order][:nev] if modes else []
        _ = PETSc  # imported for type side effects in slepc
        return vals, vecs

    def check(self, nev: int = 0, modes: bool = False) -> StabilityResult:
        """Inertia (always) and, with ``nev`` > 0, the lowest eigenpairs."""
        neg, zero, _ = self.inertia()
        vals, vecs = self.eigenpairs(nev, modes=modes, assemble=False) if nev > 0 else ([], [])
        return StabilityResult(stable=neg == 0 and zero == 0, negative_count=neg,
                               zero_count=zero, eigenvalues=vals, modes=vecs if modes else None)

    def destroy(self) -> None:
        for o in (self.ksp, self.H, self.M):
            o.destroy()
