import sys
from mpi4py import MPI
import dolfinx  # noqa
from shells.phase_diagram.config import PhaseDiagramConfig
from shells.phase_diagram.jobs import tasks_of
from shells.phase_diagram.tracing import compute_task
cfg = PhaseDiagramConfig(h_over_r=(0.04,), thetabar_range=(1.5, 3.5), points=2, refine=1, m_max=4)
tasks, _ = tasks_of(cfg)
if MPI.COMM_WORLD.rank == 0:
    rec = compute_task(tasks[-1], cfg)
    print("done", rec.get("status"), flush=True)
MPI.COMM_WORLD.Barrier()
print("rank", MPI.COMM_WORLD.rank, "exiting", flush=True)
