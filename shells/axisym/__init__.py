"""Axisymmetric (shell-of-revolution) model: the paper's energy on the meridian, exact for
axisymmetric base states, with the stability of every Fourier mode m from the same energy.

Modules: ``mesh`` (the meridian mesh), ``model`` (kinematics and energy: ``AxisymModel``, a
``shells.problem.Problem``), ``modes`` (the mode Hessians H_m, its stability blocks), ``run``
(drivers: ``branch`` and ``critical`` on the common algorithm layer).

Public API: ``AxisymModel`` (a ``shells.problem.Problem``: the algorithm layer's continuation,
Newton and ``shells.stability.Stability`` run on it; its stability blocks are the modes m),
``ModeForms`` (the H_m forms), ``branch(...)`` (generator of point records with per-m negative
counts) and ``critical(...)`` (first critical point and all critical points up to the first fold).
"""

from shells.axisym.mesh import MeridianMesh, make_meridian_nodes
from shells.axisym.model import AxisymModel, AxisymParameters
from shells.axisym.modes import ModeForms
from shells.axisym.run import (
    SNES_OPTIONS,
    RunConfig,
    branch,
    critical,
    default_cells,
    default_settings,
)
from shells.theory import sphere_kappa_b_h, sphere_mode_n

__all__ = ["SNES_OPTIONS", "AxisymModel", "AxisymParameters", "MeridianMesh", "ModeForms",
           "RunConfig", "branch", "critical", "default_cells", "default_settings",
           "make_meridian_nodes", "sphere_kappa_b_h", "sphere_mode_n"]
