"""The kinetic energy of a free shell in the coordinates of its static gauge (problem layer):
``free_body_mass``.

A free shell (the paper's caps and spheres) has six rigid motions. The static problems remove
them with a gauge: a few point values set to zero (``ShellModel._supports``' docstring, the 1D
model's axis and gauge conditions), which picks one representative w_c of each class w + Z
(Z the rigid motions). The gauge is neutral for the energy (the Hessian annihilates Z at an
equilibrium, so H(w_c) = H(w_c - z) for every z in Z) but not for the kinetic energy: a
motion in the gauged coordinates moves the pinned points of the physical shell only if a
rigid motion comes with it, and a pin that held them would act as a support. The physical
motion of a free shell with zero momentum is the gauged one minus its M-orthogonal projection
on Z, v_e = v_c - Z (ZᵀMZ)⁻¹ ZᵀM v_c, whose kinetic energy is

    T = ½ v̇_cᵀ M_free v̇_c,   M_free = M - M Z (ZᵀMZ)⁻¹ Zᵀ M,

with M the kinetic mass of the unconstrained unknowns. The map v_c ↦ v_e is one to one from
the gauged space onto the M-orthogonal complement of Z and keeps the elastic energy, so the
eigenvalues of H v = ω² M_free v in the gauged space are exactly the free shell's nonzero
ones (the six zero frequencies of the rigid motions are gone), and M_free q̈ + R(q) = 0 is the
free shell's motion seen from its centre of mass, its linear and angular momentum zero (the
gauge then holds no reaction). A pin in place of M_free (the gauged M alone) would give a
shell supported at its gauge points: lower frequencies wherever a free mode moves them (the
breathing sphere's pole moves).

``free_body_mass`` returns M_free as a PETSc MATLRC, the sparse gauged mass plus the rank-k
term -U Uᵀ with U = M Z L⁻ᵀ (LLᵀ = ZᵀMZ), its rows on the constrained DOFs zero: products
cost one sparse product and 2k dot products.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["FreeBody", "free_body_mass", "sparse_part"]


@dataclass
class FreeBody:
    """A free body's kinetic mass in gauged coordinates and the map to its physical motion.

    Attributes:
        mass: M_free (``free_body_mass``).
        rigid: the rigid motions Z.
        momenta: M Z (columns, unconstrained).
        inverse_gram: (ZᵀMZ)⁻¹.
    """

    mass: Any
    rigid: list[Any] = field(default_factory=list)
    momenta: list[Any] = field(default_factory=list)
    inverse_gram: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))

    def free_part(self, v: Any) -> Any:
        """v - Z (ZᵀMZ)⁻¹ ZᵀM v: the motion of the free body a gauged vector v stands for (a
        new vector, M-orthogonal to the rigid motions; v itself where there are none)."""
        out = v.copy()
        if self.rigid:
            a = self.inverse_gram @ np.array([float(p.dot(v)) for p in self.momenta])
            for z, ai in zip(self.rigid, a, strict=True):
                out.axpy(-float(ai), z)
        return out


def free_body_mass(M: Any, M_full: Any, rigid: list[Any],
                   zero_constrained: Callable[[Any], None]) -> FreeBody:
    """The kinetic mass of a free body in gauged coordinates, M - M Z (ZᵀMZ)⁻¹ ZᵀM.

    Args:
        M: the kinetic mass with the gauge applied (zero rows and columns, a tiny diagonal on
            the constrained DOFs), SPD; owned by the result.
        M_full: the same mass without the gauge (its constrained rows and columns kept);
            destroyed.
        rigid: the rigid motions z_i (vectors of M's layout, their values on the constrained
            DOFs included), linearly independent; none: M itself is returned.
        zero_constrained: sets a vector's constrained DOFs to zero.

    Returns:
        The ``FreeBody``: its ``mass`` M where ``rigid`` is empty, else a MATLRC M - U Uᵀ
        (``sparse_part`` gives M back), flagged symmetric.
    """
    from petsc4py import PETSc

    if not rigid:
        M_full.destroy()
        return FreeBody(M)
    k = len(rigid)
    P = []
    for z in rigid:
        p = M_full.createVecLeft()
        M_full.mult(z, p)
        P.append(p)
    G = np.array([[float(z.dot(p)) for p in P] for z in rigid])
    G = 0.5 * (G + G.T)
    L = np.linalg.cholesky(G)
    Linv = np.linalg.inv(L)
    momenta = [p.copy() for p in P]
    for p in P:
        zero_constrained(p)
    n_local = P[0].getLocalSize()
    cols = np.column_stack([p.array_r for p in P]) if n_local else np.zeros((0, k))
    U_local = cols @ Linv.T  # U = P L⁻ᵀ: U Uᵀ = P G⁻¹ Pᵀ
    comm = M.getComm()
    U = PETSc.Mat().createDense(((n_local, P[0].getSize()), (PETSc.DECIDE, k)), comm=comm)
    U.setUp()
    lo, hi = U.getOwnershipRange()
    U.setValues(np.arange(lo, hi, dtype=PETSc.IntType), np.arange(k, dtype=PETSc.IntType),
                U_local, addv=PETSc.InsertMode.INSERT_VALUES)
    U.assemble()
    c = PETSc.Vec().createSeq(k, comm=PETSc.COMM_SELF)  # the same on every rank
    c.set(-1.0)
    out = PETSc.Mat().createLRC(M, U, c, U)
    out.setOption(PETSc.Mat.Option.SYMMETRIC, True)
    for p in P:
        p.destroy()
    M_full.destroy()
    return FreeBody(out, list(rigid), momenta, Linv.T @ Linv)


def sparse_part(M: Any) -> Any:
    """The sparse matrix of a mass: M's own, or the first term of a MATLRC
    (``free_body_mass``)."""
    if M.getType() == "lrc":
        return M.getLRCMats()[0]
    return M
