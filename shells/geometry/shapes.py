"""Analytic shell geometries: sphere, spherical cap, ellipsoidal cap, flat disk and torus.

Each shape is a frozen, validated dataclass that knows its exact reference quantities (area, rim
length), its meridian parametrisation (for the axisymmetric model) and its outward unit normal and
second fundamental form, both as NumPy functions of points and as UFL expressions of the spatial
coordinate (for the surface model). All shapes are surfaces of revolution about the z axis with the
pole at the top, ``t`` being the meridian parameter measured from the pole:

* sphere / spherical cap of radius ``R``:
  x = R (sin t cos phi, sin t sin phi, cos t), t in [0, theta]
* ellipsoidal cap, semi-axes (R, R, r3): x = (R sin t cos phi, R sin t sin phi, r3 cos t)
* disk of radius ``radius``: x = (t cos phi, t sin phi, 0), t in [0, radius]
* torus, tube radius ``radius`` at ``ring`` from the axis: x = ((ring + radius sin t) cos phi,
  (ring + radius sin t) sin phi, radius cos t), t in [0, 2 pi] (no pole: t from the tube's top)

Sign convention (the paper's): the normal points outward (+z at the pole) and
b_ab = n . a_{a,b}, so that a sphere has b0 = -a0 / R.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from shells.errors import InputError

__all__ = ["CAP_THETA_MAX_DEG", "THETA_MIN_DEG", "Disk", "EllipsoidalCap", "RunScales", "Shape",
           "Sphere", "SphericalCap", "Torus", "check_positive", "check_theta", "kappa_length"]


def check_positive(name: str, value: float) -> None:
    """Refuse a value that is not a finite positive number.

    Args:
        name: the value's name, for the message.
        value: the value.

    Raises:
        InputError: if it is not a finite positive number.
    """
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
        raise InputError(f"{name} must be a positive number, got {value!r}")


#: Smallest half opening angle of a cap (degrees). Below it a cap is degenerate for the mesher:
#: ``shells.surface.mesh`` tells the cap's surface from the flat base of its OCC ball sector by the
#: height of its bounding box, flat meaning < 1e-6 R, and a cap's height is its sagitta
#: R (1 - cos theta), which falls below 1e-6 R at theta = 0.081 deg (docs/design-notes.md,
#: "Meshes"); 0.1 deg (sagitta 1.5e-6 R) keeps a margin.
#: The plate limit (theta-bar = theta / sqrt(h/R) -> 0) stays reachable: at h/R = 0.01, 0.1 deg
#: is theta-bar = 0.017. Every cap in tests/, benchmarks/ and demos/ has theta >= 2 deg.
THETA_MIN_DEG = 0.1


#: A cap with theta > 180 - THETA_MIN_DEG is refused as a "cap" (``make_shape``): it is a closed
#: sphere with a pinhole of radius < 1.7e-3 R, smaller than the boundary layer sqrt(R h) of any
#: h/R > 3e-6, and the paper's cap laws (the default kappa range) diverge at theta = 180 deg.
CAP_THETA_MAX_DEG = 180.0 - THETA_MIN_DEG


def check_theta(theta: float) -> None:
    """Refuse a cap's half opening angle outside [``THETA_MIN_DEG``, 180°].

    Args:
        theta: the angle, in radians.

    Raises:
        InputError: if it is out of range or not a number.
    """
    if not (isinstance(theta, (int, float)) and math.isfinite(theta)):
        raise InputError(f"theta must be a number, got {theta!r}")
    if not 0.0 < theta <= math.pi * (1 + 1e-12):
        raise InputError(
            f"theta must lie in (0, pi] (0 to 180 degrees), got {theta:.6g} rad "
            f"= {math.degrees(theta):.6g} deg"
        )
    if theta < math.radians(THETA_MIN_DEG) * (1 - 1e-12):
        raise InputError(
            f"theta = {math.degrees(theta):.6g} deg is too small: a cap needs theta >= "
            f"{THETA_MIN_DEG:g} deg (below it the cap is numerically flat; for the plate limit "
            "use the disk shape)"
        )


@dataclass(frozen=True)
class Shape:
    """Base class of the analytic shapes (surfaces of revolution about z, pole on top)."""

    kind = "shape"

    # -- reference quantities -------------------------------------------------------------------
    @property
    def closed(self) -> bool:
        return False

    @property
    def t_max(self) -> float:
        """Meridian parameter at the rim (or at the south pole of a closed surface)."""
        raise NotImplementedError

    @property
    def R(self) -> float:  # noqa: N802 - the paper's symbol
        """Reference radius of curvature at the pole (the length scale of kappa R): the
        shape's ``radius`` unless a shape says otherwise."""
        return self.radius  # type: ignore[attr-defined]

    def meridian(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Distance from the axis r(t) and height z(t) of the meridian."""
        raise NotImplementedError

    def meridian_derivative(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """dr/dt and dz/dt."""
        raise NotImplementedError

    def area(self) -> float:
        """Exact area: 2 pi int r(t) |x'(t)| dt (closed form where one exists)."""
        from scipy import integrate  # here: a slow import every CLI run would pay

        def integrand(t: float) -> float:
            r, _ = self.meridian(np.array(t))
            dr, dz = self.meridian_derivative(np.array(t))
            return float(r * math.hypot(dr, dz))

        val, _ = integrate.quad(integrand, 0.0, self.t_max, epsabs=0, epsrel=1e-13, limit=200)
        return 2 * math.pi * val

    def rim_length(self) -> float:
        """Length of the free boundary (0 for a closed surface)."""
        if self.closed:
            return 0.0
        r, _ = self.meridian(np.array(self.t_max))
        return float(2 * math.pi * r)

    def rim_height(self) -> float:
        """z coordinate of the rim plane."""
        return float(self.meridian(np.array(self.t_max))[1])

    # -- differential geometry (NumPy) ---------------------------------------------------------
    def normal(self, x: np.ndarray) -> np.ndarray:
        """Outward unit normal at points x (shape (3, N) or (3,))."""
        raise NotImplementedError

    def principal_curvatures(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(meridional, azimuthal) eigenvalues of b (paper's sign: negative on a sphere)."""
        raise NotImplementedError

    # -- differential geometry (UFL) -----------------------------------------------------------
    #: False: no closed-form normal (``normal_ufl`` refuses); the surface model interpolates
    #: ``normal`` instead
    has_ufl_normal = True
    #: False: the meridian does not meet the axis (a torus): no pole for the surface model's
    #: rigid-motion gauge, which then uses points of one parallel only
    has_pole = True
    #: False: not a surface of revolution about z (``surface_fit.MeshSurface``): no meridian,
    #: parallels or azimuthal mode numbers; the surface model only, with a gauge from its nodes
    of_revolution = True

    def normal_ufl(self, x: Any) -> Any:
        """Outward unit normal as a UFL expression of the spatial coordinate x."""
        raise NotImplementedError

    def curvature_tensor_ufl(self, x: Any) -> Any:
        """Second fundamental form b0 as a 3x3 tangential tensor: b0 = -P grad(n) P."""
        import ufl

        n = self.normal_ufl(x)
        P = ufl.Identity(3) - ufl.outer(n, n)
        return -P * ufl.grad(n) * P

    def describe(self) -> dict[str, Any]:
        """JSON-ready parameters (also the mesh sidecar contents)."""
        raise NotImplementedError

    def characteristic_size(self) -> float:
        """A length scale of the whole shape, for mesh sizes."""
        return self.R

    def layer_radius(self) -> float:
        """R of the rim boundary layer's width sqrt(R h): the azimuthal radius of curvature at
        the rim (a sphere's R; flat shapes: the characteristic size). Both models' meshes are
        graded with it."""
        return self.R if math.isfinite(self.R) else self.characteristic_size()


@dataclass(frozen=True)
class _AngleShape(Shape):
    """A shape whose meridian parameter runs from the pole to the angle ``theta``: closed when
    theta reaches π. The subclasses define the field ``theta`` after their others (a field
    here would come first in their constructors' positional order)."""

    @property
    def closed(self) -> bool:
        return self.theta >= math.pi * (1 - 1e-12)

    @property
    def t_max(self) -> float:
        return self.theta


@dataclass(frozen=True)
class SphericalCap(_AngleShape):
    """Spherical cap of radius ``radius`` and half opening angle ``theta`` (pole to rim)."""

    radius: float = 1.0
    theta: float = math.pi / 4
    kind = "cap"

    def __post_init__(self) -> None:
        check_positive("radius", self.radius)
        check_theta(self.theta)

    def meridian(self, t):
        return self.radius * np.sin(t), self.radius * np.cos(t)

    def meridian_derivative(self, t):
        return self.radius * np.cos(t), -self.radius * np.sin(t)

    def area(self) -> float:
        return 2 * math.pi * self.radius**2 * (1 - math.cos(self.theta))

    def normal(self, x):
        x = np.asarray(x, dtype=float)
        return x / np.linalg.norm(x, axis=0)

    def principal_curvatures(self, x):
        x = np.asarray(x, dtype=float)
        k = -np.ones(x.shape[1:]) / self.radius
        return k, k.copy()

    def normal_ufl(self, x):
        import ufl

        return x / ufl.sqrt(ufl.dot(x, x))

    def describe(self) -> dict[str, Any]:
        return {"shape": self.kind, "R": self.radius, "theta": self.theta,
                "theta_deg": math.degrees(self.theta)}


@dataclass(frozen=True)
class Sphere(SphericalCap):
    """Closed sphere of radius ``radius``."""

    theta: float = math.pi
    kind = "sphere"

    def __post_init__(self) -> None:
        check_positive("radius", self.radius)
        if abs(self.theta - math.pi) > 1e-12:
            raise InputError("a closed sphere has theta = pi; use the cap shape for open shells")

    @property
    def closed(self) -> bool:
        return True

    def describe(self) -> dict[str, Any]:
        return {"shape": self.kind, "R": self.radius}


@dataclass(frozen=True)
class EllipsoidalCap(_AngleShape):
    """Cap of the spheroid x^2/R^2 + y^2/R^2 + z^2/r3^2 = 1 down to parametric colatitude theta."""

    radius: float = 1.0
    r3: float = 1.5
    theta: float = math.pi / 2
    kind = "ellipsoid"

    def __post_init__(self) -> None:
        check_positive("radius", self.radius)
        check_positive("r3", self.r3)
        check_theta(self.theta)

    @property
    def R(self) -> float:  # noqa: N802
        """Radius of curvature at the pole: R^2 / r3."""
        return self.radius**2 / self.r3

    def characteristic_size(self) -> float:
        return min(self.radius, self.r3)

    def layer_radius(self) -> float:
        # the azimuthal radius of curvature at the rim: a sqrt(D)/c at colatitude theta
        # (the equatorial radius r1 at theta = pi/2)
        t = self.theta
        D = self.radius**2 * math.cos(t) ** 2 + self.r3**2 * math.sin(t) ** 2
        return self.radius * math.sqrt(D) / self.r3

    def meridian(self, t):
        return self.radius * np.sin(t), self.r3 * np.cos(t)

    def meridian_derivative(self, t):
        return self.radius * np.cos(t), -self.r3 * np.sin(t)

    def _grad_f(self, x):
        a2, c2 = self.radius**2, self.r3**2
        return np.stack([x[0] / a2, x[1] / a2, x[2] / c2])

    def normal(self, x):
        x = np.asarray(x, dtype=float)
        g = self._grad_f(x)
        return g / np.linalg.norm(g, axis=0)

    def principal_curvatures(self, x):
        # Spheroid with semi-axes (a, a, c): at parametric colatitude t, with
        # D = a^2 cos^2 t + c^2 sin^2 t: k_meridian = -a c / D^(3/2), k_azimuth = -c / (a sqrt(D)).
        x = np.asarray(x, dtype=float)
        a, c = self.radius, self.r3
        cos_t = np.clip(x[2] / c, -1.0, 1.0)
        sin2 = 1 - cos_t**2
        D = a**2 * cos_t**2 + c**2 * sin2
        return -a * c / D**1.5, -c / (a * np.sqrt(D))

    def normal_ufl(self, x):
        import ufl

        g = ufl.as_vector([x[0] / self.radius**2, x[1] / self.radius**2, x[2] / self.r3**2])
        return g / ufl.sqrt(ufl.dot(g, g))

    def describe(self) -> dict[str, Any]:
        return {"shape": self.kind, "R": self.radius, "r3": self.r3, "theta": self.theta,
                "theta_deg": math.degrees(self.theta), "R_pole": self.R}


@dataclass(frozen=True)
class Torus(Shape):
    """Torus: the circle of radius ``radius`` (the tube) centred at distance ``ring`` > radius
    from the z axis, revolved about it; closed, without poles. Meridian from the tube's top,
    outward first: r(t) = ring + radius sin t, z(t) = radius cos t, t in [0, 2π] (t = π/2
    the outer equator, 3π/2 the inner one, where the Gaussian curvature is negative). κR is
    κ times the tube's radius, h/R the thickness over it."""

    radius: float = 1.0
    ring: float = 3.0
    kind = "torus"
    has_pole = False

    def __post_init__(self) -> None:
        check_positive("radius", self.radius)
        check_positive("ring", self.ring)
        if not self.ring > self.radius * (1 + 1e-9):
            raise InputError(f"a torus needs its ring radius ({self.ring:g}) above its tube "
                             f"radius ({self.radius:g}): the tube would cross the axis")

    @property
    def closed(self) -> bool:
        return True

    @property
    def t_max(self) -> float:
        return 2 * math.pi

    def meridian(self, t):
        t = np.asarray(t, dtype=float)
        return self.ring + self.radius * np.sin(t), self.radius * np.cos(t)

    def meridian_derivative(self, t):
        t = np.asarray(t, dtype=float)
        return self.radius * np.cos(t), -self.radius * np.sin(t)

    def area(self) -> float:
        return 4 * math.pi**2 * self.ring * self.radius

    def meridian_angle(self, x: np.ndarray) -> np.ndarray:
        """t in [0, 2π) of points x (shape (3, N) or (3,)): the angle about the tube's centre
        circle from its top, outward first."""
        x = np.asarray(x, dtype=float)
        rho = np.hypot(x[0], x[1])
        return np.arctan2(rho - self.ring, x[2]) % (2 * math.pi)

    def normal(self, x):
        x = np.asarray(x, dtype=float)
        rho = np.hypot(x[0], x[1])
        v = np.stack([x[0] * (1 - self.ring / rho), x[1] * (1 - self.ring / rho), x[2]])
        return v / np.linalg.norm(v, axis=0)

    def principal_curvatures(self, x):
        # meridional -1/a; azimuthal -sin t / r (negative on the outer half, like a sphere's)
        x = np.asarray(x, dtype=float)
        rho = np.hypot(x[0], x[1])
        sin_t = np.sin(self.meridian_angle(x))
        return -np.ones_like(rho) / self.radius, -sin_t / rho

    def normal_ufl(self, x):
        import ufl

        c = 1 - self.ring / ufl.sqrt(x[0] ** 2 + x[1] ** 2)
        v = ufl.as_vector([x[0] * c, x[1] * c, x[2]])
        return v / ufl.sqrt(ufl.dot(v, v))

    def describe(self) -> dict[str, Any]:
        return {"shape": self.kind, "R": self.radius, "ring": self.ring}

    @classmethod
    def from_nodes(cls, x: np.ndarray, tol: float = 1e-6) -> Torus:
        """The torus through nodes x (N, 3) of a user's mesh: the circle fitted (least squares,
        algebraic) to their (r, z), centred on z = 0. Refused (``InputError``) unless every
        node lies within ``tol`` (relative to the size) of the torus so found."""
        x = np.asarray(x, dtype=float).reshape(-1, 3)
        size = float(np.max(np.abs(x)))
        r, z = np.hypot(x[:, 0], x[:, 1]), x[:, 2]
        # (r - c)² + (z - z0)² = a²: linear in (c, z0, a² - c² - z0²)
        A = np.column_stack([2 * r, 2 * z, np.ones_like(r)])
        (c, z0, k), *_ = np.linalg.lstsq(A, r * r + z * z, rcond=None)
        a = math.sqrt(max(k + c * c + z0 * z0, 0.0))
        off = float(np.max(np.abs(np.hypot(r - c, z - z0) - a))) / size
        if off > tol or abs(z0) > tol * size or not 0 < a < c:
            raise InputError(f"the mesh has no node on the z axis and is not a torus about z "
                             f"centred on z = 0 (its nodes lie up to {off:.2g}, relative, off the "
                             f"best-fitting one; centre at z = {z0:.3g}): the surface model takes "
                             "surfaces of revolution with a pole, or tori")
        return cls(radius=a, ring=c)


@dataclass(frozen=True)
class Disk(Shape):
    """Flat disk of radius ``radius`` in the plane z = 0, normal +z."""

    radius: float = 1.0
    kind = "disk"

    def __post_init__(self) -> None:
        check_positive("radius", self.radius)

    @property
    def t_max(self) -> float:
        return self.radius

    @property
    def R(self) -> float:  # noqa: N802
        return math.inf

    def characteristic_size(self) -> float:
        return self.radius

    def meridian(self, t):
        t = np.asarray(t, dtype=float)
        return t, np.zeros_like(t)

    def meridian_derivative(self, t):
        t = np.asarray(t, dtype=float)
        return np.ones_like(t), np.zeros_like(t)

    def area(self) -> float:
        return math.pi * self.radius**2

    def normal(self, x):
        x = np.asarray(x, dtype=float)
        n = np.zeros_like(x)
        n[2] = 1.0
        return n

    def principal_curvatures(self, x):
        z = np.zeros(np.asarray(x).shape[1:])
        return z, z.copy()

    def normal_ufl(self, x):
        import ufl

        return ufl.as_vector([0.0, 0.0, 1.0])

    def curvature_tensor_ufl(self, x):
        import ufl

        return ufl.zero((3, 3))

    def describe(self) -> dict[str, Any]:
        return {"shape": self.kind, "radius": self.radius}


class RunScales:
    """The length scales of a run on ``self.shape`` with thickness ratio ``self.h_over_r``
    (a mixin for the run configurations): L, the shape's ``characteristic_size`` (h/R is h/L
    and the continuation runs in κL); h = (h/R) L; R, the length of κR: the pole radius of
    curvature (the disk's radius; the ellipsoid's equatorial radius r1, as in the paper)."""

    shape: Shape
    h_over_r: float

    @property
    def L(self) -> float:  # noqa: N802
        return self.shape.characteristic_size()

    @property
    def h(self) -> float:
        return self.h_over_r * self.L

    @property
    def R(self) -> float:  # noqa: N802
        return kappa_length(self.shape)


def kappa_length(shape: Shape) -> float:
    """The length R of κR.

    Args:
        shape: the shape.

    Returns:
        The pole radius of curvature R of spheres and caps; the ellipsoid's equatorial radius
        r1 (the paper's R = r1 = r2); the disk's radius.
    """
    if isinstance(shape, EllipsoidalCap):
        return shape.radius
    return shape.R if math.isfinite(shape.R) else shape.characteristic_size()
