"""Newton modulo a symmetry orbit: equilibria of a pattern whose orientation is free (algorithm
layer).

A pattern that breaks the symmetry of a shell of revolution (the m = 2 state a deep cap snaps
into) lies on an orbit: turned about the axis it is the same state, of the same energy, in the
continuum. A mesh breaks the symmetry weakly: the energy varies along the orbit by a
discretisation error, its curvature there is orders of magnitude below the physical ones, and
the orbit is a circle in the state space. Minimisers creep along such a valley (their Newton
steps along the orbit are long and straight, the valley curved), and plain Newton does not
converge on it. Here the orientation is held instead: each Newton step is the solution of the
bordered system

    [ H   T ] [ δ ]   [ -g ]
    [ Tᵀ  0 ] [ λ ] = [  0 ],

T the orbit's tangents at the iterate (``OrbitTangents``), solved by the Schur complement on
one factorisation of H: δ = x - Y S⁻¹ Tᵀ x with H x = -g, H Y = T, S = Tᵀ Y, with a
backtracking line search on the energy (Armijo) where the problem has one. It converges
quadratically to a state where the gradient lies along the orbit, g = T λ: an equilibrium in
every direction but the orientation, where what is left is the mesh's pinning force. Its
energy differs from that of another orientation by the mesh's pinning only, which vanishes as
the mesh is refined (``benchmarks/snap_orbit_pinning.py``).

Options prefix ``shells_orbit_`` (the factorisation of H: MUMPS LU by default).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from shells.algorithms.newton import apply_options, configure_factor, setup_factor
from shells.problem.interface import OrbitTangents

__all__ = ["ORBIT_OPTIONS", "ORBIT_PREFIX", "OrbitNewtonResult", "has_orbit",
           "newton_modulo_orbit"]

log = logging.getLogger("shells")

#: the options prefix of the factorisation of H
ORBIT_PREFIX = "shells_orbit_"
#: its defaults (H is indefinite along the orbit where the mesh's pinning is a maximum: LU)
ORBIT_OPTIONS: dict[str, Any] = {"ksp_type": "preonly", "pc_type": "lu",
                                 "pc_factor_mat_solver_type": "mumps"}
#: a step that raises the gradient off the orbit by more than this factor ends the solve
#: (outside Newton's basin: the caller goes on with its globalised method)
GROWTH_MAX = 10.0
#: the line search on a problem with an energy: a step is halved at most this many times
#: until the energy falls by ``ARMIJO`` of the step's first-order decrease (or stays within
#: ``ENERGY_NOISE`` |E| of it, where the energy's round-off hides a converged Newton step)
HALVINGS = 8
ARMIJO = 1.0e-4
ENERGY_NOISE = 1.0e-13


@dataclass(frozen=True)
class OrbitNewtonResult:
    """What a ``newton_modulo_orbit`` ended with.

    Attributes:
        converged: the gradient off the orbit fell to ``atol``.
        iterations: Newton steps taken.
        gradient_off_orbit: the norm of the gradient's part off the orbit's tangents.
        orbit_gradient: the norm of its part along them (the mesh's pinning force).
    """

    converged: bool
    iterations: int
    gradient_off_orbit: float
    orbit_gradient: float


def has_orbit(problem: Any) -> bool:
    """Whether the problem's current state has an orbit (``OrbitTangents``, non-empty)."""
    if not isinstance(problem, OrbitTangents):
        return False
    tangents = problem.orbit_tangents()
    for t in tangents:
        t.destroy()
    return bool(tangents)


def _split(g: Any, tangents: list[Any]) -> tuple[float, float]:
    """(|g off the span of the tangents|, |g along it|), Euclidean (collective)."""
    k = len(tangents)
    gram = np.array([[a.dot(b) for b in tangents] for a in tangents]).reshape(k, k)
    c = np.array([t.dot(g) for t in tangents])
    along2 = float(c @ np.linalg.solve(gram, c)) if k else 0.0
    g2 = g.dot(g)
    return math.sqrt(max(g2 - along2, 0.0)), math.sqrt(max(along2, 0.0))


def newton_modulo_orbit(problem: Any, atol: float, max_it: int = 25,
                        options: dict[str, Any] | None = None) -> OrbitNewtonResult:
    """Newton on the problem's residual with the state's orientation on its orbit held.

    Each step solves the bordered system of the module docstring at the current iterate (its
    tangents recomputed there). A failed solve (no convergence in ``max_it`` steps, a step that
    raises the gradient off the orbit ``GROWTH_MAX``-fold, a failed factorisation, a state
    that loses its orbit) leaves the state as it was.

    Args:
        problem: a ``Problem`` with ``OrbitTangents``; its state is the start and, on success,
            the end.
        atol: convergence: the gradient's norm off the orbit at most ``atol``.
        max_it: at most this many steps.
        options: PETSc options over ``ORBIT_OPTIONS`` (prefix ``shells_orbit_``).

    Returns:
        The ``OrbitNewtonResult``.
    """
    from petsc4py import PETSc

    from shells.problem.interface import FactorOptions

    start = problem.state.copy()
    g = problem.create_vector()
    H = problem.create_jacobian()
    x, y = g.duplicate(), g.duplicate()
    ksp = PETSc.KSP().create(problem.comm)
    recommended = problem.factor_options if isinstance(problem, FactorOptions) else {}
    opts = apply_options(ksp, ORBIT_PREFIX, {**ORBIT_OPTIONS, **recommended, **(options or {})})
    configure_factor(ksp, H, opts)
    off = along = math.inf
    its, converged, first = 0, False, None
    try:
        for its in range(max_it + 1):
            problem.assemble_residual(g)
            tangents = problem.orbit_tangents()
            try:
                if not tangents:
                    break
                off, along = _split(g, tangents)
                first = off if first is None else first
                log.debug("orbit Newton %d: |g| off the orbit %.3g, along it %.3g", its, off,
                          along)
                if off <= atol:
                    converged = True
                    break
                if its == max_it or not off <= GROWTH_MAX * first:
                    break
                if not _step(problem, ksp, H, opts, g, tangents, x, y):
                    break
            finally:
                for t in tangents:
                    t.destroy()
    finally:
        for obj in (ksp, H, x, y):
            obj.destroy()
    if not converged:
        start.copy(problem.state)
        problem.sync()
    start.destroy()
    g.destroy()
    return OrbitNewtonResult(converged=converged, iterations=its,
                             gradient_off_orbit=off, orbit_gradient=along)


def _step(problem: Any, ksp: Any, H: Any, opts: dict[str, Any], g: Any, tangents: list[Any],
          x: Any, y: Any) -> bool:
    """One bordered Newton step from the current state (``g`` its gradient; changed); False
    where the factorisation or the Schur complement fails."""
    problem.assemble_jacobian(H)
    ksp.setOperators(H)
    if not setup_factor(ksp, H, opts):
        return False
    g.scale(-1.0)
    ksp.solve(g, x)
    ys = []
    try:
        for t in tangents:
            ksp.solve(t, y)
            ys.append(y.copy())
        S = np.array([[t.dot(v) for v in ys] for t in tangents])
        try:
            lam = np.linalg.solve(S, np.array([t.dot(x) for t in tangents]))
        except np.linalg.LinAlgError:
            return False
        if not np.all(np.isfinite(lam)):
            return False
        for li, v in zip(lam, ys, strict=True):
            x.axpy(-li, v)
    finally:
        for v in ys:
            v.destroy()
    return _line_search(problem, g, x)


def _line_search(problem: Any, minus_g: Any, step: Any) -> bool:
    """Add the step to the state, halved until the energy decreases enough (``ARMIJO``) where
    the problem has one; else the whole step. False, with the state as it was, where no
    halving decreases it (the slice's Hessian is not positive definite there)."""
    from shells.problem.interface import Energy

    if not isinstance(problem, Energy):
        problem.state.axpy(1.0, step)
        problem.sync()
        return True
    e0 = problem.total_energy()
    slope = -minus_g.dot(step)  # dE along the step, negative for a descent direction
    alpha = 1.0
    for _ in range(HALVINGS + 1):
        problem.state.axpy(alpha, step)
        problem.sync()
        e = problem.total_energy()
        if e <= e0 + ARMIJO * alpha * min(slope, 0.0) + ENERGY_NOISE * abs(e0):
            return True
        problem.state.axpy(-alpha, step)
        problem.sync()
        alpha /= 2
    return False
