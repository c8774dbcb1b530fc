"""The 2D surface model: the shell's mid-surface meshed in 3D (the model layer).

Modules:

* ``mesh``: gmsh meshes of the shapes (second-order geometry, graded rim layers, sector
  symmetry) and reading user meshes;
* ``model``: ``ShellModel``, the paper's energy on the surface (a ``shells.problem.Problem``);
* ``fields``: fields written for ParaView (VTX);
* ``frame``: a state turned into the shell's best-fit rigid frame (``RigidFrame``), where
  quantities read in the material frame do not depend on the gauge's rotation.
"""
