"""The meridian mesh of the axisymmetric model (problem layer): a 1D interval mesh of the
meridian parameter, graded towards a free rim.

Geometry. The reference meridian (r°(t), z°(t)) of a ``shells.geometry.shapes`` shape (Sphere,
SphericalCap, EllipsoidalCap, Disk) is parametrised by its own parameter t (the colatitude of the
sphere/cap, the parametric colatitude of the spheroid, the radius of the disk) on a 1D interval
mesh of [0, t_max]; g(t) = |x°'(t)| converts to arclength, ds = g dt (g = R on a sphere, so the
mesh is uniform/graded in arclength s = R t there). With a free rim the cells are graded towards
it down to ``sqrt(R h) / layer_cells`` in arclength (the boundary layer).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from shells.errors import InputError
from shells.geometry.catalogue import perfect_shape
from shells.geometry.meridian import MeridianTable
from shells.geometry.shapes import Disk, EllipsoidalCap, Shape, SphericalCap

__all__ = ["MeridianMesh", "check_supported", "make_meridian_nodes"]


def check_supported(shape: Any) -> None:
    """Refuse a shape the 1D model cannot take.

    Args:
        shape: the shape.

    Raises:
        InputError: if it is not a surface of revolution with a pole, or not one of the
            1D model's shapes.
    """
    if not getattr(shape, "of_revolution", True):
        raise InputError("the mesh is not a surface of revolution about the z axis (nor a "
                         "torus): the 1D model needs one; the surface model takes it "
                         "(--model surface)")
    if not getattr(shape, "has_pole", True):
        raise InputError(f"the axisymmetric model needs a meridian from a pole, and a "
                         f"{shape.kind} has none: use the surface model (--model surface)")
    if not isinstance(shape, (SphericalCap, EllipsoidalCap, Disk, MeridianTable)):
        raise InputError(f"the axisymmetric model needs a sphere, cap, ellipsoid, disk or "
                         f"meridian table, got {type(shape).__name__}")


def _arclength_table(shape: Shape, n: int = 4001) -> tuple[np.ndarray, np.ndarray]:
    """(t, s(t)) on a fine grid: the meridian's arclength from the top pole."""
    t = np.linspace(0.0, shape.t_max, n)
    dr, dz = shape.meridian_derivative(t)
    g = np.hypot(dr, dz)
    s = np.concatenate([[0.0], np.cumsum(0.5 * (g[1:] + g[:-1]) * np.diff(t))])
    return t, s


def make_meridian_nodes(shape: Shape, h: float, cells: int, layer_cells: float,
                        grading: float) -> np.ndarray:
    """Sorted nodes in t of the meridian mesh.

    Closed shapes: uniform in arclength. A free rim: from the rim inwards, cells of arclength
    ``sqrt(R h) / layer_cells`` growing by ``grading`` up to the bulk size S / cells (S: the
    meridian's length), then uniform; the nodes are mapped back to t through s(t).

    Args:
        shape: the shell of revolution.
        h: the thickness.
        cells: the bulk cells.
        layer_cells: cells per sqrt(R h) at a free rim.
        grading: the growth factor of the cells away from the rim.

    Returns:
        The nodes, ascending.
    """
    # an imperfect sphere is meshed as its perfect sphere (nodes uniform in the angle from the
    # pole): every amplitude of a knock-down curve shares one mesh, so that states, residuals
    # and the imperfection's derivative dR/dδ compare DOF by DOF (the arclength changes by
    # O(δ²) only)
    t_tab, s_tab = _arclength_table(perfect_shape(shape))
    S = float(s_tab[-1])
    if shape.closed:
        s_nodes = np.linspace(0.0, S, cells + 1)
    else:
        ell = math.sqrt(shape.layer_radius() * h)
        bulk = S / cells
        size = min(ell / layer_cells, bulk)
        sizes, d = [], 0.0
        while d < S:
            sizes.append(size)
            d += size
            size = min(size * grading, bulk)
        sizes = np.array(sizes)
        sizes *= S / sizes.sum()  # fit exactly (the last, bulk-sized cells absorb the change)
        d_from_rim = np.concatenate([[0.0], np.cumsum(sizes)])
        s_nodes = np.sort(S - d_from_rim)
        s_nodes[0], s_nodes[-1] = 0.0, S
    t_nodes = np.interp(s_nodes, s_tab, t_tab)
    t_nodes[0], t_nodes[-1] = 0.0, shape.t_max
    return t_nodes


@dataclass
class MeridianMesh:
    """The 1D mesh of the meridian, on ``comm`` (MPI.COMM_SELF: every rank holds all of it)."""

    shape: Shape
    nodes: np.ndarray
    comm: Any = None
    mesh: Any = field(init=False)

    def __post_init__(self) -> None:
        from dolfinx import mesh as dmesh
        from mpi4py import MPI

        if self.comm is None:
            self.comm = MPI.COMM_SELF
        if self.comm.size != 1:
            raise InputError("the axisymmetric model runs on one process per communicator "
                             "(use MPI.COMM_SELF)")
        n = len(self.nodes) - 1
        self.mesh = dmesh.create_interval(self.comm, n, [0.0, float(self.nodes[-1])])
        self.mesh.topology.create_connectivity(0, 1)
        x = self.mesh.geometry.x
        idx = np.rint(x[:, 0] / float(self.nodes[-1]) * n).astype(int)
        x[:, 0] = self.nodes[idx]
