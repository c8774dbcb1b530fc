import math, sys, time
import numpy as np
from shells.axisym import SNES_OPTIONS
from shells.axisym.model import AxisymModel, AxisymParameters
from shells.geometry import Sphere
from shells.solvers import NewtonSolver
from shells.stimulus import CurvatureField

h, cells = float(sys.argv[1]) if len(sys.argv) > 1 else 0.001, 2500
fld = CurvatureField(f"step(0.8 - theta, {0.25 * math.sqrt(h):.6g})")
def run(steps, kh=0.002):
    m = AxisymModel(Sphere(1.0), AxisymParameters(h=h, nu=0.5, cells=cells, penalty=1e6,
                                                  kappa_field=fld))
    ns = NewtonSolver(m, options={**SNES_OPTIONS})
    hist = []
    ns.snes.setMonitor(lambda s, it, f: hist.append(f))
    for k in range(1, steps + 1):
        hist.clear()
        m.set_kappa(kh * k / steps / h)
        ok, its = ns.solve()
        print(f"step {k}: ok={ok} its={its} noise_acc={ns.noise_accepted} "
              f"floor={ns.roundoff_floor():.2e} noise={ns._test['noise']} hist="
              + " ".join(f"{f:.2e}" for f in hist))
    print("noise at end", ns.residual_noise(), "floor", ns.roundoff_floor())
    p = m.meridian_profile()
    return p["ur"] * np.sin(p["t"]) + p["uz"] * np.cos(p["t"])
if len(sys.argv) > 2: NewtonSolver.NOISE_FACTOR = float(sys.argv[2])
a = run(1); b = run(4)
print("rel diff", np.linalg.norm(a - b) / np.linalg.norm(a))
