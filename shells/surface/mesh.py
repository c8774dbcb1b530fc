"""gmsh meshes of the analytic shapes, graded in the rim boundary layer, read in parallel.

``MeshSpec`` says what to mesh; ``generate`` builds the gmsh model on rank 0 and distributes it with
``dolfinx.io.gmshio``; ``write_msh``/``load_mesh`` store and read a mesh (a ``.msh`` file plus a
``.msh.json`` sidecar holding the shape, so the analytic normal and curvature travel with it).

Rotational symmetry: the surface is split into ``sectors`` congruent sectors about the axis and
gmsh meshes one of them, copying its mesh onto the others by rotation (periodic surfaces), so
the mesh is exactly invariant under the rotation by 2π/sectors. The axisymmetric state then
stays exactly C_k-symmetric, and a loss of symmetry into a mode m that is not a multiple of k is
a perfect bifurcation of the discrete problem, as it is of the shell: on a one-piece mesh the
mesh's own asymmetry makes every such bifurcation imperfect, and a continuation in small steps
turns smoothly onto the buckled branch without any eigenvalue crossing (docs/model.md,
"Symmetric meshes: perfect bifurcations"). For k = 8 (the default) the pairs m = 1, 2, 3, 5,
6, 7 are exactly double, m = 4 splits into two perfect pitchforks, m = 8 is imperfect.

Element size: ``size`` (bulk, relative to the shape's size) away from the rim, and
``sqrt(R h) / layer_elements`` within ``layer_widths * sqrt(R h)`` of the rim, where the boundary
layer of width sqrt(R h) lives. Geometry is second order by default, with nodes on the exact
surface. Physical tags: surface = 1 (cells), rim = 1 (facets).
"""

from __future__ import annotations

import contextlib
import json
import logging
import math
import os
from collections.abc import Iterator
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from shells.errors import InputError
from shells.geometry.catalogue import mesh_reference, onto_shape, shape_from_description
from shells.geometry.shapes import Disk, EllipsoidalCap, Shape, Sphere

if TYPE_CHECKING:
    import dolfinx.mesh
    from mpi4py import MPI

__all__ = ["MeshSpec", "ShellMesh", "generate", "write_msh", "load_mesh", "SURFACE_TAG", "RIM_TAG",
           "estimate_cells", "estimate_cap_cells", "check_mesh_size"]

SURFACE_TAG = 1
RIM_TAG = 1


@dataclass(frozen=True)
class MeshSpec:
    """What to mesh and how finely.

    Attributes:
        shape: the analytic surface.
        h: shell thickness (same units as the shape); sets the boundary-layer width sqrt(R h).
            ``None`` meshes uniformly.
        size: bulk element size relative to the shape's characteristic size.
        layer_elements: elements across one boundary-layer width sqrt(R h) at the rim.
        layer_widths: extent of the refined band, in boundary-layer widths.
        order: geometric order (1 or 2).
        sectors: k, the mesh is invariant under rotations by 2π/k about the axis (a multiple
            of 4, the rigid-motion gauge's points lying on the sectors' edges; 1: one piece,
            no symmetry; see the module docstring).
    """

    shape: Shape
    h: float | None = None
    size: float = 0.1
    layer_elements: float = 4.0
    layer_widths: float = 3.0
    order: int = 2
    sectors: int = 8

    def __post_init__(self) -> None:
        if self.h is not None and not (math.isfinite(self.h) and self.h > 0):
            raise InputError(f"thickness h must be positive, got {self.h!r}")
        if not (math.isfinite(self.size) and 0 < self.size <= 2):
            raise InputError(f"element size must lie in (0, 2] (relative), got {self.size!r}")
        if not (math.isfinite(self.layer_elements) and self.layer_elements > 0):
            raise InputError(f"layer_elements must be positive, got {self.layer_elements!r}")
        if not self.layer_widths > 0:
            raise InputError(f"layer_widths must be positive, got {self.layer_widths!r}")
        if self.order not in (1, 2):
            raise InputError(f"geometric order must be 1 or 2, got {self.order!r}")
        if not (isinstance(self.sectors, int) and (self.sectors == 1 or (
                self.sectors % 4 == 0 and 4 <= self.sectors <= 64))):
            raise InputError(f"sectors must be 1 or a multiple of 4 in [4, 64], got "
                             f"{self.sectors!r}")
        if self.sectors == 1 and not self.shape.has_pole:
            # the apex and gauge nodes lie on the sector edges (on OCC's seam with one piece)
            raise InputError("a torus is meshed in sectors: give a multiple of 4")

    @property
    def bulk_size(self) -> float:
        return self.size * self.shape.characteristic_size()

    @property
    def layer_width(self) -> float | None:
        """Boundary-layer width sqrt(R h) (R: ``Shape.layer_radius``), or None without
        thickness."""
        if self.h is None or self.shape.closed:
            return None
        return math.sqrt(self.shape.layer_radius() * self.h)

    @property
    def layer_size(self) -> float:
        w = self.layer_width
        return self.bulk_size if w is None else min(self.bulk_size, w / self.layer_elements)

    def describe(self) -> dict[str, Any]:
        d = {k: v for k, v in asdict(self).items() if k != "shape"}
        d["shape"] = self.shape.describe()
        return d

    @classmethod
    def from_description(cls, d: dict[str, Any], sectors_if_missing: int = 8) -> MeshSpec:
        """The spec of a description (``describe``).

        Args:
            d: the description.
            sectors_if_missing: the sectors of a description without the key: 1 for a mesh
                sidecar (a mesh written without sectors is one piece), the default for a spec
                file.

        Returns:
            The ``MeshSpec``.
        """
        kw = {k: d[k] for k in ("h", "size", "layer_elements", "layer_widths", "order") if k in d}
        return cls(shape=shape_from_description(d["shape"]),
                   sectors=d.get("sectors", sectors_if_missing), **kw)


@dataclass
class ShellMesh:
    """A distributed dolfinx surface mesh with its tags and (when known) its analytic shape."""

    mesh: dolfinx.mesh.Mesh
    cell_tags: dolfinx.mesh.MeshTags | None
    facet_tags: dolfinx.mesh.MeshTags | None
    shape: Shape | None = None
    spec: MeshSpec | None = None
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def comm(self) -> MPI.Comm:
        return self.mesh.comm

    def num_cells(self) -> int:
        imap = self.mesh.topology.index_map(self.mesh.topology.dim)
        return int(imap.size_global)

    def area(self) -> float:
        """Area of the discrete surface, summed over all ranks."""
        import ufl
        from dolfinx import fem
        from mpi4py import MPI

        one = fem.Constant(self.mesh, 1.0)
        local = fem.assemble_scalar(fem.form(one * ufl.dx(domain=self.mesh)))
        return float(self.comm.allreduce(local, op=MPI.SUM))

    def rim_length(self) -> float:
        """Length of the tagged rim, summed over all ranks (0 for closed surfaces)."""
        import ufl
        from dolfinx import fem
        from mpi4py import MPI

        if self.facet_tags is None:
            return 0.0
        ds = ufl.Measure("ds", domain=self.mesh, subdomain_data=self.facet_tags)
        one = fem.Constant(self.mesh, 1.0)
        local = fem.assemble_scalar(fem.form(one * ds(RIM_TAG)))
        return float(self.comm.allreduce(local, op=MPI.SUM))

    def summary(self) -> dict[str, Any]:
        """Sizes and the area/rim errors against the exact shape."""
        out: dict[str, Any] = {"cells": self.num_cells(),
                               "nodes": int(self.mesh.geometry.index_map().size_global),
                               "area": self.area(), "rim_length": self.rim_length()}
        if self.shape is not None and self.shape.of_revolution:  # a MeshSurface is no exact shape
            out["area_exact"] = self.shape.area()
            out["rim_length_exact"] = self.shape.rim_length()
            out["area_rel_error"] = abs(out["area"] / out["area_exact"] - 1)
            if out["rim_length_exact"] > 0:
                out["rim_rel_error"] = abs(out["rim_length"] / out["rim_length_exact"] - 1)
        if self.spec is not None:
            out["spec"] = self.spec.describe()
        return out


@contextlib.contextmanager
def gmsh_model(name: str) -> Iterator[Any]:
    """A fresh gmsh model; gmsh is initialised once per process, quietly, not grabbing SIGINT."""
    import gmsh

    if not gmsh.isInitialized():
        try:
            gmsh.initialize(interruptible=False)
        except TypeError:  # older gmsh
            gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.option.setNumber("General.Verbosity", 1)
    gmsh.model.add(name)
    try:
        yield gmsh
    finally:
        gmsh.model.remove()


def _spherical_cap_volume(gmsh: Any, R: float, theta: float) -> int:
    """OCC solid of the ball sector above colatitude theta; returns its tag."""
    occ = gmsh.model.occ
    lat_min = max(-math.pi / 2, math.pi / 2 - theta)
    return occ.addSphere(0, 0, 0, R, -1, lat_min, math.pi / 2, 2 * math.pi)


def _build_geometry(gmsh: Any, shape: Shape) -> list[int]:
    """Create the OCC surface of ``shape``; return its surface tags."""
    occ = gmsh.model.occ
    if isinstance(shape, Disk):
        s = occ.addDisk(0, 0, 0, shape.radius, shape.radius)
        occ.synchronize()
        return [s]
    if not shape.has_pole:  # a torus: the boundary of OCC's solid torus
        v = occ.addTorus(0, 0, 0, shape.ring, shape.radius)
        occ.synchronize()
        faces = [t for _, t in gmsh.model.getBoundary([(3, v)], oriented=False)]
        occ.remove([(3, v)])
        occ.synchronize()
        return faces

    R = shape.radius  # both SphericalCap/Sphere and EllipsoidalCap have .radius
    # (an ellipsoidal cap: the spherical cap of the same parametric angle, dilated along the
    # axis by ``_dilate`` once cut into sectors: OCC's dilated sphere is a BSpline surface whose
    # seam does not match a cut at azimuth 0)
    v = _spherical_cap_volume(gmsh, R, math.pi if shape.closed else shape.t_max)
    occ.synchronize()
    faces = [t for _, t in gmsh.model.getBoundary([(3, v)], oriented=False)]
    # the ball sector's flat base (absent for a closed sphere) is not part of the shell
    drop = [] if shape.closed else [f for f in faces if _is_flat(gmsh, f, R)]
    keep = [f for f in faces if f not in drop]
    occ.remove([(3, v)])
    if drop:
        occ.remove([(2, f) for f in drop])
    occ.synchronize()
    return keep


def _rim_curves(gmsh: Any, shape: Shape, surfaces: list[int]) -> list[int]:
    """The rim: the boundary of positive length in the plane z = z_rim (none if closed)."""
    if shape.closed:
        return []
    if isinstance(shape, Disk):
        return [c for d, c in gmsh.model.getBoundary([(2, f) for f in surfaces], combined=True,
                                                     oriented=False) if d == 1]
    occ, R = gmsh.model.occ, shape.radius
    bnd = gmsh.model.getBoundary([(2, f) for f in surfaces], combined=True, oriented=False)
    # drop OCC's degenerate pole edge and the seam
    z_rim = shape.rim_height()
    return [c for d, c in bnd if d == 1 and occ.getMass(1, c) > 1e-9 * R
            and _on_plane(gmsh, 1, c, z_rim, R)]


def _cut_sectors(gmsh: Any, shape: Shape, surfaces: list[int], k: int) -> list[int]:
    """Split ``surfaces`` (not yet dilated, ``_dilate``) into k sectors by the half-planes
    through the axis at azimuths 2πj/k, with a vertex on each sector edge at the gauge parallel
    (``gauge_points``); returns the sector faces, sorted by azimuth."""
    occ = gmsh.model.occ
    box = gmsh.model.getBoundingBox(-1, -1)
    size = 4.0 * max(abs(b) for b in box) + shape.characteristic_size()
    tools = []
    for j in range(k):
        r = occ.addRectangle(0.0, -size, 0.0, size, 2.0 * size)  # x >= 0 in the xy plane
        occ.rotate([(2, r)], 0, 0, 0, 1, 0, 0, math.pi / 2)     # into the xz plane
        occ.rotate([(2, r)], 0, 0, 0, 0, 0, 1, 2 * math.pi * j / k)
        tools.append((2, r))
    _, pieces = occ.fragment([(2, f) for f in surfaces], tools)
    faces = sorted({t for m in pieces[: len(surfaces)] for _, t in m})
    tool_faces = {t for m in pieces[len(surfaces):] for _, t in m} - set(faces)
    occ.remove([(2, t) for t in tool_faces], recursive=True)
    occ.synchronize()
    pts = []
    if not isinstance(shape, Disk):
        for r_g, z_g in _edge_points(shape):
            if isinstance(shape, EllipsoidalCap):
                z_g *= shape.radius / shape.r3
            for j in range(k):
                a = 2 * math.pi * j / k
                pts.append((0, occ.addPoint(r_g * math.cos(a), r_g * math.sin(a), z_g)))
        out, _ = occ.fragment([(2, f) for f in faces], pts)
        faces = [t for d, t in out if d == 2]
    occ.synchronize()
    if len(faces) != k:
        raise RuntimeError(f"meshing: {len(faces)} sector faces, expected {k}")

    def azimuth(f: int) -> float:
        x, y, _ = occ.getCenterOfMass(2, f)
        return math.atan2(y, x) % (2 * math.pi)

    return sorted(faces, key=azimuth)


def _dilate(gmsh: Any, shape: Shape, surfaces: list[int]) -> None:
    """An ellipsoidal cap: the spherical cap dilated along the axis by r3 / R."""
    if isinstance(shape, EllipsoidalCap):
        gmsh.model.occ.dilate([(2, f) for f in surfaces], 0, 0, 0, 1, 1, shape.r3 / shape.radius)
        gmsh.model.occ.synchronize()


def _set_periodic(gmsh: Any, faces: list[int]) -> None:
    """Sectors 1..k-1 (sorted by azimuth) meshed as copies of sector 0 rotated about z."""
    k = len(faces)
    for j, f in enumerate(faces[1:], 1):
        a = 2 * math.pi * j / k
        c, s = math.cos(a), math.sin(a)
        gmsh.model.mesh.setPeriodic(2, [f], [faces[0]],
                                    [c, -s, 0, 0, s, c, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1])


#: OCC pads bounding boxes by an absolute tolerance (~1e-7 model units on each side), so a
#: bound relative to R alone misses the flat base and the rim of small caps (R < 0.25); the
#: base is told by its surface type (docs/design-notes.md, "Meshes")
_BOX_PAD = 1e-6


def _is_flat(gmsh: Any, face: int, R: float) -> bool:
    if gmsh.model.getType(2, face) == "Plane":  # the ball sector's base (OCC's own type)
        return True
    _, _, zmin, _, _, zmax = gmsh.model.getBoundingBox(2, face)
    return abs(zmax - zmin) < 1e-9 * R


def _on_plane(gmsh: Any, dim: int, tag: int, z: float, R: float) -> bool:
    _, _, zmin, _, _, zmax = gmsh.model.getBoundingBox(dim, tag)
    tol = 1e-6 * R + _BOX_PAD
    return abs(zmax - z) < tol and abs(zmin - z) < tol


def _set_sizes(gmsh: Any, spec: MeshSpec, rim: list[int]) -> None:
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeMax", spec.bulk_size)
    width = spec.layer_width
    if _pole_refinement(gmsh, spec):
        return
    if not rim or width is None or spec.layer_size >= spec.bulk_size:
        gmsh.option.setNumber("Mesh.MeshSizeMin", spec.bulk_size)
        return
    length = sum(gmsh.model.occ.getMass(1, c) for c in rim)
    _graded_sizes(gmsh, "CurvesList", rim, spec.layer_size, spec.bulk_size,
                  spec.layer_widths * width,
                  sampling=int(min(20000, max(200, 4 * length / spec.layer_size))))


#: growth of the element size per unit distance across a graded transition (gmsh's Threshold
#: field, linear from the fine size to the coarse one): about 20 % per element
GRADING_SLOPE = 0.2


def _graded_sizes(gmsh: Any, kind: str, tags: list[int], fine: float, coarse: float,
                  dist_min: float, sampling: int | None = None) -> None:
    """Elements of size ``fine`` within ``dist_min`` of the entities ``tags`` (``kind``: the
    Distance field's "CurvesList" or "PointsList"), growing at most ~20 % per element to
    ``coarse`` beyond: the background mesh size."""
    field_ = gmsh.model.mesh.field
    gmsh.option.setNumber("Mesh.MeshSizeMin", fine)
    dist = field_.add("Distance")
    field_.setNumbers(dist, kind, tags)
    if sampling is not None:
        field_.setNumber(dist, "Sampling", sampling)
    thr = field_.add("Threshold")
    field_.setNumber(thr, "InField", dist)
    field_.setNumber(thr, "SizeMin", fine)
    field_.setNumber(thr, "SizeMax", coarse)
    field_.setNumber(thr, "DistMin", dist_min)
    field_.setNumber(thr, "DistMax", dist_min + max(coarse - fine, 0.0) / GRADING_SLOPE)
    field_.setAsBackgroundMesh(thr)


#: elements across the width β0 of an imperfect sphere's pole dimple (P3 elements resolve the
#: Gaussian's curvature with 4)
DIMPLE_ELEMENTS = 4.0


def _pole_refinement(gmsh: Any, spec: MeshSpec) -> bool:
    """A closed imperfect sphere with a pole dimple of width β0: elements of β0 R / 4 within
    3 β0 of the pole, growing to the bulk size beyond. True if set."""
    from shells.geometry.imperfections import ImperfectSphere

    shape = spec.shape
    if not (isinstance(shape, ImperfectSphere) and shape.closed and shape.profile == "dimple"):
        return False
    R = shape.radius
    fine = min(shape.width * R / DIMPLE_ELEMENTS, spec.bulk_size)
    pole = [t for _, t in gmsh.model.getEntities(0)
            if np.allclose(gmsh.model.getValue(0, t, []), [0.0, 0.0, R], atol=1e-6 * R)]
    if not pole or fine >= spec.bulk_size:
        return False
    _graded_sizes(gmsh, "PointsList", pole, fine, spec.bulk_size, 3 * shape.width * R)
    return True


def _move_onto_shape(gmsh: Any, shape: Shape) -> None:
    """Move the nodes of the generated mesh of ``mesh_reference(shape)`` onto ``shape``
    (``geometry.onto_shape``), in the gmsh model itself: the mesh written to a .msh file and
    the one distributed to dolfinx are both the moved one."""
    if mesh_reference(shape) is shape:
        return
    tags, x, _ = gmsh.model.mesh.getNodes()
    y = onto_shape(shape, np.asarray(x, dtype=float).reshape(-1, 3))
    for tag, p in zip(tags, y, strict=True):
        gmsh.model.mesh.setNode(int(tag), p.tolist(), [])


def _edge_points(shape: Shape) -> list[tuple[float, float]]:
    """(r, z) of the meridian points that get a node on every sector edge: the gauge
    parallel's, and on a shape without poles also the top and bottom of the meridian (t = 0,
    π: where the model reads its apex displacement)."""
    r_g, _, z_g = gauge_points(shape)[0]
    out = [(r_g, z_g)]
    if not shape.has_pole:
        out += [tuple(float(v) for v in shape.meridian(np.array(t))) for t in (0.0, math.pi)]
    return out


def gauge_points(shape: Shape) -> list[tuple[float, float, float]]:
    """Points the surface model's rigid-motion gauge uses; meshes have nodes there.

    On curved shells: three points of the parallel t = t_max / 2 at azimuth 0, pi/2, pi.
    """
    if isinstance(shape, Disk):
        return []
    t = 0.5 * (math.pi if shape.closed else shape.t_max)
    r, z = (float(v) for v in shape.meridian(np.array(t)))
    return [(r, 0.0, z), (0.0, r, z), (-r, 0.0, z)]


def _embed_gauge_points(gmsh: Any, shape: Shape, surfaces: list[int]) -> None:
    occ = gmsh.model.occ
    if isinstance(shape, Disk):  # a node at the centre (the model's gauge)
        centre = occ.addPoint(0, 0, 0)
        occ.synchronize()
        gmsh.model.mesh.embed(0, [centre], 2, surfaces[0])
        return
    pts = []
    for x, y, z in gauge_points(shape)[1:]:  # azimuth 0 lies on the OCC seam, which has nodes
        pts.append(occ.addPoint(x, y, z))
    occ.synchronize()
    if pts:
        gmsh.model.mesh.embed(0, pts, 2, surfaces[0])


def _build_model(gmsh: Any, spec: MeshSpec) -> None:
    # an imperfect sphere, a meridian table: a sphere's or a cap's mesh, moved onto the shape
    # (_move_onto_shape)
    shape = mesh_reference(spec.shape)
    surfaces = _build_geometry(gmsh, shape)
    if spec.sectors > 1:
        surfaces = _cut_sectors(gmsh, shape, surfaces, spec.sectors)
        _dilate(gmsh, shape, surfaces)
        _set_periodic(gmsh, surfaces)
    else:
        _dilate(gmsh, shape, surfaces)
        _embed_gauge_points(gmsh, shape, surfaces)
    rim = _rim_curves(gmsh, shape, surfaces)
    gmsh.model.addPhysicalGroup(2, surfaces, SURFACE_TAG, name="surface")
    if rim:
        gmsh.model.addPhysicalGroup(1, rim, RIM_TAG, name="rim")
    _set_sizes(gmsh, spec, rim)
    gmsh.option.setNumber("Mesh.Algorithm", 6)
    gmsh.model.mesh.generate(2)
    if spec.order > 1:
        gmsh.model.mesh.setOrder(spec.order)
    _move_onto_shape(gmsh, spec.shape)


# --------------------------------------------------------------------------------------------
# cell-count and memory estimate, checked before meshing
# --------------------------------------------------------------------------------------------
#: Triangles per unit area at element size s: 2.5 / s^2. An equilateral triangle of side s has
#: area (sqrt 3 / 4) s^2, i.e. 2.31 / s^2; gmsh's frontal-Delaunay meshes come slightly above
#: (docs/design-notes.md, "Meshes"; tests/test_validation.py checks two estimates).
CELLS_PER_SIZE2 = 2.5
#: Peak resident memory of ``shells mesh`` per cell, bytes: above the per-cell peak of the
#: meshing, reading and distribution, with a margin (docs/design-notes.md, "Meshes").
MESH_BYTES_PER_CELL = 2048
#: Resident memory of one process before meshing (dolfinx, gmsh, PETSc imported), rounded up
#: (docs/design-notes.md, "Meshes").
PROCESS_BASE_BYTES = 256 * 2**20


def estimate_cells(spec: MeshSpec) -> float:
    """An upper estimate of the number of triangles gmsh makes for ``spec``.

    From the size field of ``_set_sizes``: bulk size, the rim band at the layer size, the
    graded transition.

    Args:
        spec: the mesh.

    Returns:
        The estimate (inf where the sizes overflow).
    """
    try:
        return _estimate_cells(spec)
    except (ZeroDivisionError, OverflowError):  # a size of 5e-324 squared, a radius of 1e300
        return math.inf


def _estimate_cells(spec: MeshSpec) -> float:
    shape = spec.shape
    L = shape.characteristic_size()
    area = shape.area() / L**2  # in units of L
    s_b = spec.bulk_size / L
    s_l = spec.layer_size / L
    c = CELLS_PER_SIZE2
    bulk = c * area / s_b**2
    w = spec.layer_width
    rim = 0.0 if shape.closed else shape.rim_length() / L
    if w is None or rim <= 0 or s_l >= s_b:
        return bulk
    band = spec.layer_widths * w / L  # DistMin: the band at the layer size
    grow = (s_b - s_l) / GRADING_SLOPE  # DistMax - DistMin: size linear from s_l to s_b over it
    layer = c * rim * band / s_l**2
    graded = c * rim * grow / (s_l * s_b)  # integral of 1/s(x)^2 across the transition
    return min(bulk + layer + graded, c * area / s_l**2)


def estimate_cap_cells(spec: MeshSpec, samples: int = 2001) -> float:
    """The number of triangles gmsh makes for ``spec`` of a spherical cap (``SphericalCap``).

    ``CELLS_PER_SIZE2`` / s² integrated over the cap, s the size field of ``_set_sizes`` at the
    chord distance from the rim: the layer size within the rim band, growing by
    ``GRADING_SLOPE`` to the bulk size. Unlike ``estimate_cells`` it follows the band where it
    covers most of the cap (docs/design-notes.md, "Surface model defaults": its error).

    Args:
        spec: the mesh; its shape a spherical cap.
        samples: quadrature points over the polar angle.

    Returns:
        The estimate.
    """
    shape = spec.shape
    R, theta = shape.R, shape.theta
    s_b, s_l = spec.bulk_size, spec.layer_size
    band = spec.layer_widths * (spec.layer_width or 0.0)
    phi = np.linspace(0.0, theta, samples)
    dist = 2.0 * R * np.sin(0.5 * (theta - phi))  # chord to the rim along the meridian
    s = np.clip(s_l + GRADING_SLOPE * (dist - band), s_l, s_b)
    f = CELLS_PER_SIZE2 / s**2 * 2.0 * math.pi * R**2 * np.sin(phi)
    return float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(phi)))


def memory_limit() -> int | None:
    """Bytes of memory this machine (or the cgroup it runs in, if smaller) can hold."""
    limit = None
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemTotal:"):
                    limit = int(line.split()[1]) * 1024
                    break
    except (OSError, ValueError, IndexError):
        pass
    try:
        with open("/sys/fs/cgroup/memory.max") as f:
            v = f.read().strip()
        if v.isdigit():
            limit = int(v) if limit is None else min(limit, int(v))
    except OSError:
        pass
    return limit


def check_mesh_size(spec: MeshSpec, comm: MPI.Comm | None = None) -> float:
    """Refuse a mesh whose estimated memory, over all ranks, exceeds the machine's memory.

    Args:
        spec: the mesh.
        comm: the ranks that will hold it (default ``MPI.COMM_WORLD``).

    Returns:
        The estimated number of cells.

    Raises:
        InputError: on every rank of ``comm``, if the mesh is too large.
    """
    from mpi4py import MPI as _MPI

    comm = _MPI.COMM_WORLD if comm is None else comm
    err = None
    cells = 0.0
    if comm.rank == 0:
        cells = estimate_cells(spec)
        need = comm.size * PROCESS_BASE_BYTES + cells * MESH_BYTES_PER_CELL
        limit = memory_limit()
        if not math.isfinite(cells) or (limit is not None and need > limit):
            err = (f"the mesh would have about {cells:.3g} cells and need about "
                   f"{need / 2**30:.3g} GiB, more than this machine's "
                   f"{(limit or 0) / 2**30:.3g} GiB of memory: use a larger --size (now "
                   f"{spec.size:g}) or fewer --layer-elements (now {spec.layer_elements:g})")
    if comm.size > 1:
        err, cells = comm.bcast((err, cells), root=0)
    if err:
        raise InputError(err)
    return cells


def generate(spec: MeshSpec, comm: MPI.Comm | None = None, msh_path: str | os.PathLike | None = None
             ) -> ShellMesh:
    """Mesh ``spec`` with gmsh on rank 0 of ``comm`` and distribute it over ``comm``.

    A mesh too large for the machine's memory is refused first (``check_mesh_size``).

    Args:
        spec: the mesh.
        comm: the communicator (default ``MPI.COMM_WORLD``).
        msh_path: rank 0 also writes the gmsh file there, with its JSON sidecar.

    Returns:
        The distributed mesh.

    Raises:
        InputError: if the mesh is too large.
    """
    from dolfinx.io import gmshio
    from mpi4py import MPI as _MPI

    comm = _MPI.COMM_WORLD if comm is None else comm
    check_mesh_size(spec, comm)
    with gmsh_model(f"shells-{spec.shape.kind}") as gmsh:
        if comm.rank == 0:
            _build_model(gmsh, spec)
            if msh_path is not None:
                _write_current(gmsh, spec, Path(msh_path))
        mesh, cell_tags, facet_tags = gmshio.model_to_mesh(gmsh.model, comm, 0, gdim=3)[:3]
    mesh.name = f"shells-{spec.shape.kind}"
    return ShellMesh(mesh, cell_tags, facet_tags, spec.shape, spec)


def _write_current(gmsh: Any, spec: MeshSpec, path: Path) -> None:
    if path.suffix != ".msh":
        raise InputError(f"mesh output must be a gmsh .msh file, got {str(path)!r}")
    path.parent.mkdir(parents=True, exist_ok=True)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.option.setNumber("Mesh.Binary", 0)
    gmsh.write(str(path))
    sidecar = {"shells_mesh": 1, "spec": spec.describe()}
    Path(str(path) + ".json").write_text(json.dumps(sidecar, indent=2) + "\n")


def write_msh(spec: MeshSpec, path: str | os.PathLike, comm: MPI.Comm | None = None) -> None:
    """Mesh ``spec`` on rank 0 of ``comm`` and write it.

    Args:
        spec: the mesh.
        path: the ``.msh`` file; its JSON sidecar is ``path``.json.
        comm: the communicator (default ``MPI.COMM_WORLD``).

    Raises:
        InputError: if the mesh is too large.
    """
    from mpi4py import MPI as _MPI

    comm = _MPI.COMM_WORLD if comm is None else comm
    check_mesh_size(spec, comm)
    err = None
    if comm.rank == 0:
        try:
            with gmsh_model(f"shells-{spec.shape.kind}") as gmsh:
                _build_model(gmsh, spec)
                _write_current(gmsh, spec, Path(path))
        except InputError as e:
            err = str(e)
    err = comm.bcast(err, root=0)
    if err:
        raise InputError(err)


def _check_msh(path: Path) -> None:
    if not path.exists():
        raise InputError(f"mesh file not found: {str(path)!r}")
    if path.is_dir():
        raise InputError(f"mesh path is a directory, not a gmsh .msh file: {str(path)!r}")
    try:
        with open(path, "rb") as f:
            head = f.read(64)
    except OSError as e:
        raise InputError(f"cannot read mesh file {str(path)!r}: {e.strerror}") from None
    if not head.lstrip().startswith(b"$MeshFormat"):
        raise InputError(f"{str(path)!r} is not a gmsh .msh mesh file (no $MeshFormat header)")


def _checked(path: str | os.PathLike, comm: MPI.Comm) -> Path:
    """``path`` once rank 0 has found it a readable .msh file (``_check_msh``), before gmsh
    starts; else ``InputError`` on every rank."""
    path = Path(path)
    err = None
    if comm.rank == 0:
        try:
            _check_msh(path)
        except InputError as e:
            err = str(e)
    err = comm.bcast(err, root=0)
    if err:
        raise InputError(err)
    return path


def _sidecar_spec(path: Path) -> MeshSpec | None:
    """The spec in a mesh file's ``.msh.json`` sidecar (None without one)."""
    sidecar = Path(str(path) + ".json")
    if not sidecar.exists():
        return None
    try:
        return MeshSpec.from_description(json.loads(sidecar.read_text())["spec"],
                                         sectors_if_missing=1)
    except (KeyError, ValueError, TypeError) as e:
        raise InputError(f"mesh sidecar {str(sidecar)!r} is not valid: {e}") from None


def _read_on_rank0(gmsh: Any, path: Path, comm: MPI.Comm, recover: bool) -> Shape | None:
    """Rank 0 merges ``path`` (checked by ``_checked``) into ``gmsh``; with ``recover``, the
    shape recovered from its nodes (``_user_mesh_shape``), on every rank. Any error:
    ``InputError`` on every rank."""
    err = table = None
    if comm.rank == 0:
        try:
            gmsh.merge(str(path))
            if not gmsh.model.getEntities(2):
                err = f"{str(path)!r} holds no surface (no 2D elements)"
            elif recover:
                table = _user_mesh_shape(gmsh, str(path))
            elif not gmsh.model.getPhysicalGroups(2):
                err = (f"{str(path)!r} holds no tagged surface (a shells mesh has a 2D "
                       "physical group)")
        except InputError as e:
            err = f"{str(path)!r}: {e}"
        except Exception as e:  # gmsh raises a bare Exception on malformed files
            err = f"{str(path)!r} could not be read as a gmsh mesh: {e}"
    err, table = comm.bcast((err, table), root=0)
    if err:
        raise InputError(err)
    return table


def read_mesh_shape(path: str | os.PathLike, comm: MPI.Comm | None = None) -> Shape:
    """The shape of a gmsh ``.msh`` file without building its mesh: its sidecar's, or, for a
    mesh made elsewhere, the meridian recovered from its nodes (as ``load_mesh`` does)."""
    from mpi4py import MPI as _MPI

    comm = _MPI.COMM_WORLD if comm is None else comm
    path = _checked(path, comm)
    spec = _sidecar_spec(path)
    with gmsh_model("shells-read") as gmsh:
        recovered = _read_on_rank0(gmsh, path, comm, recover=spec is None)
    return spec.shape if spec is not None else recovered


def load_mesh(path: str | os.PathLike, comm: MPI.Comm | None = None) -> ShellMesh:
    """Read a gmsh ``.msh`` surface mesh in parallel.

    The shape comes from its JSON sidecar, or, for a mesh made elsewhere, from its nodes (a
    surface of revolution about z).

    Args:
        path: the ``.msh`` file.
        comm: the communicator (default ``MPI.COMM_WORLD``).

    Returns:
        The distributed mesh.

    Raises:
        InputError: if the file is missing, unreadable or not a surface mesh.
    """
    from dolfinx.io import gmshio
    from mpi4py import MPI as _MPI

    comm = _MPI.COMM_WORLD if comm is None else comm
    path = _checked(path, comm)
    spec = _sidecar_spec(path)
    shape = spec.shape if spec is not None else None
    with gmsh_model("shells-read") as gmsh:
        recovered = _read_on_rank0(gmsh, path, comm, recover=spec is None)
        if recovered is not None:
            shape = recovered
        mesh, cell_tags, facet_tags = gmshio.model_to_mesh(gmsh.model, comm, 0, gdim=3)[:3]
    if mesh.topology.dim != 2:
        raise InputError(f"{str(path)!r} is not a surface mesh (topological dimension "
                         f"{mesh.topology.dim}, expected 2)")
    if recovered is not None:
        facet_tags = _tag_boundary(mesh)
    return ShellMesh(mesh, cell_tags, facet_tags, shape, spec)


def _tag_boundary(mesh: Any) -> Any:
    """The facets on the boundary of a user's mesh, tagged as the rim (its file may hold no
    boundary elements: gmsh saves only those of physical groups; any it has are not used)."""
    from dolfinx import mesh as dmesh

    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    facets = dmesh.exterior_facet_indices(mesh.topology)
    return dmesh.meshtags(mesh, tdim - 1, facets, np.full(len(facets), RIM_TAG, dtype=np.int32))


def _user_mesh_shape(gmsh: Any, path: str = "") -> Shape:
    """A mesh made outside ``shells`` (no sidecar): its surface put in the physical group a
    shells mesh has, if it has none (gmsh's reader takes the cells of physical groups only),
    and its shape recovered from its nodes: the meridian of a surface of revolution about z
    (``MeridianTable.from_nodes``), a torus about z (``Torus.from_nodes``, without a node on
    the axis), or else the surface known only by its mesh (``surface_fit.MeshSurface``: normal
    and curvatures fitted at its nodes; the surface model only). The rim is tagged on the
    dolfinx mesh (``_tag_boundary``)."""
    from shells.geometry.meridian import MeridianTable
    from shells.geometry.shapes import Torus
    from shells.geometry.surface_fit import MeshSurface

    model = gmsh.model
    if not model.getPhysicalGroups(2):
        model.addPhysicalGroup(2, [t for _, t in model.getEntities(2)], SURFACE_TAG)
    tags, x, _ = model.mesh.getNodes()
    x = np.asarray(x, dtype=float).reshape(-1, 3)
    try:
        if not (np.hypot(x[:, 0], x[:, 1]) < 1e-9 * float(np.max(np.abs(x)))).any():
            return Torus.from_nodes(x)
        return MeridianTable.from_nodes(x)
    except InputError as e:
        why = str(e)
    index = {int(t): i for i, t in enumerate(tags)}
    tris = []
    for etype, _, enodes in zip(*model.mesh.getElements(2), strict=True):
        name, _, _, nn, *_ = model.mesh.getElementProperties(etype)
        if not name.startswith("Triangle"):
            raise InputError(f"the mesh holds {name} elements: triangles only")
        conn = np.asarray(enodes, dtype=np.int64).reshape(-1, nn)
        tris.append(np.vectorize(index.__getitem__)(conn))
    if len({t.shape[1] for t in tris}) > 1:
        tris = [t[:, :3] for t in tris]  # mixed orders: the corners
    shape = MeshSurface.from_mesh(x, np.vstack(tris), file=path)
    logging.getLogger("shells").debug("mesh: not of revolution about z or a torus (%s)", why)
    return shape


def sphere_spec(h_over_r: float, size: float = 0.1, order: int = 2) -> MeshSpec:
    """Convenience: unit sphere of thickness h/R."""
    return MeshSpec(Sphere(1.0), h=h_over_r, size=size, order=order)
