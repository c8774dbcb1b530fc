import gc, sys
from shells.cli import main
rc = main(sys.argv[1:])
from petsc4py import PETSc
from mpi4py import MPI
gc.collect()
objs = [o for o in gc.get_objects() if isinstance(o, PETSc.Object)]
desc = []
for o in objs:
    try:
        c = o.getComm()
        desc.append((type(o).__name__, c.getSize(), o.getRefCount()))
    except Exception as e:
        desc.append((type(o).__name__, 'err', str(e)[:30]))
big = [d for d in desc if d[1] != 1]
print(f"rank {MPI.COMM_WORLD.rank}: {len(objs)} petsc objects; comm size != 1: {big[:10]}", flush=True)
sys.exit(rc)
