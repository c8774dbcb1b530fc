"""A spherical cap meshed with gmsh's own Python API, as a user would outside shells: an OCC ball
sector's curved face, second order, finer towards the rim, the surface alone in a physical group
(so the file holds no boundary elements). Optionally stretched along x (not a surface of
revolution).

    python3 gmsh_cap.py OUT.msh [--theta-deg 30] [--size 0.1] [--rim-size 0.05] [--stretch 1]
"""

import argparse
import math

import gmsh

p = argparse.ArgumentParser()
p.add_argument("out")
p.add_argument("--theta-deg", type=float, default=30.0)
p.add_argument("--size", type=float, default=0.1)
p.add_argument("--rim-size", type=float, default=0.05)
p.add_argument("--stretch", type=float, default=1.0)
a = p.parse_args()
gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.model.add("cap")
occ = gmsh.model.occ
th = math.radians(a.theta_deg)
v = occ.addSphere(0, 0, 0, 1.0, -1, math.pi / 2 - th, math.pi / 2, 2 * math.pi)
occ.synchronize()
faces = [t for _, t in gmsh.model.getBoundary([(3, v)], oriented=False)]
keep = [f for f in faces if gmsh.model.getType(2, f) != "Plane"]
occ.remove([(3, v)])
occ.remove([(2, f) for f in faces if f not in keep])
occ.synchronize()
rim = [c for d, c in gmsh.model.getBoundary([(2, f) for f in keep], combined=True,
                                            oriented=False) if d == 1 and occ.getMass(1, c) > 1e-6]
fld = gmsh.model.mesh.field
dist = fld.add("Distance")
fld.setNumbers(dist, "CurvesList", rim)
fld.setNumber(dist, "Sampling", 400)
thr = fld.add("Threshold")
fld.setNumber(thr, "InField", dist)
fld.setNumber(thr, "SizeMin", a.rim_size)
fld.setNumber(thr, "SizeMax", a.size)
fld.setNumber(thr, "DistMin", 0.3)
fld.setNumber(thr, "DistMax", 0.6)
fld.setAsBackgroundMesh(thr)
for opt in ("MeshSizeFromPoints", "MeshSizeFromCurvature", "MeshSizeExtendFromBoundary"):
    gmsh.option.setNumber(f"Mesh.{opt}", 0)
gmsh.model.addPhysicalGroup(2, keep, 7)
gmsh.model.mesh.generate(2)
gmsh.model.mesh.setOrder(2)
if a.stretch != 1.0:
    tags, x, _ = gmsh.model.mesh.getNodes()
    for t, i in zip(tags, range(0, len(x), 3), strict=True):
        gmsh.model.mesh.setNode(int(t), [x[i] * a.stretch, x[i + 1], x[i + 2]], [])
gmsh.write(a.out)
gmsh.finalize()
