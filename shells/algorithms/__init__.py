"""The algorithm layer: solvers and path-following written against ``shells.problem.Problem``
only (no algorithm imports a model).

Modules:

* ``newton``: ``NewtonSolver`` (PETSc SNES, bordered solves);
* ``continuation``: natural and pseudo-arclength continuation, the one corrector and the one
  arclength loop;
* ``stability``: inertia and eigenpairs of the stability blocks (MUMPS, SLEPc);
* ``critical``: following a branch with its stability, locating critical points, branch
  switching;
* ``asymptotics``: Koiter's reduced equation at a located bifurcation.
"""
