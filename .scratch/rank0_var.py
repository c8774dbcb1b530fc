import sys
from mpi4py import MPI
import dolfinx  # noqa
if len(sys.argv) > 2: from slepc4py import SLEPc  # noqa
v = sys.argv[1]
if MPI.COMM_WORLD.rank == 0:
    if v == "vec":
        from petsc4py import PETSc
        x = PETSc.Vec().createSeq(10, comm=MPI.COMM_SELF); x.destroy()
    elif v == "mesh":
        m = dolfinx.mesh.create_unit_interval(MPI.COMM_SELF, 10)
    elif v == "model":
        from shells.axisym.model import AxisymModel, AxisymParameters
        from shells.geometry import Sphere
        m = AxisymModel(Sphere(1.0), AxisymParameters(h=0.05, nu=0.5, cells=50))
    elif v == "newton":
        from shells.axisym.model import AxisymModel, AxisymParameters
        from shells.geometry import Sphere
        from shells.solvers import NewtonSolver
        m = AxisymModel(Sphere(1.0), AxisymParameters(h=0.05, nu=0.5, cells=50))
        ns = NewtonSolver(m); m.set_kappa(1.0); print(ns.solve()); ns.destroy()
    elif v == "eps":
        from slepc4py import SLEPc
        e = SLEPc.EPS().create(MPI.COMM_SELF); e.destroy()
    print("done", flush=True)
MPI.COMM_WORLD.Barrier()
