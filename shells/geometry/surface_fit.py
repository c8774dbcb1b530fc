"""The reference geometry of any surface mesh, recovered from its nodes (geometry layer).

A user's mesh that is neither a surface of revolution about z nor a torus (``shells.surface.mesh``)
has no analytic shape: ``MeshSurface`` recovers its normal and second fundamental form from the
mesh itself. The triangles are first oriented consistently (across every shared edge; a mesh
that cannot be, a Möbius strip, or whose edges are shared by more than two triangles, is
refused), outward on a closed surface (∫ x·n dA > 0), towards +z on an open one. At each node a
quartic height function z = f(u, v) over its tangent plane is fitted by least squares to the nodes
of the triangles around it and around their neighbours (two rings, up to four on a coarse
first-order mesh where two hold fewer than ``MIN_NODES``), in the frame of the
averaged triangle normals, then once more in the fit's own normal. The normal at a point x is
that of the fit of the node nearest x, at x's (u, v). On the nodes of a second-order mesh
(they lie on the surface) the normal converges at rate 5 and the curvatures (the fit's second
derivatives) at rate 4: on the 30° cap at sizes 0.2, 0.1, 0.05 the curvatures' largest errors
are 7.1e-3, 3.3e-4, 2.0e-5 (a cubic fit gave 6.3e-2, 1.5e-2, 4.4e-3). The surface model
interpolates this normal in Lagrange of one degree above its state's (as for a meridian table)
and takes b° = -∇n°.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from shells.errors import InputError
from shells.geometry.shapes import Shape

__all__ = ["MeshSurface"]

#: nodes a fit takes at least (14 coefficients; two rings of a second-order mesh hold 19-40,
#: a first-order mesh's rim node fewer: its rings grow to four)
MIN_NODES = 21
#: the monomials u^i v^j of the quartic fit (f(0, 0) = 0: the node lies on the surface)
_POWERS = [(i, d - i) for d in range(1, 5) for i in range(d, -1, -1)]


def _orient(tri: np.ndarray) -> np.ndarray:
    """Signs (+1 / -1) that orient the triangles ``tri`` (corner node indices, (M, 3))
    consistently across every shared edge; InputError if none can."""
    edges: dict[tuple[int, int], list[tuple[int, int]]] = {}
    for k, (a, b, c) in enumerate(tri):
        for p, q in ((a, b), (b, c), (c, a)):
            edges.setdefault((min(p, q), max(p, q)), []).append((k, 1 if p < q else -1))
    for e, owners in edges.items():
        if len(owners) > 2:
            raise InputError(f"the mesh is not a manifold surface: its edge {e} is shared by "
                             f"{len(owners)} triangles")
    nbr: list[list[tuple[int, int]]] = [[] for _ in range(len(tri))]
    for owners in edges.values():
        if len(owners) == 2:
            (k1, d1), (k2, d2) = owners
            # consistent: the shared edge is run through in opposite directions
            rel = -d1 * d2
            nbr[k1].append((k2, rel))
            nbr[k2].append((k1, rel))
    sign = np.zeros(len(tri), dtype=int)
    for start in range(len(tri)):
        if sign[start]:
            continue
        sign[start] = 1
        todo = deque([start])
        while todo:
            k = todo.popleft()
            for j, rel in nbr[k]:
                want = sign[k] * rel
                if sign[j] == 0:
                    sign[j] = want
                    todo.append(j)
                elif sign[j] != want:
                    raise InputError("the mesh cannot be oriented consistently (a Möbius-like "
                                     "surface): it has no normal field")
    return sign


def _fit(p: np.ndarray, n: np.ndarray, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The frame (e1, e2, n) at ``p`` and the quartic height function's coefficients fitted to
    ``pts`` (K, 3) in it."""
    e1 = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    d = pts - p
    u, v, w = d @ e1, d @ e2, d @ n
    scale = max(float(np.max(np.hypot(u, v))), 1e-300)
    A = np.column_stack([(u / scale) ** i * (v / scale) ** j for i, j in _POWERS])
    c, *_ = np.linalg.lstsq(A, w, rcond=None)
    c = c / np.array([scale ** (i + j) for i, j in _POWERS])
    return np.array([e1, e2, n]), c


def _derivatives(c: np.ndarray, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, ...]:
    """f_u, f_v, f_uu, f_uv, f_vv of the polynomial with coefficients c (rows: points) on the
    monomials ``_POWERS``."""
    out = [np.zeros_like(u) for _ in range(5)]
    for k, (i, j) in enumerate(_POWERS):
        ck = c[:, k]
        for m, (a, b) in enumerate(((1, 0), (0, 1), (2, 0), (1, 1), (0, 2))):
            if i >= a and j >= b:
                coef = math.perm(i, a) * math.perm(j, b)
                out[m] = out[m] + ck * coef * u ** (i - a) * v ** (j - b)
    return tuple(out)


@dataclass(frozen=True)
class MeshSurface(Shape):
    """A surface known only by its mesh (``from_mesh``): normal and curvatures from local quartic
    fits at its nodes (module docstring). ``R`` is 1 / (the area-weighted mean of |H|), H the
    mean curvature: a sphere's or cap's radius; κR and h/R are over it."""

    file: str = ""
    closed_surface: bool = False
    radius: float = 1.0
    surface_area: float = 0.0
    nodes: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)), compare=False,
                              repr=False)
    frames: np.ndarray = field(default_factory=lambda: np.zeros((0, 3, 3)), compare=False,
                               repr=False)
    coeffs: np.ndarray = field(default_factory=lambda: np.zeros((0, len(_POWERS))), compare=False,
                               repr=False)
    kind = "mesh"
    has_ufl_normal = False
    has_pole = False
    of_revolution = False

    # -- construction ------------------------------------------------------------------------
    @classmethod
    def from_mesh(cls, x: np.ndarray, tri: np.ndarray, file: str = "") -> MeshSurface:
        """From the nodes x (N, 3) and the triangles ``tri`` (M, 3 or 6: corners first, then
        edge midpoints, gmsh's order) of a surface mesh."""
        x = np.asarray(x, dtype=float).reshape(-1, 3)
        tri = np.asarray(tri, dtype=np.int64)
        if tri.ndim != 2 or tri.shape[1] < 3 or len(tri) == 0:
            raise InputError("the mesh has no triangles")
        corners = tri[:, :3]
        sign = _orient(corners)
        a, b, c = (x[corners[:, i]] for i in range(3))
        cn = np.cross(b - a, c - a) * sign[:, None]  # 2 × area × unit normal
        area2 = np.linalg.norm(cn, axis=1)
        if np.any(area2 <= 0):
            raise InputError("the mesh has degenerate triangles (zero area)")
        # boundary: corner edges owned once
        edges: dict[tuple[int, int], int] = {}
        for t in corners:
            for p, q in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
                e = (min(p, q), max(p, q))
                edges[e] = edges.get(e, 0) + 1
        closed = all(v == 2 for v in edges.values())
        centroid = (a + b + c) / 3
        if closed:
            flip = float(np.sum(np.einsum("ij,ij->i", centroid - centroid.mean(axis=0), cn))) < 0
        else:
            flip = float(np.sum(cn[:, 2])) < 0
        if flip:
            cn, sign = -cn, -sign
        # node normals: the triangles' normals summed (area-weighted) over each node's triangles
        nn = np.zeros_like(x)
        for k in range(tri.shape[1]):
            np.add.at(nn, tri[:, k], cn)
        used = np.linalg.norm(nn, axis=1) > 0
        nn[used] /= np.linalg.norm(nn[used], axis=1)[:, None]
        # two rings of triangles around each node
        node_tris: list[list[int]] = [[] for _ in range(len(x))]
        for k, t in enumerate(tri):
            for i in t:
                node_tris[i].append(k)
        frames = np.zeros((len(x), 3, 3))
        coeffs = np.zeros((len(x), len(_POWERS)))
        for i in np.flatnonzero(used):
            ring = set(node_tris[i])
            for rings in range(1, 5):  # two rings, more where they hold too few nodes
                if rings >= 2 and len(pts := np.unique(tri[list(ring)].ravel())) >= MIN_NODES:
                    break
                ring = {k2 for k in ring for j in tri[k] for k2 in node_tris[j]}
            pts = x[np.unique(tri[list(ring)].ravel())]
            if len(pts) < MIN_NODES:
                raise InputError(f"the mesh is too coarse around node {i} for a curvature fit "
                                 f"({len(pts)} nodes in four rings of triangles, {MIN_NODES} "
                                 "needed)")
            F, co = _fit(x[i], nn[i], pts)
            fu, fv = co[0], co[1]  # the fit's own normal at the node, then fit again in it
            n1 = F[2] - fu * F[0] - fv * F[1]
            F, co = _fit(x[i], n1 / np.linalg.norm(n1), pts)
            frames[i], coeffs[i] = F, co
        keep = np.flatnonzero(used)
        shape = cls(file=str(file), closed_surface=closed, radius=1.0,
                    surface_area=float(0.5 * area2.sum()), nodes=x[keep], frames=frames[keep],
                    coeffs=coeffs[keep])
        # R: 1 / the area-weighted mean |H| over the triangles' centroids
        k1, k2 = shape.principal_curvatures(centroid.T)
        H = np.abs(0.5 * (k1 + k2))
        mean_h = float(np.sum(H * area2) / np.sum(area2))
        R = 1.0 / mean_h if mean_h > 0 else math.inf
        if not math.isfinite(R):
            raise InputError("the mesh is flat: give it as a disk (--shape disk)")
        object.__setattr__(shape, "radius", R)
        return shape

    # -- the fits ----------------------------------------------------------------------------
    def _tree(self) -> Any:
        t = self.__dict__.get("_kdtree")
        if t is None:
            from scipy.spatial import cKDTree

            t = cKDTree(self.nodes)
            object.__setattr__(self, "_kdtree", t)
        return t

    def _local(self, x: np.ndarray) -> tuple[np.ndarray, ...]:
        x = np.asarray(x, dtype=float)
        pts = x.reshape(3, -1).T
        _, idx = self._tree().query(pts)
        F, c = self.frames[idx], self.coeffs[idx]
        d = pts - self.nodes[idx]
        u = np.einsum("ij,ij->i", d, F[:, 0])
        v = np.einsum("ij,ij->i", d, F[:, 1])
        return F, c, u, v

    def normal(self, x):
        x = np.asarray(x, dtype=float)
        F, c, u, v = self._local(x)
        fu, fv, *_ = _derivatives(c, u, v)
        n = F[:, 2] - fu[:, None] * F[:, 0] - fv[:, None] * F[:, 1]
        n /= np.linalg.norm(n, axis=1)[:, None]
        return n.T.reshape(x.shape)

    def principal_curvatures(self, x):
        """The principal curvatures (min, max) of the fitted graph at x: the eigenvalues of
        its shape operator, with the paper's sign (b_ab = n·x_ab: negative on a sphere)."""
        x = np.asarray(x, dtype=float)
        _, c, u, v = self._local(x)
        fu, fv, fuu, fuv, fvv = _derivatives(c, u, v)
        w = np.sqrt(1 + fu * fu + fv * fv)
        E, Fm, G = 1 + fu * fu, fu * fv, 1 + fv * fv
        L_, M_, N_ = fuu / w, fuv / w, fvv / w
        det = E * G - Fm * Fm
        H = (E * N_ - 2 * Fm * M_ + G * L_) / (2 * det)
        K = (L_ * N_ - M_ * M_) / det
        disc = np.sqrt(np.maximum(H * H - K, 0.0))
        shp = x.shape[1:]
        return (H - disc).reshape(shp), (H + disc).reshape(shp)

    # -- Shape ---------------------------------------------------------------------------------
    @property
    def closed(self) -> bool:
        return self.closed_surface

    def area(self) -> float:
        """The area of the mesh's straight-sided triangles (the second-order mesh's own area
        is ``ShellMesh.area``)."""
        return self.surface_area

    def rim_length(self) -> float:
        return 0.0 if self.closed else math.nan

    def meridian(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        raise InputError("a surface known only by its mesh has no meridian (the 1D model needs "
                         "a surface of revolution about z)")

    def describe(self) -> dict[str, Any]:
        return {"shape": self.kind, "file": self.file, "R": self.radius,
                "closed": self.closed, "area": self.surface_area}
