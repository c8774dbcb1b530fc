"""A shell as a user describes it (API layer): a geometry, with units where they are given,
a thickness, a Poisson ratio, and optionally a bilayer that sets its natural curvature.

Every computation runs on the dimensionless shape (lengths in units of its radius R); a
geometry given with units keeps R in metres beside it (``Geometry.length``), so the same cap
given in mm, in m or dimensionless runs the same computation and gives the same κR.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from shells.errors import InputError
from shells.geometry.shapes import Shape, kappa_length
from shells.layers import Bilayer
from shells.parameters import check_h_over_r, check_nu
from shells.units import is_quantity, length, modulus

__all__ = ["Geometry", "Shell", "bilayer", "cap", "disk", "ellipsoid", "mesh", "meridian",
           "sphere", "torus"]


@dataclass(frozen=True)
class Geometry:
    """A reference shape and the length its numbers are measured in.

    Attributes:
        shape: the dimensionless shape (``shells.geometry``).
        length: metres per unit length of ``shape`` (its R in metres when the user gave the
            radius with units); None: dimensionless.
    """

    shape: Shape
    length: float | None = None

    @property
    def radius(self) -> float | None:
        """R (the length of κR) in metres, or None when dimensionless."""
        return None if self.length is None else self.length * kappa_length(self.shape)

    def describe(self) -> dict[str, Any]:
        """The shape's description, and R in metres where it has units."""
        d = dict(self.shape.describe())
        if self.length is not None:
            d["R_m"] = self.radius
        return d


def _scale(radius: Any, what: str = "the radius") -> tuple[float, float | None]:
    """(the radius in the shape's numbers, metres per unit): a radius with units becomes 1
    and its length in metres; a plain number stays as given, dimensionless."""
    si = length(radius, what)
    if si is not None:
        if not si > 0:
            raise InputError(f"{what} must be positive, got {radius!r}")
        return 1.0, si
    if not (isinstance(radius, (int, float)) and math.isfinite(radius) and radius > 0):
        raise InputError(f"{what} must be a positive number or a length, got {radius!r}")
    return float(radius), None


def _second_length(value: Any, name: str, default: float, unit: float | None) -> float:
    """A shape's second length (an ellipsoid's r3, a torus's ring) in the shape's numbers:
    ``default`` if None; with units only when the radius has them (then over its length)."""
    if value is None:
        return default
    if is_quantity(value) != (unit is not None):
        raise InputError(f"give radius and {name} both with units or both as numbers")
    return length(value, name) / unit if unit is not None else float(value)


def _angle(theta_deg: Any, theta: Any) -> float | None:
    if theta_deg is not None and theta is not None:
        raise InputError("give the opening angle once: theta_deg or theta (radians)")
    if theta_deg is not None:
        if not (isinstance(theta_deg, (int, float)) and math.isfinite(theta_deg)):
            raise InputError(f"theta_deg must be a number, got {theta_deg!r}")
        return math.radians(theta_deg)
    return theta


def cap(theta_deg: float | None = None, *, theta: float | None = None,
        radius: Any = 1.0) -> Geometry:
    """A spherical cap.

    Args:
        theta_deg: the half opening angle in degrees (or ``theta`` in radians).
        theta: the half opening angle in radians.
        radius: R: a number (dimensionless) or a length (``"25 mm"``, a pint quantity).

    Returns:
        The cap's ``Geometry``.

    Raises:
        InputError: an angle outside (0.1°, 179.9°] or a radius that is not positive.
    """
    from shells.geometry.catalogue import make_shape

    t = _angle(theta_deg, theta)
    if t is None:
        raise InputError("a cap needs its opening angle: theta_deg (or theta in radians)")
    r, unit = _scale(radius)
    return Geometry(make_shape("cap", radius=r, theta=t), unit)


def sphere(radius: Any = 1.0) -> Geometry:
    """A closed sphere of radius ``radius`` (a number or a length)."""
    from shells.geometry.shapes import Sphere

    r, unit = _scale(radius)
    return Geometry(Sphere(r), unit)


def ellipsoid(radius: Any = 1.0, r3: Any = None, theta_deg: float | None = 90.0, *,
              theta: float | None = None) -> Geometry:
    """An ellipsoidal cap: semi-axes (R, R, r3) (r3 = 1.5 R by default, the supplement's),
    opening angle ``theta_deg`` from the pole (90°: the half ellipsoid).

    Raises:
        InputError: r3 with units when the radius has none, or the other way round.
    """
    from shells.geometry.shapes import EllipsoidalCap

    r, unit = _scale(radius)
    c = _second_length(r3, "r3", 1.5 * r, unit)
    t = _angle(theta_deg if theta is None else None, theta)
    return Geometry(EllipsoidalCap(radius=r, r3=c, theta=math.pi / 2 if t is None else t), unit)


def disk(radius: Any = 1.0) -> Geometry:
    """A flat disk of radius ``radius`` (a number or a length)."""
    from shells.geometry.shapes import Disk

    r, unit = _scale(radius)
    return Geometry(Disk(radius=r), unit)


def torus(radius: Any = 1.0, ring: Any = None) -> Geometry:
    """A torus: tube radius ``radius`` at distance ``ring`` (default 3 radius) from the axis."""
    from shells.geometry.shapes import Torus

    r, unit = _scale(radius)
    c = _second_length(ring, "ring", 3.0 * r, unit)
    return Geometry(Torus(radius=r, ring=c), unit)


def meridian(table: Any, length_unit: Any = None) -> Geometry:
    """Any shell of revolution from its meridian: a file (rows ``r z`` from the pole) or a
    sequence of (r, z) points; ``length_unit`` (e.g. ``"1 mm"``): what one unit of the table
    is, if it has units."""
    from shells.geometry.meridian import MeridianTable

    shape = (MeridianTable.from_file(str(table)) if isinstance(table, (str, bytes))
             or hasattr(table, "__fspath__") else MeridianTable(tuple(tuple(map(float, p))
                                                                      for p in table)))
    unit = None if length_unit is None else length(length_unit, "the length unit")
    return Geometry(shape, unit)


def mesh(path: Any, length_unit: Any = None) -> Geometry:
    """The shape of a gmsh surface mesh (made by ``shells mesh`` or by the user: a surface of
    revolution about z, a torus, or any oriented surface: the surface model only)."""
    from mpi4py import MPI

    from shells.surface.mesh import read_mesh_shape

    unit = None if length_unit is None else length(length_unit, "the length unit")
    return Geometry(read_mesh_shape(str(path), MPI.COMM_WORLD), unit)


def bilayer(h: tuple[Any, Any], E: tuple[Any, Any], mismatch: float,
            nu: Any = 0.5) -> Bilayer:
    """A bilayer from its layers' thicknesses, Young's moduli and Poisson ratios.

    Args:
        h: (outer, inner) thicknesses, numbers in one unit or lengths (``"0.5 mm"``); the outer
            layer is on the side the normal points to (the outside of a cap or sphere).
        E: (outer, inner) Young's moduli, numbers in one unit or moduli (``"1.2 MPa"``).
        mismatch: Δε, the equal-biaxial strain by which the outer layer expands relative to the
            inner one (differential swelling, or α ΔT).
        nu: one Poisson ratio for both layers, or (outer, inner).

    Returns:
        The ``Bilayer`` (``.kappa``, ``.thickness``, ``.modulus``), in metres and pascals when
        the thicknesses and moduli have units.

    Raises:
        InputError: a layer's thickness or modulus not positive, mixed units and numbers.
    """
    hs = [length(x, "a layer's thickness") for x in h]
    es = [modulus(x, "a layer's modulus") for x in E]
    if len(hs) != 2 or len(es) != 2:
        raise InputError("a bilayer has two layers: h=(outer, inner), E=(outer, inner)")
    if (hs[0] is None) != (hs[1] is None) or (es[0] is None) != (es[1] is None):
        raise InputError("give both layers' thicknesses (and both moduli) with units or both "
                         "as numbers")
    hv = hs if hs[0] is not None else [float(x) for x in h]
    ev = es if es[0] is not None else [float(x) for x in E]
    nus = (nu, nu) if isinstance(nu, (int, float)) else tuple(nu)
    return Bilayer((hv[0], ev[0], float(nus[0])), (hv[1], ev[1], float(nus[1])),
                   float(mismatch))


@dataclass(frozen=True)
class Shell:
    """A thin shell: its geometry, thickness and material.

    Give the thickness once: ``h_over_r`` (thickness over the shape's length scale), or
    ``thickness`` (a length when the geometry has units, else a number in the shape's units),
    or a ``layers`` bilayer (its total thickness; its natural curvature is then
    ``kappa_natural``).

    Attributes:
        geometry: the reference shape (``shells.cap(...)``, ``shells.sphere(...)``, ...).
        h_over_r: thickness over the shape's length scale (R; a disk's radius).
        nu: Poisson's ratio (a bilayer's: its layers' mean by default).
        E: Young's modulus (a number, or a modulus such as ``"1.2 MPa"``): energies in joules
            when it and the geometry have units.
        layers: the bilayer that sets the natural curvature, if any.
        kappa_field: a natural-curvature field (``shells.geometry.stimulus.CurvatureField``);
            None: uniform.
    """

    geometry: Geometry
    h_over_r: float = field(default=float("nan"))
    nu: float = 0.5
    E: float | None = None
    layers: Bilayer | None = None
    kappa_field: Any = None

    def __init__(self, geometry: Geometry | Shape, *, h_over_r: float | None = None,
                 thickness: Any = None, nu: float | None = None, E: Any = None,
                 layers: Bilayer | None = None, kappa_field: Any = None) -> None:
        if isinstance(geometry, Shape):
            geometry = Geometry(geometry)
        if not isinstance(geometry, Geometry):
            raise InputError(f"a shell needs a geometry (shells.cap(...), ...), got "
                             f"{geometry!r}")
        given = [x is not None for x in (h_over_r, thickness, layers)]
        if sum(given) != 1:
            raise InputError("give the thickness once: h_over_r, thickness or layers")
        L = geometry.shape.characteristic_size()
        if h_over_r is not None:
            hr = h_over_r
        else:
            t = layers.thickness if layers is not None else thickness
            si = length(t, "the thickness") if layers is None else None
            if si is not None or (layers is not None and geometry.length is not None):
                if geometry.length is None:
                    raise InputError("a thickness with units needs a geometry with units "
                                     "(e.g. shells.cap(30, radius='25 mm'))")
                hr = (si if si is not None else t) / (geometry.length * L)
            else:
                if not isinstance(t, (int, float)):
                    raise InputError(f"the thickness must be a number or a length, got {t!r}")
                hr = t / L
        check_h_over_r(hr)
        if nu is None:
            nu = layers.nu if layers is not None else 0.5
        check_nu(nu)
        e = modulus(E, "E") if E is not None else None
        e = e if e is not None else (None if E is None else float(E))
        if e is None and layers is not None and geometry.length is not None:
            e = layers.modulus
        object.__setattr__(self, "geometry", geometry)
        object.__setattr__(self, "h_over_r", float(hr))
        object.__setattr__(self, "nu", float(nu))
        object.__setattr__(self, "E", e)
        object.__setattr__(self, "layers", layers)
        object.__setattr__(self, "kappa_field", kappa_field)

    @property
    def shape(self) -> Shape:
        """The dimensionless reference shape the computations run on."""
        return self.geometry.shape

    @property
    def kappa_natural(self) -> float | None:
        """The bilayer's natural curvature as κ in the shape's units (κR for R = 1), or None
        without a bilayer."""
        if self.layers is None:
            return None
        if self.geometry.length is not None:
            return self.layers.kappa * self.geometry.length
        return self.layers.kappa

    def describe(self) -> dict[str, Any]:
        """The shell as JSON: shape, h/R, ν, and R, h, E in SI units where given."""
        d: dict[str, Any] = {"shape": self.geometry.describe(), "h_over_R": self.h_over_r,
                             "nu": self.nu}
        if self.geometry.length is not None:
            R = self.geometry.radius
            d["R_m"] = R
            d["h_m"] = self.h_over_r * self.geometry.length * self.shape.characteristic_size()
        if self.E is not None:
            d["E"] = self.E
        if self.layers is not None:
            d["bilayer"] = self.layers.describe()
            d["kappa_natural_R"] = self.kappa_natural * kappa_length(self.shape)
        return d
