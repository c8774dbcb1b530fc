"""Kinematics shared by the 1D model's energy and its mode Hessians (model layer): the
displacement jet, the reference meridian in UFL, the compiled forms' options, the gauge's
Dirichlet conditions and the staleness check of the compiled forms' inputs.

``shells.axisym.model`` (the energy) and ``shells.axisym.modes`` (the Fourier-mode Hessians)
both build on these; neither imports the other's internals.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from shells.geometry.imperfections import ImperfectSphere
from shells.geometry.meridian import MeridianTable
from shells.geometry.shapes import Disk, EllipsoidalCap, Shape, SphericalCap
from shells.problem.formcache import cache_root

__all__ = ["JIT_OPTIONS", "Jet", "cross", "dirichlet", "dot", "is_sphere", "meridian_ufl",
           "read_inputs", "same_inputs"]

#: the mode Hessian's kernel is long to compile (the second variation of the whole density at
#: two phases); the 1D model's forms go to a cache folder of their own (``~/.cache/shells/ffcx``):
#: FFCx lists its cache folder at every lookup of a compiled form, whose cost grows with the
#: folder's size (docs/model.md, "Stability and critical points"; docs/design-notes.md, "The
#: 1D model's assembly")
JIT_OPTIONS: dict[str, Any] = {"timeout": 300, "cache_dir": str(cache_root() / "ffcx")}
@dataclass
class Jet:
    """Cylindrical components (r, φ, z) of a displacement and its derivatives at a point (UFL).

    ``val``, ``t``, ``ph``, ``tph``, ``phph``: u, ∂_t u, ∂_φ u, ∂_t∂_φ u, ∂_φφ u; ``p``: the slope
    field (≈ ∂_t u) and ``pt`` = ∂_t p, which replaces ∂_tt u (C1 by penalty).
    """

    val: tuple
    t: tuple
    ph: tuple
    tph: tuple
    phph: tuple
    p: tuple
    pt: tuple
    pph: tuple

    def __add__(self, other: Jet) -> Jet:
        return Jet(*(tuple(a + b for a, b in zip(x, y, strict=True)) for x, y in
                     zip(self.fields(), other.fields(), strict=True)))

    def fields(self) -> tuple:
        return (self.val, self.t, self.ph, self.tph, self.phph, self.p, self.pt, self.pph)


def meridian_ufl(shape: Shape, t: Any, mesh: Any = None) -> tuple:
    """The reference meridian and its derivatives as UFL expressions of t.

    An imperfect sphere's amplitude is a ``fem.Constant`` on ``mesh``: one compiled kernel for
    every amplitude of a knock-down curve.

    Args:
        shape: a shape the 1D model supports (or one with its own ``meridian_ufl``).
        t: the meridian coordinate (a UFL expression).
        mesh: the meridian mesh: it holds an imperfect sphere's amplitude Constant and a
            meridian table's interpolated spline.

    Returns:
        (r°, z°, r°_t, z°_t, r°_tt, z°_tt).
    """
    import ufl

    if isinstance(shape, Disk):
        return t, 0.0 * t, 1.0 + 0.0 * t, 0.0 * t, 0.0 * t, 0.0 * t
    if isinstance(shape, MeridianTable):
        # the spline's values and derivatives, each interpolated into P5 on the meridian mesh
        # (exact in a cell that holds one cubic piece; C2 across a knot, O(size³) there)
        from dolfinx import fem

        V = fem.functionspace(mesh, ("Lagrange", 5))
        out = []
        for fn in (shape.meridian, shape.meridian_derivative, shape.meridian_second_derivative):
            for k in (0, 1):
                f = fem.Function(V)
                f.interpolate(lambda x, fn=fn, k=k: np.asarray(fn(x[0])[k], dtype=float))
                out.append(f)
        return tuple(out)
    if isinstance(shape, ImperfectSphere):
        from dolfinx import default_scalar_type, fem

        amp = fem.Constant(mesh, default_scalar_type(shape.amplitude)) if mesh else None
        r, z = shape.meridian_ufl(t, amp)
        return r, z, r.dx(0), z.dx(0), r.dx(0).dx(0), z.dx(0).dx(0)
    if isinstance(shape, EllipsoidalCap):
        a, c = shape.radius, shape.r3
    else:
        a = c = shape.radius
    s, co = ufl.sin(t), ufl.cos(t)
    return a * s, c * co, a * co, -c * s, -a * s, -c * co


def dot(a: tuple, b: tuple) -> Any:
    """The dot product of two 3-tuples of UFL expressions.

    Args:
        a, b: the 3-tuples.

    Returns:
        Σ a_i b_i.
    """
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a: tuple, b: tuple) -> tuple:
    """The cross product of two 3-tuples of UFL expressions.

    Args:
        a, b: the 3-tuples.

    Returns:
        a × b, a 3-tuple.
    """
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def read_inputs(coefficients: Any, constants: Any, mesh: Any) -> list[np.ndarray]:
    """Everything compiled forms read, to tell whether a matrix assembled from them is stale.

    Args:
        coefficients: the forms' coefficients (``fem.Function``).
        constants: the forms' ``fem.Constant``.
        mesh: the mesh (its geometry).

    Returns:
        Views (not copies): each coefficient's local array (ghosts included), each Constant's
        value, the mesh geometry.
    """
    return ([w.x.array for w in coefficients] + [np.atleast_1d(k.value) for k in constants]
            + [mesh.geometry.x])


def same_inputs(old: list[np.ndarray] | None, new: list[np.ndarray]) -> bool:
    """Whether the inputs ``new`` (``read_inputs``) equal ``old`` (a copy of earlier ones).

    Args:
        old: the earlier inputs, or None (never the same).
        new: the current inputs.

    Returns:
        True if every array is equal exactly.
    """
    return old is not None and len(old) == len(new) and all(
        np.array_equal(a, b) for a, b in zip(old, new, strict=True))


def dirichlet(V: Any, vertices: np.ndarray) -> list[Any]:
    """Homogeneous Dirichlet conditions on the DOFs of ``V`` at ``vertices``.

    Args:
        V: a (sub)space.
        vertices: the mesh vertices.

    Returns:
        The conditions (none if ``vertices`` is empty).
    """
    from dolfinx import default_scalar_type, fem

    if len(vertices) == 0:
        return []
    dofs = fem.locate_dofs_topological(V, 0, vertices)
    return [fem.dirichletbc(default_scalar_type(0.0), dofs, V)]


def is_sphere(shape: Shape) -> bool:
    """Whether ``shape`` is a closed sphere (for the 1D model: two poles, no rim).

    Args:
        shape: the shape.

    Returns:
        True for a closed sphere (imperfect ones included).
    """
    return isinstance(shape, SphericalCap) and shape.closed
