"""Phase diagram of open spherical caps under natural curvature κ (the paper's Fig. 3), in one run.

For every (h/R, θ̄ = θ/√(h/R)) two branches of the axisymmetric model (``shells.axisym``) are
followed from κ = 0 with the Hessian inertia of every Fourier mode m = 0..m_max:

* **up** (κ > 0): the first critical point: the snap-through fold (m = 0), a loss of symmetry
  (bifurcation m ≥ 1) before it, or, for shallow caps that invert smoothly (no fold), the loss of
  symmetry of the inverted shell. The axisymmetric fold is followed to the end even when a
  bifurcation precedes it (the paper's snapping line comes from a 1D model): ``kappa_snap_R``.
* **down** (κ < 0): the loss of symmetry κ_b R of Eq. (4), with its m.
* **everted branch** (κ > 0, past the snap): its loss of symmetry is κ_e R = 2 - κ_b R *exactly*:
  reflecting a state in the plane of the rim keeps a and flips b (the normal is reversed), so with
  b° = -a°/R the energy at κ of the reflected state equals the energy at 2/R - κ of the original.
  The everted branch is the mirror of the fundamental branch, and the paper's mirrored Eq. (4) is
  a symmetry of the energy (checked numerically by ``everted_check``, which follows the branch
  through the snap and its second fold onto the everted branch).

Points run in parallel, one per MPI process (each on ``MPI.COMM_SELF``; the axisymmetric model is
serial), dynamically: a process claims the next task by creating a claim file, so ``mpirun -n 2``
computes two at once. Every result is appended (one line, flushed) to ``DIR/points.jsonl`` by the
process that computed it; a rerun reads that file and skips finished tasks (same numerics).
Then rank 0 fits the paper's laws with standard errors (``fit_all``), refines θ̄_s by bisection,
writes ``DIR/phase_diagram.json`` and the figure ``DIR/phase_diagram.{png,pdf}``.

``--model surface`` computes the same first critical points with the 2D surface model
(``shells.algorithms.following.follow``) for spot checks (much slower; no everted-branch check).

Modules: ``config`` (configuration and tasks), ``tracing`` (one branch), ``jobs`` (claims, the
points file, the run), ``fits`` (merged points and fits), ``figure``, ``landings`` (where
``shells snap`` runs landed, shown in the figure: ``--landings``).
"""

from shells.analyses.phase_diagram.config import Discretisation, PhaseDiagramConfig, Task, tasks_of
from shells.analyses.phase_diagram.figure import make_figure
from shells.analyses.phase_diagram.fits import fit_all, merge_points
from shells.analyses.phase_diagram.jobs import RunStats, run
from shells.analyses.phase_diagram.landings import read_landings
from shells.analyses.phase_diagram.tracing import compute_task, everted_check

__all__ = ["Discretisation", "PhaseDiagramConfig", "RunStats", "Task", "compute_task",
           "everted_check", "fit_all", "make_figure", "merge_points", "read_landings", "run",
           "tasks_of"]
