import math, traceback, sys
from shells.algebraic import FoldProblem
from shells.continuation import ContinuationSettings
from shells.critical import CriticalSettings, follow
K = int(sys.argv[1])
P = FoldProblem()
real = P.assemble_residual
n = [0]
def spoilt(b):
    n[0] += 1
    real(b)
    if n[0] == K:
        traceback.print_stack(limit=6)
        b.set(math.nan)
P.assemble_residual = spoilt
out = list(follow(P, ContinuationSettings(ds=0.1, ds_max=0.2), 3.0, CriticalSettings(rel_tol=1e-8)))
found = [c for _, _, cps in out for c in cps]
print(K, [(c.kind, c.kappa, c.accuracy, c.evaluations, c.kappa_lo, c.kappa_hi) for c in found])
