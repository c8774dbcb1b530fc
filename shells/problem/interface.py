"""The problem interface: what the algorithm layer may know of a model (problem layer).

Every algorithm in ``shells`` (Newton, continuation, stability, critical points, branch
switching) is written against ``Problem`` and nothing else: no algorithm reads a model's private
attributes. Three kinds of problem implement it:

* ``shells.surface.model.ShellModel``: the 2D surface model (one stability block, ``None``);
* ``shells.axisym.AxisymModel``: the 1D axisymmetric model (one stability block per Fourier
  mode m = 0, 1, 2, ...);
* ``shells.problem.algebraic``: tiny algebraic problems with exact answers (a fold, a pitchfork)
  that test the algorithms in milliseconds.

The two finite-element models get the assembly half of the interface from
``shells.problem.forms.FormProblem`` (residual, Jacobian and dR/dκ from compiled dolfinx forms, the
gauge as Dirichlet conditions).

Conventions. The state is a PETSc vector distributed over ``comm`` (ghosted or not): its owned
values are the unknowns, ``sync()`` refreshes whatever a model derives from them (ghost values)
after they were changed in place. The load parameter is the natural curvature κ; algorithms
continue in λ = κ L with L = ``length_scale()``, and measure the state in units of
``state_scale()`` (the thickness h): the arclength norm is |δw|²/(N s²) + δλ². Residual and
dR/dκ vectors are zero on constrained (gauge) DOFs, the Jacobian has unit rows there. The
stability blocks are symmetric matrices whose inertia decides stability: the Hessian itself
(surface model) or its Fourier blocks H_m (axisymmetric model), with a mass matrix for the
eigenproblem H v = μ M v; ``classify_mode`` names an eigenvector's mode (m, n). Block ``None``
is always the Jacobian (the Hessian of the state's own unknowns): its eigenvectors live in the
state's space, so branch switching follows them (on the axisymmetric model: the axisymmetric
modes, the only ones it can follow past a bifurcation).
"""

from __future__ import annotations

import math
from collections.abc import Hashable
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

__all__ = ["BlockFactor", "BlockInertia", "BlockInertias", "CondensedHessian", "DefiniteBlocks",
           "Energy", "FactorOptions", "HessianQuadratic", "KineticMass", "ModeInfo",
           "OrbitTangents", "PoleFunctional", "Problem",
           "get_state", "orbit_cosine", "set_state"]


@dataclass(frozen=True)
class ModeInfo:
    """What a mode is: azimuthal wavenumber m (surfaces of revolution), spherical-harmonic
    degree n (closed spheres), and the Rayleigh quotients they were read from."""

    m: int | None = None
    n: int | None = None
    rayleigh: dict[str, float] = field(default_factory=dict)


def orbit_cosine(cross: np.ndarray, gram: np.ndarray, v2: float, s2: float,
                 tangents: int) -> float:
    """How far a mode v lies along the orbit of a state under a symmetry of the reference
    surface, modulo rigid motions: |cos| of the angle between v and the orbit's tangent space
    in the quotient of L² by the rigid motions' span (the gauge picks one representative of
    each rigid motion, so the orbit's tangent in the gauged space is a tangent plus a rigid
    motion). From the inner products of v and of the basis b_i, the ``tangents`` orbit
    tangents first, then the rigid motions: ``cross`` = (v·b_i), ``gram`` = (b_i·b_j) for
    i ≤ j row by row, ``v2`` = v·v; ``s2`` the state's own squared norm (the scale below which
    a tangent counts as zero).

    Args:
        cross: (v·b_i), the ``tangents`` orbit tangents first, then the rigid motions.
        gram: (b_i·b_j) for i ≤ j, row by row.
        v2: v·v.
        s2: the state's own squared norm.
        tangents: how many of the b_i are orbit tangents.

    Returns:
        The |cos| in [0, 1]; 0 when every tangent vanishes (a state with no orbit).
    """
    cross = np.asarray(cross, dtype=float)
    n = len(cross)
    G = np.zeros((n, n))
    G[np.triu_indices(n)] = gram
    G = G + np.triu(G, 1).T
    d = np.diag(G)
    has = np.arange(n) < tangents
    live = np.where(has, d > 1e-12 * max(s2, 1e-300), d > 0)
    if not (live & has).any() or not v2 > 0:
        return 0.0

    def projected(idx: np.ndarray) -> float:
        """|P v|² on the span of the basis functions ``idx`` (Jacobi-scaled, rank-revealing)."""
        if idx.size == 0:
            return 0.0
        sc = 1.0 / np.sqrt(d[idx])
        lam, Q = np.linalg.eigh(G[np.ix_(idx, idx)] * np.outer(sc, sc))
        k = lam > 1e-10 * lam.max()
        return float(np.sum((Q[:, k].T @ (cross[idx] * sc)) ** 2 / lam[k]))

    rigid = projected(np.flatnonzero(live & ~has))
    rest = v2 - rigid
    if not rest > 1e-10 * v2:  # v is a rigid motion (to round-off): no orbit direction
        return 0.0
    return float(min(1.0, math.sqrt(max(projected(np.flatnonzero(live)) - rigid, 0.0) / rest)))


@runtime_checkable
class Problem(Protocol):
    """A parameter-dependent equilibrium problem R(w, κ) = 0 with a symmetric Jacobian."""

    comm: Any

    # -- state and parameter ---------------------------------------------------------------------
    @property
    def state(self) -> Any:
        """The current state (PETSc Vec); algorithms change its owned values, then ``sync()``."""

    def sync(self) -> None:
        """Refresh what derives from the state's owned values (ghosts) after a change."""

    def get_kappa(self) -> float:
        """The natural curvature κ of the current point."""

    def set_kappa(self, kappa: float) -> None:
        """Set κ (no solve)."""

    def length_scale(self) -> float:
        """L: the continuation parameter is λ = κ L."""

    def state_scale(self) -> float:
        """s: the state is measured in units of s (the thickness) by the arclength norm."""

    def num_dofs(self) -> int:
        """Global number of unknowns."""

    # -- assembly --------------------------------------------------------------------------------
    def create_vector(self) -> Any:
        """A vector of the residual's layout."""

    def create_jacobian(self) -> Any:
        """A matrix of the Jacobian's layout."""

    def assemble_residual(self, b: Any) -> None:
        """R(w, κ) into ``b`` (zero on the constrained DOFs)."""

    def assemble_jacobian(self, A: Any) -> None:
        """∂R/∂w into ``A`` (unit rows and columns on the constrained DOFs)."""

    def assemble_dkappa(self, b: Any) -> None:
        """∂R/∂κ into ``b`` (zero on the constrained DOFs)."""

    def zero_constrained(self, v: Any) -> None:
        """Set the constrained (gauge) DOFs of a state-shaped vector to zero."""

    # -- what a point is -------------------------------------------------------------------------
    def scalars(self) -> dict[str, float]:
        """Scalar indicators of the current point (the same on every rank)."""

    # -- stability -------------------------------------------------------------------------------
    def stability_blocks(self) -> tuple[Hashable, ...]:
        """Labels of the stability blocks: ``(None,)`` for one Hessian, Fourier modes m..."""

    def block_layout(self, block: Hashable) -> Hashable:
        """Blocks with equal layout keys share one matrix (same sparsity, same size)."""

    def create_hessian(self, block: Hashable) -> Any:
        """A matrix of the block's layout."""

    def assemble_hessian(self, block: Hashable, H: Any) -> None:
        """The block's Hessian at the current point (unit rows on its constrained DOFs)."""

    def assemble_mass(self, block: Hashable) -> Any:
        """A new SPD mass matrix of the block (tiny diagonal on its constrained DOFs)."""

    def classify_mode(self, vec: Any, block: Hashable) -> ModeInfo:
        """The mode (m, n) of an eigenvector of the block's Hessian."""


# -- optional capabilities ---------------------------------------------------------------------
# A problem may offer any of these; the algorithms use one where ``isinstance(problem, X)``
# says the problem has it, and otherwise do the general thing (assemble and factor the block
# with MUMPS, take the eigenvalue the eigensolver gives). Each is a runtime-checkable protocol
# of one member, so that what an algorithm may ask of a problem is declared in one place.


@runtime_checkable
class DefiniteBlocks(Protocol):
    """Definiteness of stability blocks decided without assembling them."""

    def definite_blocks(self, blocks: Any, margin: float) -> dict[Hashable, bool] | None:
        """Whether each block's Hessian H has a Cholesky factor of H - margin diag(H).

        Returns:
            block -> bool for the blocks the problem decides (the 1D model on one process:
            element matrices condensed on its chain of cells); blocks left out, or None, are
            tested on their assembled matrices.
        """


@runtime_checkable
class BlockInertia(Protocol):
    """Exact inertia of a stability block from a factorisation the problem does itself."""

    def block_inertia(self, block: Hashable, growth: float) -> tuple[int, int, int] | None:
        """(negative, zero, positive) of the block, or None where the problem cannot vouch for
        it (an unpivoted LDLᵀ whose |L||D||Lᵀ| exceeds ``growth`` times the matrix's
        diagonal); then ``CondensedHessian`` or MUMPS counts it."""


@runtime_checkable
class BlockInertias(Protocol):
    """``BlockInertia`` of several blocks at once (the 1D model: one C call for all)."""

    def block_inertias(self, blocks: list[Hashable], growth: float
                       ) -> dict[Hashable, tuple[int, int, int] | None] | None:
        """block -> ``block_inertia(block, growth)``, or None."""


@runtime_checkable
class CondensedHessian(Protocol):
    """A smaller matrix with a block's inertia, for exact counts of indefinite blocks."""

    def condensed_hessian(self, block: Hashable) -> tuple[Any, int] | None:
        """(matrix, k): a Schur complement after eliminating k DOFs on which the block is
        positive definite, whose inertia is the block's but for k fewer positive eigenvalues;
        None: factor the block itself."""


@runtime_checkable
class BlockFactor(Protocol):
    """The operator of the shift-invert eigensolves, factored by the problem."""

    def block_factor(self, block: Hashable) -> Any:
        """The block's Hessian at the current state (as ``assemble_hessian`` assembles it)
        factored by the problem: ``solver.solve(b, x)`` writes H⁻¹ b into x (arrays of the
        local DOFs); None: MUMPS."""


@runtime_checkable
class HessianQuadratic(Protocol):
    """vᵀ H v by quadrature, for eigenvalues free of the assembled matrix's round-off."""

    def hessian_quadratic(self, block: Hashable, v: Any) -> float | None:
        """vᵀ H v of the block at the current state by quadrature of the energy's second
        variation d²E(v, v) (constrained DOFs of v taken as zero), not by a product with the
        assembled matrix: its round-off is that of the mode's own energy, not ε ‖H‖.
        ``shells.algorithms.stability`` turns every eigenvalue into its eigenvector's
        Rayleigh quotient with it."""


@runtime_checkable
class PoleFunctional(Protocol):
    """The depth of the top pole as a linear functional of the state."""

    def pole_functional(self) -> Any:
        """e with e·w = Ψ3(pole)/h (a state-shaped vector; shapes of revolution with a pole):
        the parameter a closed sphere's dimple branch is followed with."""


@runtime_checkable
class Energy(Protocol):
    """The energy itself, for minimisation (``shells.algorithms.minimise``)."""

    def total_energy(self) -> float:
        """E(w, κ) at the current state: the functional whose gradient ``assemble_residual``
        assembles (the same on every rank)."""


@runtime_checkable
class OrbitTangents(Protocol):
    """The directions in which the state moves along its symmetry orbit, for minimisation
    modulo the orbit (``shells.algorithms.orbit``)."""

    def orbit_tangents(self) -> list[Any]:
        """New state-shaped vectors, zero on the constrained DOFs: the derivatives of the
        current state along the one-parameter symmetries of the reference shell that the
        gauge leaves free (a shell of revolution: its rotation about the axis, which turns a
        pattern). Neutral in the continuum, such a direction is nearly so on a mesh, which
        pins the pattern's orientation weakly. Empty where the state has no orbit: a state
        invariant under the symmetry (an axisymmetric one), up to the mesh's interpolation
        error, or a shape without symmetry."""


@runtime_checkable
class KineticMass(Protocol):
    """The mass of the shell's kinetic energy, for natural frequencies and dynamics."""

    def assemble_kinetic_mass(self, block: Hashable) -> Any:
        """A new mass matrix M of the block's kinetic energy T = ½ v̇ᵀ M v̇ at the current state.

        T = ½ ∫ (ρh |u̇|² + ρh³/12 |ḋ|²) dA in the units of the energy (E h / (8 (1 - ν²)) per
        unit of ``energy_ufl``) with time in units of L √(ρ/E), L = ``length_scale()``: the
        eigenvalues of H v = ω² M v are ω² in units of E / (ρ L²). The gauge's constrained
        DOFs as in ``assemble_mass`` (zero rows and columns, a tiny diagonal), and the rigid
        motions that the gauge removes carry no kinetic energy: M is the mass of the free
        shell's motion relative to its centre of mass (``shells.problem.kinetic``), so the
        gauge acts as no support. A PETSc matrix, possibly a MATLRC (sparse part:
        ``shells.problem.kinetic.sparse_part``), symmetric positive definite."""

    def free_motion(self, block: Hashable, v: Any) -> Any:
        """The free shell's motion that a gauged vector v of the block stands for: v minus its
        rigid part, M-orthogonal to the rigid motions (a new vector; M and the rigid motions
        of the last ``assemble_kinetic_mass(block)``)."""


@runtime_checkable
class FactorOptions(Protocol):
    """PETSc options the problem recommends for its Jacobian's factorisation."""

    factor_options: dict[str, Any]


def get_state(problem: Problem) -> np.ndarray:
    """A copy of this rank's owned state values.

    Args:
        problem: the problem.

    Returns:
        The owned values (a numpy array).
    """
    return problem.state.array_r.copy()


def set_state(problem: Problem, values: np.ndarray) -> None:
    """Set the owned state values and sync the ghosts.

    Args:
        problem: the problem.
        values: at least this rank's owned values (the first ``local size`` are taken).
    """
    v = problem.state
    v.array_w[:] = values[: v.getLocalSize()]
    problem.sync()
