"""The algorithm layer: solvers and path-following written against ``shells.problem.Problem``
only (no algorithm imports a model).

Modules:

* ``settings``: ``ContinuationSettings``, ``CriticalSettings`` (frozen, validated);
* ``records``: ``CriticalPoint`` and the resume records ``FollowResume``, ``SwitchResume``;
* ``newton``: ``NewtonSolver`` (PETSc SNES, bordered solves) and the options prefixes;
* ``bordered``: the one corrector, ``bordered_newton``, and its ``Arclength`` vectors;
* ``continuation``: natural and pseudo-arclength continuation, the one arclength loop;
* ``stability``: inertia and eigenpairs of the stability blocks (MUMPS, SLEPc);
* ``locate``: locating folds and bifurcations inside a step;
* ``following``: ``follow``, continuation with stability at every point;
* ``switching``: ``switch_branch``, branch switching at a located bifurcation;
* ``asymptotics``: Koiter's reduced equation at a located bifurcation.
"""
