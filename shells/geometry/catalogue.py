"""The shape catalogue (geometry layer): shapes by name (``make_shape``, the command line's
``--shape``), back from their description (``shape_from_description``, a mesh's sidecar), and
the reference shape a mesh is made for and moved from (``mesh_reference``, ``onto_shape``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from shells.errors import InputError
from shells.geometry.imperfections import HarmonicImperfectSphere, ImperfectSphere
from shells.geometry.meridian import MeridianTable
from shells.geometry.shapes import (
    CAP_THETA_MAX_DEG,
    Disk,
    EllipsoidalCap,
    Shape,
    Sphere,
    SphericalCap,
    Torus,
)

__all__ = ["SHAPES", "make_shape", "mesh_reference", "onto_shape", "perfect_shape",
           "shape_from_description"]


def perfect_shape(shape: Shape) -> Shape:
    """An imperfect sphere's perfect sphere (or cap); any other shape itself.

    Meshes of an imperfect sphere are those of its perfect shape (the surface mesh then moved
    onto it).

    Args:
        shape: the shape.

    Returns:
        Its perfect shape.
    """
    if isinstance(shape, ImperfectSphere):
        return Sphere(shape.radius) if shape.closed else SphericalCap(shape.radius, shape.theta)
    if isinstance(shape, HarmonicImperfectSphere):
        return Sphere(shape.radius)
    return shape


def mesh_reference(shape: Shape) -> Shape:
    """The shape whose gmsh mesh ``onto_shape`` moves onto ``shape``.

    Args:
        shape: the shape.

    Returns:
        An imperfect sphere's perfect one, a meridian table's ``reference_shape``; any other
        shape itself.
    """
    if isinstance(shape, MeridianTable):
        return shape.reference_shape()
    return perfect_shape(shape)


def onto_shape(shape: Shape, x: np.ndarray) -> np.ndarray:
    """Points x (N, 3) of a mesh of ``mesh_reference(shape)`` moved onto ``shape``: radially
    onto an imperfect sphere ρ(β) = R - δ f(β) (a harmonic one's ρ(θ, φ)), along the meridian
    onto a meridian table; every geometry node, the edges' midpoints too, so that a
    second-order mesh interpolates the surface.

    Args:
        shape: the shape.
        x: the points, (N, 3).

    Returns:
        The moved points (other shapes: x itself).
    """
    if isinstance(shape, MeridianTable):
        return shape.from_reference(x)
    if isinstance(shape, ImperfectSphere):
        r = np.linalg.norm(x, axis=1)
        beta = np.arccos(np.clip(x[:, 2] / r, -1.0, 1.0))
        return x * (shape.radius_at(beta) / r)[:, None]
    if isinstance(shape, HarmonicImperfectSphere):
        r = np.linalg.norm(x, axis=1)
        return x * (shape.rho((x / r[:, None]).T) / r)[:, None]
    return x


SHAPES = ("sphere", "cap", "ellipsoid", "disk", "torus")


def make_shape(kind: str, *, radius: float = 1.0, theta: float | None = None,
               r3: float | None = None, ring: float | None = None) -> Shape:
    """Build a shape from its name and parameters (the CLI and the mesh sidecar use this).

    Args:
        kind: one of ``SHAPES``.
        radius: the pole radius R (the disk's radius, the torus' tube radius).
        theta: a cap's half opening angle in radians (an ellipsoid's: default π/2).
        r3: the ellipsoid's axial semi-axis (default 1.5 R).
        ring: the distance of the torus' tube from the axis (default 3 R).

    Returns:
        The shape.

    Raises:
        InputError: for an unknown kind, a cap without ``theta``, a cap so deep it is a
            closed sphere, or parameters the shape refuses.
    """
    if kind == "sphere":
        return Sphere(radius=radius)
    if kind == "cap":
        if theta is None:
            raise InputError("the cap shape needs an opening angle (--theta-deg)")
        if isinstance(theta, (int, float)) and math.isfinite(theta) \
                and math.radians(CAP_THETA_MAX_DEG) < theta <= math.pi * (1 + 1e-12):
            raise InputError(
                f"a cap of theta = {math.degrees(theta):.6g} deg is a closed sphere (a cap needs "
                f"theta <= {CAP_THETA_MAX_DEG:g} deg): use the sphere shape (--shape sphere)")
        return SphericalCap(radius=radius, theta=theta)
    if kind == "ellipsoid":
        return EllipsoidalCap(radius=radius, r3=1.5 * radius if r3 is None else r3,
                              theta=math.pi / 2 if theta is None else theta)
    if kind == "disk":
        return Disk(radius=radius)
    if kind == "torus":
        return Torus(radius=radius, ring=3.0 * radius if ring is None else ring)
    raise InputError(f"unknown shape {kind!r}: choose one of {', '.join(SHAPES)}")


def shape_from_description(d: dict[str, Any]) -> Shape:
    """The shape of a description: the inverse of ``Shape.describe``.

    Args:
        d: the description.

    Returns:
        The shape.

    Raises:
        InputError: for an unknown kind, or a surface known only by its mesh (read from the
            mesh file instead).
    """
    kind = d.get("shape")
    if kind == "disk":
        return Disk(radius=float(d["radius"]))
    if kind == "sphere":
        return Sphere(radius=float(d["R"]))
    if kind == "cap":
        return SphericalCap(radius=float(d["R"]), theta=float(d["theta"]))
    if kind == "ellipsoid":
        return EllipsoidalCap(radius=float(d["R"]), r3=float(d["r3"]), theta=float(d["theta"]))
    if kind == "meridian":
        return MeridianTable(tuple(tuple(p) for p in d["points"]))
    if kind == "torus":
        return Torus(radius=float(d["R"]), ring=float(d["ring"]))
    if kind == "imperfect-sphere":
        return ImperfectSphere(float(d["R"]), float(d["theta"]), float(d["amplitude"]),
                               str(d["profile"]), float(d["width"]), int(d["degree"]))
    if kind == "harmonic-sphere":
        return HarmonicImperfectSphere(float(d["R"]), float(d["amplitude"]), int(d["degree"]),
                                       int(d["order"]))
    if kind == "mesh":
        raise InputError("a surface known only by its mesh is read from the mesh file "
                         f"({d.get('file')!r}), not from a description")
    raise InputError(f"unknown shape {kind!r} in mesh description")
