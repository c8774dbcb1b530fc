"""Axisymmetric (shell-of-revolution) model: the paper's energy on the meridian, exact for
axisymmetric base states, with the stability of every Fourier mode m from the same energy (the
model layer).

Modules: ``mesh`` (the meridian mesh), ``model`` (kinematics and energy: ``AxisymModel``, a
``shells.problem.Problem``), ``modes`` (the mode Hessians H_m, its stability blocks), ``chain``
(their definiteness from element matrices, native code in ``chain.c``), ``revolve`` (3D shapes
of a meridian for ParaView).

The runs of this model (``branch``, ``critical``) are analyses: ``shells.analyses.axisym_runs``.
"""

from shells.axisym.mesh import MeridianMesh, make_meridian_nodes
from shells.axisym.model import SNES_OPTIONS, AxisymModel, AxisymParameters
from shells.axisym.modes import ModeForms

__all__ = ["SNES_OPTIONS", "AxisymModel", "AxisymParameters", "MeridianMesh", "ModeForms",
           "make_meridian_nodes"]
