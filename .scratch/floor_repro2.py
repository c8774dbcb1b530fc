import math, sys
import numpy as np
from shells.axisym import SNES_OPTIONS
from shells.axisym.model import AxisymModel, AxisymParameters
from shells.geometry import Sphere
from shells.solvers import NewtonSolver
from shells.stimulus import CurvatureField
h = float(sys.argv[1]); cells = 2500
NewtonSolver.NOISE_FACTOR = float(sys.argv[2])
fld = CurvatureField(f"step(0.8 - theta, {0.25 * math.sqrt(h):.6g})")
orig = NewtonSolver._converged
log = []
def conv(self, snes, its, norms):
    r = orig(self, snes, its, norms); log.append((its, *norms, r)); return r
NewtonSolver._converged = conv
def run(steps, kh=0.002):
    m = AxisymModel(Sphere(1.0), AxisymParameters(h=h, nu=0.5, cells=cells, penalty=1e6, kappa_field=fld))
    ns = NewtonSolver(m, options={**SNES_OPTIONS})
    for k in range(1, steps + 1):
        log.clear()
        m.set_kappa(kh * k / steps / h)
        ok, its = ns.solve()
        print(f"step {k}/{steps}: its={its}", " ".join(f"[{f:.1e} y/x={y/max(x,1e-300):.1e}]" for _, x, y, f, r in log))
    p = m.meridian_profile()
    return p["ur"] * np.sin(p["t"]) + p["uz"] * np.cos(p["t"])
a = run(1); b = run(4)
print("rel diff", np.linalg.norm(a - b) / np.linalg.norm(a))
