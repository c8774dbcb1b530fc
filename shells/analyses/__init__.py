"""The analyses: which problem to build from a shell's description, the files a run writes,
resume, and the results of ``shells branch``, ``critical``, ``postbuckle``, ``knockdown`` and
``phase-diagram``.

Each analysis has one entry point, its module's ``run``:

* ``branch.run``: the equilibrium branch in κ, either model;
* ``critical.run``: the critical points of the fundamental branch, either model;
* ``postbuckle.run``: the branch that bifurcates at a critical point, both sides;
* ``knockdown.run``: the knock-down of a closed sphere's buckling by an imperfection;
* ``phase_diagram.run``: the phase diagram of open caps.

Shared pieces: ``setup`` (the κ range a run covers by default), ``store`` (checkpoints and
resume), ``axisym_runs`` (the 1D model's ``branch`` and ``critical``), ``writers`` (3D shapes
and fields for ParaView), ``render`` (off-screen pictures).
"""
