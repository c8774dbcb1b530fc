"""The problem layer: what an equilibrium problem R(w, κ) = 0 offers the algorithms.

Modules:

* ``interface``: the ``Problem`` protocol every algorithm is written against, its optional
  capabilities, and ``ModeInfo``;
* ``forms``: ``FormProblem``, the assembly half of the interface for a model whose residual,
  Jacobian and dR/dκ are dolfinx forms of a UFL energy;
* ``kinetic``: the kinetic mass of a free shell in its static gauge's coordinates;
* ``formcache``: compiled forms derived in UFL, remembered on disk;
* ``algebraic``: small algebraic problems with exact answers (a fold, a pitchfork) that test the
  algorithms in milliseconds.

The interface's names are re-exported here: ``from shells.problem import Problem``.
"""

from shells.problem.interface import (
    BlockFactor,
    BlockInertia,
    BlockInertias,
    CondensedHessian,
    DefiniteBlocks,
    FactorOptions,
    HessianQuadratic,
    KineticMass,
    ModeInfo,
    PoleFunctional,
    Problem,
    get_state,
    orbit_cosine,
    set_state,
)

__all__ = ["BlockFactor", "BlockInertia", "BlockInertias", "CondensedHessian", "DefiniteBlocks",
           "FactorOptions", "HessianQuadratic", "KineticMass", "ModeInfo", "PoleFunctional",
           "Problem", "get_state", "orbit_cosine", "set_state"]
