from shells.algebraic import FoldProblem
from shells.continuation import ContinuationSettings, continuation
from shells.axisym.model import AxisymModel, AxisymParameters
from shells.geometry import SphericalCap
import math
P = FoldProblem()
pts = list(continuation(P, ContinuationSettings(method="natural", ds=0.1, ds_max=0.2), kappa_end=-3.0))
print("fold problem down:", len(pts), sum(p.newton_its for p in pts), max(abs(p.scalars["w0"]-P.exact_x(p.kappa)) for p in pts))
m = AxisymModel(SphericalCap(1.0, math.radians(30)), AxisymParameters(h=0.04, nu=0.5, cells=200))
pts = list(continuation(m, ContinuationSettings(method="natural", ds=0.1, ds_max=0.2), kappa_end=-1.2))
print("cap down:", len(pts), sum(p.newton_its for p in pts), pts[-1].scalars)
