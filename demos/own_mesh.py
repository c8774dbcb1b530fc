"""Your own mesh, made with gmsh
=============================

Any surface meshed by the user runs on the surface model: ``shells.mesh("file.msh")``. A
mesh that is a surface of revolution about z is recognised as such: its meridian is
recovered from the nodes and its rim tagged, so the 1D model runs on it too (the default
for a shell of revolution), and the two models can be compared on the user's own shape.

Here the mesh is a 30° spherical cap made with gmsh's own Python API, as one would outside
``shells``: the curved face of an OpenCASCADE ball sector, second-order triangles, finer at
the rim where the boundary layer is. The quick mode runs the 1D model on the recovered
meridian, on a coarse mesh; the full mode also locates the snap-through fold on the
surface model, on a finer mesh.
"""

# %%
import math
import os
import sys
from pathlib import Path

import gmsh
from mpi4py import MPI

import shells

QUICK = os.environ.get("SHELLS_DEMO_QUICK") == "1" or "--quick" in sys.argv
OUT = Path(os.environ.get("SHELLS_DEMO_OUT", "results/demos")) / "own_mesh"
comm = MPI.COMM_WORLD

# %% [markdown]
# The mesh
# --------
#
# Rank 0 writes the file; every rank reads it.


# %%
def write_cap_mesh(path: Path, theta_deg: float, size: float, rim_size: float) -> None:
    """A spherical cap of radius 1: the curved face of a ball sector, meshed with gmsh."""
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("cap")
    occ = gmsh.model.occ
    th = math.radians(theta_deg)
    vol = occ.addSphere(0, 0, 0, 1.0, -1, math.pi / 2 - th, math.pi / 2, 2 * math.pi)
    occ.synchronize()
    faces = [t for _, t in gmsh.model.getBoundary([(3, vol)], oriented=False)]
    keep = [f for f in faces if gmsh.model.getType(2, f) != "Plane"]
    occ.remove([(3, vol)])
    occ.remove([(2, f) for f in faces if f not in keep])
    occ.synchronize()
    rim = [c for d, c in gmsh.model.getBoundary([(2, f) for f in keep], combined=True,
                                                oriented=False)
           if d == 1 and occ.getMass(1, c) > 1e-6]
    fields = gmsh.model.mesh.field
    dist = fields.add("Distance")
    fields.setNumbers(dist, "CurvesList", rim)
    thr = fields.add("Threshold")
    fields.setNumber(thr, "InField", dist)
    fields.setNumber(thr, "SizeMin", rim_size)
    fields.setNumber(thr, "SizeMax", size)
    fields.setNumber(thr, "DistMin", 0.2)
    fields.setNumber(thr, "DistMax", 0.5)
    fields.setAsBackgroundMesh(thr)
    for opt in ("MeshSizeFromPoints", "MeshSizeFromCurvature", "MeshSizeExtendFromBoundary"):
        gmsh.option.setNumber(f"Mesh.{opt}", 0)
    gmsh.model.addPhysicalGroup(2, keep, 1)
    gmsh.model.mesh.generate(2)
    gmsh.model.mesh.setOrder(2)
    gmsh.write(str(path))
    gmsh.finalize()


path = OUT / "my_cap.msh"
if comm.rank == 0:
    OUT.mkdir(parents=True, exist_ok=True)
    write_cap_mesh(path, 30.0, size=0.35 if QUICK else 0.1, rim_size=0.15 if QUICK else 0.04)
comm.barrier()
geometry = shells.mesh(path)
shell = shells.Shell(geometry, h_over_r=0.04)
if comm.rank == 0:
    print(f"the mesh's shape: {geometry.describe()['shape']}")

# %% [markdown]
# The 1D model on the recovered meridian
# --------------------------------------

# %%
one_d = shells.critical(shell, direction="up", first_only=True)
if comm.rank == 0:
    print(f"1D model on the mesh's meridian: {one_d.kind} at kappa R = {one_d.kappa_R:.5f}")

# %% [markdown]
# The surface model on the mesh itself
# ------------------------------------
#
# ``model="surface"`` computes on the user's triangles (the mesh file is the surface
# model's mesh; its degree of approximation is raised to the model's P3 on tables). The
# full mode locates the fold on it at P3 (a few minutes; the quick mode stops at the 1D model).

# %%
if not QUICK:
    surf = shells.critical(shell, direction="up", model="surface", first_only=True)
    if comm.rank == 0:
        print(f"surface model on the mesh: {surf.kind} at kappa R = {surf.kappa_R:.5f}")
    fig = surf.plot()
    assert surf.kind == "fold" and abs(surf.kappa_R / one_d.kappa_R - 1) < 2e-3

# %% [markdown]
# Checks
# ------
#
# The recovered meridian's fold is the built-in 30° cap's, κR = 1.3934, to the mesh's
# accuracy.

# %%
assert one_d.kind == "fold" and abs(one_d.kappa_R - 1.3934) < 5e-3
