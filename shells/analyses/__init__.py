"""The analyses (drivers): which problem to build from a configuration, the runs' files and
resume, and the results of ``shells branch``, ``critical``, ``postbuckle``, ``knockdown`` and
``phase-diagram``.

Modules:

* ``store``: run folders, JSON lines, checkpoints and resume;
* ``drivers``: the surface model's ``branch``, ``critical`` and ``postbuckle`` runs;
* ``axisym_runs``: the 1D model's ``branch`` and ``critical``;
* ``branch``, ``postbuckle``, ``knockdown``, ``phase_diagram``: the analyses themselves;
* ``render``: off-screen pictures of meshes and fields.
"""
