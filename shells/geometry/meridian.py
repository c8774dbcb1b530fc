"""Any shell of revolution (geometry layer): a meridian given as a table of points r(s), z(s)
from the pole, a cubic spline through them and their mirror images at the axis
(``MeridianTable``), read from a file or recovered from a mesh's nodes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from shells.errors import InputError
from shells.geometry.shapes import CAP_THETA_MAX_DEG, Shape, Sphere, SphericalCap

__all__ = ["MeridianTable"]


@dataclass(frozen=True)
class MeridianTable(Shape):
    """Any shell of revolution about z, its meridian a table of points (r, z) from the pole
    (r = 0, first) to the rim, or to the other pole (r = 0 again: a closed shell).

    The meridian is the cubic spline through the points and their mirror images across the
    axis (so it meets the axis at a right angle and is smooth there), parametrised by the
    chord length t from the first pole. Every reference quantity (normal, metric, curvatures)
    comes from the spline's derivatives, computed once here. The axisymmetric model takes it;
    the surface model interpolates its ``normal`` (no closed form in UFL), on a mesh of
    ``reference_shape()`` moved onto the surface by ``from_reference``.
    """

    points: tuple[tuple[float, float], ...] = ()
    kind = "meridian"

    def __post_init__(self) -> None:
        try:
            pts = np.asarray(self.points, dtype=float)
        except (TypeError, ValueError):
            pts = np.zeros((0,))
        if pts.ndim != 2 or pts.shape[1] != 2 or not 4 <= len(pts) <= 100000:
            raise InputError("a meridian table needs 4 to 100000 rows of two numbers (r z), "
                             "from the pole to the rim")
        if not np.all(np.isfinite(pts)):
            raise InputError("a meridian table holds a value that is not finite")
        size = float(np.max(np.abs(pts)))
        if size <= 0 or abs(pts[0, 0]) > 1e-9 * size:
            raise InputError("a meridian table must start on the axis (r = 0: the pole)")
        if np.any(pts[1:-1, 0] <= 0) or pts[-1, 0] < -1e-9 * size:
            raise InputError("a meridian table must have r > 0 between its ends (one side of "
                             "the axis)")
        if np.any(np.hypot(*np.diff(pts, axis=0).T) <= 1e-9 * size):
            raise InputError("a meridian table repeats a point")
        pts[0, 0] = 0.0
        closed = abs(pts[-1, 0]) <= 1e-9 * size
        if closed:
            pts[-1, 0] = 0.0
        from scipy.interpolate import CubicSpline

        # mirror images across the axis at each pole: r odd, z even in t there
        mirror = lambda q: q[::-1] * np.array([-1.0, 1.0])  # noqa: E731
        full = np.vstack([mirror(pts[1:4]), pts] + ([mirror(pts[-4:-1])] if closed else []))
        s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(full, axis=0).T))])
        s0, s1 = s[3], s[3 + len(pts) - 1]
        spline = CubicSpline(s - s0, full)
        object.__setattr__(self, "points", tuple(tuple(float(v) for v in p) for p in pts))
        object.__setattr__(self, "_spline", spline)
        object.__setattr__(self, "_t_max", float(s1 - s0))
        object.__setattr__(self, "_closed", bool(closed))
        (dr, dz), (ddr, ddz) = spline(0.0, 1), spline(0.0, 2)
        k = (dr * ddz - dz * ddr) / (dr**2 + dz**2) ** 1.5  # signed curvature at the pole
        object.__setattr__(self, "_R", float(-1.0 / k) if k < -1e-9 / size else math.inf)
        object.__setattr__(self, "_size", size)

    @property
    def closed(self) -> bool:
        return self._closed  # type: ignore[attr-defined]

    @property
    def t_max(self) -> float:
        return self._t_max  # type: ignore[attr-defined]

    @property
    def R(self) -> float:  # noqa: N802
        """The pole's radius of curvature (inf if the pole is flat or curved the other way)."""
        return self._R  # type: ignore[attr-defined]

    def characteristic_size(self) -> float:
        return self.R if math.isfinite(self.R) else float(max(p[0] for p in self.points))

    def layer_radius(self) -> float:
        """The azimuthal radius of curvature at the rim, r/|n_r| (flat rims: the size)."""
        if self.closed:
            return self.characteristic_size()
        r, _ = self.meridian(np.array(self.t_max))
        dr, dz = self.meridian_derivative(np.array(self.t_max))
        n_r = abs(float(dz)) / math.hypot(float(dr), float(dz))
        return float(r) / n_r if n_r > 1e-6 else self.characteristic_size()

    def meridian(self, t):
        v = self._spline(np.asarray(t, dtype=float))  # type: ignore[attr-defined]
        return v[..., 0], v[..., 1]

    def meridian_derivative(self, t):
        v = self._spline(np.asarray(t, dtype=float), 1)  # type: ignore[attr-defined]
        return v[..., 0], v[..., 1]

    def meridian_second_derivative(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        v = self._spline(np.asarray(t, dtype=float), 2)  # type: ignore[attr-defined]
        return v[..., 0], v[..., 1]

    def meridian_parameter(self, x: np.ndarray) -> np.ndarray:
        """t of the meridian point nearest to each point x (shape (3, N) or (3,)): the nearest
        of 4097 samples (a k-d tree: every interpolation point of a mesh asks), then Newton on
        (γ(t) - p)·γ'(t) = 0 (to round-off for points on the surface, as mesh nodes are)."""
        from scipy.spatial import cKDTree

        x = np.asarray(x, dtype=float)
        p = np.stack([np.hypot(x[0], x[1]), x[2]], axis=-1).reshape(-1, 2)
        sp = self._spline  # type: ignore[attr-defined]
        ts = np.linspace(0.0, self.t_max, 4097)
        t = ts[cKDTree(sp(ts)).query(p)[1]]
        for _ in range(8):
            e, d1, d2 = sp(t) - p, sp(t, 1), sp(t, 2)
            f = np.sum(e * d1, axis=1)
            df = np.sum(d1 * d1, axis=1) + np.sum(e * d2, axis=1)
            t = np.clip(t - f / df, 0.0, self.t_max)
        return t.reshape(x.shape[1:])

    def _frame(self, x: np.ndarray) -> tuple[np.ndarray, ...]:
        """t, the unit tangent (dr, dz), cos φ and sin φ at points x."""
        x = np.asarray(x, dtype=float)
        t = self.meridian_parameter(x)
        dr, dz = self.meridian_derivative(t)
        s = np.hypot(dr, dz)
        phi = np.arctan2(x[1], x[0])
        return t, dr / s, dz / s, np.cos(phi), np.sin(phi)

    def normal(self, x):
        """Outward unit normal: (-dz, dr) in the meridian plane (a sphere's x/R)."""
        _, tr, tz, c, s = self._frame(x)
        return np.stack([-tz * c, -tz * s, tr])

    def principal_curvatures(self, x):
        """Meridional (r'z'' - z'r'')/|γ'|³ and azimuthal -n_r / r, with the paper's sign (-1/R
        on a sphere); on the axis both are the meridional one."""
        t, tr, tz, _, _ = self._frame(x)
        (dr, dz), (ddr, ddz) = self.meridian_derivative(t), self.meridian_second_derivative(t)
        k1 = (dr * ddz - dz * ddr) / np.hypot(dr, dz) ** 3
        r, _ = self.meridian(t)
        with np.errstate(divide="ignore", invalid="ignore"):
            k2 = np.where(r > 1e-9 * self._size, tz / r, k1)  # type: ignore[attr-defined]
        return k1, k2

    def normal_ufl(self, x):
        raise InputError("a meridian table has no closed-form normal: the surface model "
                         "interpolates ``normal`` (has_ufl_normal is False)")

    has_ufl_normal = False

    def reference_shape(self) -> Shape:
        """The sphere (closed tables) or spherical cap whose mesh ``onto_shape`` maps onto this
        surface: of the table's meridian length, its angle chosen so that its rim radius is
        the table's (sin θ / θ = r_rim / t_max), at least 5° (flatter tables: a 5° cap)."""
        if self.closed:
            return Sphere(self.t_max / math.pi)
        r_rim = float(self.meridian(np.array(self.t_max))[0])
        q = min(r_rim / self.t_max, math.sin(math.radians(5)) / math.radians(5))
        lo, hi = math.radians(5), math.radians(CAP_THETA_MAX_DEG)
        for _ in range(100):  # sin θ / θ decreases on (0, π]
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if math.sin(mid) / mid > q else (lo, mid)
        theta = 0.5 * (lo + hi)
        return SphericalCap(self.t_max / theta, theta)

    def from_reference(self, x: np.ndarray) -> np.ndarray:
        """Points x (N, 3) of ``reference_shape()`` moved onto this surface: the polar angle β
        to the meridian parameter t = R_ref β (arc length kept), the azimuth kept."""
        ref = self.reference_shape()
        beta = np.arctan2(np.hypot(x[:, 0], x[:, 1]), x[:, 2])
        t = np.clip(beta * ref.radius, 0.0, self.t_max)
        r, z = self.meridian(t)
        phi = np.arctan2(x[:, 1], x[:, 0])
        return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)

    def describe(self) -> dict[str, Any]:
        return {"shape": self.kind, "points": [list(p) for p in self.points],
                "R_pole": self.R, "closed": self.closed}

    @classmethod
    def from_nodes(cls, x: np.ndarray, points: int = 400, tol: float = 1e-6) -> MeridianTable:
        """The meridian of a surface of revolution about z from nodes on it (x: (N, 3), a user's
        mesh): their (r, z) ordered by the distance from the top pole (monotone along convex
        meridians, caps and closed shells alike), about ``points`` of them kept at even spacing.
        Refused (``InputError``) unless a node lies on the axis at the top, and unless every
        node lies within ``tol`` (relative to the size) of the surface so recovered: a surface
        that is not one of revolution about z, or nodes off it."""
        x = np.asarray(x, dtype=float).reshape(-1, 3)
        size = float(np.max(np.abs(x)))
        rz = np.column_stack([np.hypot(x[:, 0], x[:, 1]), x[:, 2]])
        on_axis = rz[:, 0] < 1e-9 * size
        if not on_axis.any():
            raise InputError("the mesh has no node on the z axis: a surface of revolution about "
                             "z needs a node at its pole")
        top = np.array([0.0, rz[on_axis, 1].max()])
        d = np.hypot(*(rz - top).T)
        order = np.argsort(d)
        rz, d = rz[order], d[order]
        keep = [0]
        step = float(np.sum(np.hypot(*np.diff(rz, axis=0).T))) / points  # the meridian's length
        for i in range(1, len(d)):
            if math.dist(rz[i], rz[keep[-1]]) >= step:  # even along the curve, poles included
                keep.append(i)
        if keep[-1] != len(d) - 1:
            keep[-1] = len(d) - 1  # the rim (or the bottom pole) itself
        pts = rz[keep].copy()
        pts[0] = top
        closed = bool(pts[-1, 0] < 1e-9 * size)
        if closed:
            pts[-1, 0] = 0.0
        try:
            tab = cls(tuple(map(tuple, pts)))
        except InputError as e:
            raise InputError(f"the mesh's nodes give no meridian ({e}): is it a surface of "
                             "revolution about z?") from None
        rr, zz = tab.meridian(tab.meridian_parameter(x.T))
        off = float(np.max(np.hypot(rr - np.hypot(x[:, 0], x[:, 1]), zz - x[:, 2]))) / size
        if off > tol:
            raise InputError(f"the mesh is not a surface of revolution about the z axis: its "
                             f"nodes lie up to {off:.2g} (relative) off the meridian through "
                             "them (the surface model takes such meshes only)")
        return tab

    @classmethod
    def from_file(cls, path: str) -> MeridianTable:
        """Rows "r z" from the pole to the rim (spaces, tabs, commas or semicolons; # comments;
        a header row such as ``r,z`` names the columns, as pandas and spreadsheets write it)."""
        from shells.files import read_number_rows

        return cls(read_number_rows(path, "the meridian file", "'r z'", columns=(("r", "z"),)))
