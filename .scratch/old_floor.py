import sys
sys.path.insert(0, "tests")
import numpy as np
from shells.solvers import NewtonSolver
orig = NewtonSolver._converged
def old(self, snes, its, norms):
    if norms[2] <= self.roundoff_floor():
        return 2
    return orig(self, snes, its, norms)
NewtonSolver._converged = old
from test_solvers import _thin_sphere_profile
a, i1, _ = _thin_sphere_profile(1); b, i4, _ = _thin_sphere_profile(4)
print(i1, i4, np.linalg.norm(a - b) / np.linalg.norm(a))
