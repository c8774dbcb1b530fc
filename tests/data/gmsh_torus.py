"""A torus meshed with gmsh's own Python API, as a user would outside shells: OCC's torus,
second order, one piece (no sectors), the surface alone in a physical group.

    python3 gmsh_torus.py OUT.msh [--ring 3] [--radius 1] [--size 0.3]
"""

import argparse

import gmsh

p = argparse.ArgumentParser()
p.add_argument("out")
p.add_argument("--ring", type=float, default=3.0)
p.add_argument("--radius", type=float, default=1.0)
p.add_argument("--size", type=float, default=0.3)
a = p.parse_args()
gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.model.add("torus")
occ = gmsh.model.occ
v = occ.addTorus(0, 0, 0, a.ring, a.radius)
occ.synchronize()
faces = [t for _, t in gmsh.model.getBoundary([(3, v)], oriented=False)]
occ.remove([(3, v)])
occ.synchronize()
gmsh.option.setNumber("Mesh.MeshSizeMax", a.size)
gmsh.option.setNumber("Mesh.MeshSizeMin", a.size)
gmsh.model.addPhysicalGroup(2, faces, 7)
gmsh.model.mesh.generate(2)
gmsh.model.mesh.setOrder(2)
gmsh.write(a.out)
gmsh.finalize()
