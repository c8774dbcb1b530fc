"""The rigid-motion gauge of a surface known only by its mesh (surface model): which six
displacement components of which nodes are held at zero.

``mesh_gauge`` chooses them from the nodes alone, in numpy, so that the choice is the same on
every rank (each holds the whole mesh's nodes) and testable without a model.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["MeshGauge", "RING_CONDITIONING_MIN", "mesh_gauge", "rotation_conditioning",
           "three_two_one_gauge"]

#: the azimuthal gauge is taken where its constraints fix the rigid motions with a smallest
#: singular value at least this fraction of the best 3-2-1 gauge's. The ring's height below A
#: is what fixes the tilts: on caps the fraction grows with the depth, on a flat mesh it is 0
#: (docs/kappa-fields.md). The surfaces of revolution's gauge, the same constraints, serves
#: caps of any depth; this bound only refuses the nearly flat.
RING_CONDITIONING_MIN = 1.0e-3


class MeshGauge(NamedTuple):
    """Six scalar constraints u_comp(point) = 0.

    Attributes:
        kind: "azimuthal" (about the vertical through the highest node) or "3-2-1".
        points: the nodes, the highest node A first.
        constraints: (index into ``points``, displacement component 0, 1 or 2), six of them.
    """

    kind: str
    points: list[np.ndarray]
    constraints: list[tuple[int, int]]


def _cross_matrix(r: np.ndarray) -> np.ndarray:
    """The matrix of ω ↦ ω × r."""
    return -np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])


def rotation_conditioning(points: list[np.ndarray], constraints: list[tuple[int, int]]) -> float:
    """The smallest singular value of the map from the rigid motions (translation t, rotation
    ω about ``points[0]``) to the constrained components of t + ω × (x - points[0]): zero iff
    some rigid motion meets every constraint."""
    a = points[0]
    rows = []
    for i, comp in constraints:
        row = np.zeros(6)
        row[comp] = 1.0
        row[3:] = _cross_matrix(points[i] - a)[comp]
        rows.append(row)
    return float(np.linalg.svd(np.array(rows), compute_uv=False)[-1])


def three_two_one_gauge(x: np.ndarray) -> MeshGauge:
    """The 3-2-1 gauge of the surface whose nodes are ``x`` (n × 3): u = 0 at the highest node
    A, two components of u at the node B farthest from A and one at the node C farthest from
    the line AB, the components chosen (of the 9 choices) whose ``rotation_conditioning`` is
    largest. It fixes every rigid motion of any mesh that is not a straight line, but a state
    symmetric about the vertical through A meets it only turned (``mesh_gauge``).

    Args:
        x: the mesh's node coordinates (every node, the same on every rank).

    Returns:
        The ``MeshGauge`` (kind "3-2-1", points A, B, C).
    """
    a = x[int(np.argmax(x[:, 2]))]
    d = x - a
    b = x[int(np.argmax(np.linalg.norm(d, axis=1)))]
    e = (b - a) / np.linalg.norm(b - a)
    c = x[int(np.argmax(np.linalg.norm(d - np.outer(d @ e, e), axis=1)))]
    translation = [(0, 0), (0, 1), (0, 2)]
    options = [translation + [(1, i) for i in range(3) if i != drop] + [(2, k)]
               for drop in range(3) for k in range(3)]
    best = max(options, key=lambda o: rotation_conditioning([a, b, c], o))
    return MeshGauge("3-2-1", [a, b, c], best)


def mesh_gauge(x: np.ndarray) -> MeshGauge:
    """The gauge of the surface whose nodes are ``x`` (n × 3).

    Preferably the surfaces of revolution's gauge about the vertical through the highest node
    A: u = 0 at A, and the azimuthal components about that vertical (u_y, u_x, u_y) at the
    nodes B, C, D nearest the azimuths 0, π/2, π of the ring at half the mesh's largest
    horizontal distance from A (least angular offset, then nearest the ring: u_y at azimuth δ
    reads the radial displacement by sin δ). A state that is axisymmetric about that vertical
    meets it with a translation only. Any six independent constraints cost no energy in this
    geometrically exact model (a finite rigid motion meets them), but a gauge that a state
    meets only turned makes Newton find that finite rotation from a predictor that extrapolates
    linearly: on a cap's user mesh the steps Newton converges from shrink by an order of
    magnitude (``tests/test_surface_fit.py``).

    Where that gauge cannot fix the tilts (``RING_CONDITIONING_MIN``: a nearly flat mesh), the
    ``three_two_one_gauge``.

    Args:
        x: the mesh's node coordinates (every node, the same on every rank).

    Returns:
        The ``MeshGauge``.
    """
    a = x[int(np.argmax(x[:, 2]))]
    d = x - a
    rho = np.hypot(d[:, 0], d[:, 1])
    ring = 0.5 * float(rho.max())
    fallback = three_two_one_gauge(x)
    near = (rho > 0.5 * ring) & (rho < 1.5 * ring)
    ring_nodes = []
    for ax, side in ((0, 1.0), (1, 1.0), (0, -1.0)):  # azimuths 0, π/2, π
        ok = near & (side * d[:, ax] > 0)
        if not ok.any():
            return fallback
        offset = np.abs(d[:, 1 - ax]) / np.maximum(rho, 1e-300)
        score = np.where(ok, offset + 0.1 * np.abs(rho / ring - 1.0), np.inf)
        ring_nodes.append(x[int(np.argmin(score))])
    azimuthal = MeshGauge("azimuthal", [a, *ring_nodes],
                          [(0, 0), (0, 1), (0, 2), (1, 1), (2, 0), (3, 1)])
    if (rotation_conditioning(azimuthal.points, azimuthal.constraints)
            >= RING_CONDITIONING_MIN * rotation_conditioning(fallback.points,
                                                             fallback.constraints)):
        return azimuthal
    return fallback
