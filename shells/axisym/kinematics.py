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
#: FFCx lists its cache folder at every lookup of a compiled form (2.4 ms a form in a shared
#: folder of 3900 files, 0.1 ms in one of 84: the 21 forms of a run, 50 ms of its set-up)
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
    """r°, z° and their first and second t-derivatives as UFL expressions of t. An imperfect
    sphere's amplitude is a ``fem.Constant`` on ``mesh``: one compiled kernel for every
    amplitude of a knock-down curve."""
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
    """The dot product of two 3-tuples (UFL)."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a: tuple, b: tuple) -> tuple:
    """The cross product of two 3-tuples (UFL)."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def read_inputs(coefficients: Any, constants: Any, mesh: Any) -> list[np.ndarray]:
    """Everything compiled forms read (views, not copies): each coefficient's local array
    (ghosts included), each Constant's value, the mesh geometry."""
    return ([w.x.array for w in coefficients] + [np.atleast_1d(k.value) for k in constants]
            + [mesh.geometry.x])


def same_inputs(old: list[np.ndarray] | None, new: list[np.ndarray]) -> bool:
    """Whether ``read_inputs`` are those of ``old`` (a copy of earlier ones), exactly."""
    return old is not None and len(old) == len(new) and all(
        np.array_equal(a, b) for a, b in zip(old, new, strict=True))


def dirichlet(V: Any, vertices: np.ndarray) -> list[Any]:
    """Homogeneous Dirichlet conditions on the DOFs of ``V`` at ``vertices`` (none if empty)."""
    from dolfinx import default_scalar_type, fem

    if len(vertices) == 0:
        return []
    dofs = fem.locate_dofs_topological(V, 0, vertices)
    return [fem.dirichletbc(default_scalar_type(0.0), dofs, V)]


def is_sphere(shape: Shape) -> bool:
    """Whether ``shape`` is a closed sphere (the 1D model's two poles)."""
    return isinstance(shape, SphericalCap) and shape.closed
