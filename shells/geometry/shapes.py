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

__all__ = ["Shape", "Sphere", "SphericalCap", "EllipsoidalCap", "Disk", "Torus", "make_shape",
           "SHAPES", "ImperfectSphere", "HarmonicImperfectSphere"]


def _positive(name: str, value: float) -> None:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
        raise InputError(f"{name} must be a positive number, got {value!r}")


#: Smallest half opening angle of a cap (degrees). Below it a cap is degenerate for the mesher:
#: ``shells.surface.mesh`` tells the cap's surface from the flat base of its OCC ball sector by the
#: height of its bounding box, flat meaning < 1e-6 R, and a cap's height is its sagitta
#: R (1 - cos theta), which falls below 1e-6 R at theta = 0.081 deg (measured: 0.05 deg fails
#: with an IndexError in gmsh, 0.09 deg meshes); 0.1 deg (sagitta 1.5e-6 R) keeps a margin.
#: The plate limit (theta-bar = theta / sqrt(h/R) -> 0) stays reachable: at h/R = 0.01, 0.1 deg
#: is theta-bar = 0.017. Every cap in tests/, benchmarks/ and demos/ has theta >= 2 deg.
THETA_MIN_DEG = 0.1
#: A cap with theta > 180 - THETA_MIN_DEG is refused as a "cap" (``make_shape``): it is a closed
#: sphere with a pinhole of radius < 1.7e-3 R, smaller than the boundary layer sqrt(R h) of any
#: h/R > 3e-6, and the paper's cap laws (the default kappa range) diverge at theta = 180 deg.
CAP_THETA_MAX_DEG = 180.0 - THETA_MIN_DEG


def _check_theta(theta: float) -> None:
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
        """Reference radius of curvature at the pole (the length scale of kappa R)."""
        raise NotImplementedError

    def meridian(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Distance from the axis r(t) and height z(t) of the meridian."""
        raise NotImplementedError

    def meridian_derivative(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """dr/dt and dz/dt."""
        raise NotImplementedError

    def area(self) -> float:
        """Exact area: 2 pi int r(t) |x'(t)| dt (closed form where one exists)."""
        from scipy import integrate  # here: importing it costs 0.3-0.5 s, paid by every CLI run

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
    #: parallels or azimuthal mode numbers; the surface model only, with a 3-2-1 gauge
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
        _positive("radius", self.radius)
        _check_theta(self.theta)

    @property
    def R(self) -> float:  # noqa: N802
        return self.radius

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
        _positive("radius", self.radius)
        if abs(self.theta - math.pi) > 1e-12:
            raise InputError("a closed sphere has theta = pi; use the cap shape for open shells")

    @property
    def closed(self) -> bool:
        return True

    def describe(self) -> dict[str, Any]:
        return {"shape": self.kind, "R": self.radius}


def perfect_shape(shape: Shape) -> Shape:
    """An imperfect sphere's perfect sphere (or cap); any other shape itself. Meshes of an
    imperfect sphere are those of its perfect shape (the surface mesh then moved onto it)."""
    if isinstance(shape, ImperfectSphere):
        return Sphere(shape.radius) if shape.closed else SphericalCap(shape.radius, shape.theta)
    if isinstance(shape, HarmonicImperfectSphere):
        return Sphere(shape.radius)
    return shape


def mesh_reference(shape: Shape) -> Shape:
    """The shape whose gmsh mesh ``onto_shape`` moves onto ``shape``: an imperfect sphere's
    perfect one, a meridian table's ``reference_shape``; any other shape itself."""
    if isinstance(shape, MeridianTable):
        return shape.reference_shape()
    return perfect_shape(shape)


def onto_shape(shape: Shape, x: np.ndarray) -> np.ndarray:
    """Points x (N, 3) of a mesh of ``mesh_reference(shape)`` moved onto ``shape``: radially
    onto an imperfect sphere ρ(β) = R - δ f(β) (a harmonic one's ρ(θ, φ)), along the meridian
    onto a meridian table; every geometry node, the edges' midpoints too, so that a
    second-order mesh interpolates the surface. Other shapes: x itself."""
    if isinstance(shape, MeridianTable):
        return shape.from_reference(x)
    if isinstance(shape, ImperfectSphere):
        r = np.linalg.norm(x, axis=1)
        beta = np.arccos(np.clip(x[:, 2] / r, -1.0, 1.0))
        return x * (shape._rho(beta) / r)[:, None]
    if isinstance(shape, HarmonicImperfectSphere):
        r = np.linalg.norm(x, axis=1)
        return x * (shape.rho((x / r[:, None]).T) / r)[:, None]
    return x


def legendre_cosine_series(n: int) -> list[tuple[int, float]]:
    """P_n(cos t) = Σ_j a_j cos(j t): the pairs (j, a_j), from P_n(cos t) = Σ_k g_k g_(n-k)
    cos((n - 2k) t), g_k = C(2k, k) / 4^k (the terms of k and n - k merged)."""
    g = [math.comb(2 * k, k) / 4.0**k for k in range(n + 1)]
    out: dict[int, float] = {}
    for k in range(n + 1):
        j = abs(n - 2 * k)
        out[j] = out.get(j, 0.0) + g[k] * g[n - k]
    return sorted(out.items())


@dataclass(frozen=True)
class ImperfectSphere(SphericalCap):
    """A sphere (or a cap, ``theta`` < π) whose stress-free reference surface is displaced
    along its normal by w0(t) = -``amplitude`` f(t), t the angle from the pole: f = exp(-(t/β0)²)
    (``profile`` "dimple", β0 = ``width`` in radians: the pressure-buckling literature's
    localised dimple) or f = P_n(cos t) (``profile`` "mode", n = ``degree``: the shape of an
    axisymmetric buckling mode). Amplitude > 0 is inward at the pole. The meridian is
    (R + w0(t)) (sin t, cos t); its UFL form is differentiated symbolically, so the reference
    metric and curvature of the imperfect surface enter the energy exactly. The surface model
    takes it too: ``shells.surface.mesh`` meshes the sphere (refined at a pole dimple) and moves its
    nodes radially onto ρ(β); ``normal_ufl`` is the exact normal."""

    radius: float = 1.0
    theta: float = math.pi
    amplitude: float = 0.0
    profile: str = "dimple"
    width: float = 0.1
    degree: int = 2
    kind = "imperfect-sphere"

    def __post_init__(self) -> None:
        _positive("radius", self.radius)
        if not (0 < self.theta <= math.pi * (1 + 1e-12)):
            raise InputError(f"theta must lie in (0, pi], got {self.theta!r}")
        if self.profile not in ("dimple", "mode"):
            raise InputError(f"imperfection profile must be 'dimple' or 'mode', got "
                             f"{self.profile!r}")
        if not (isinstance(self.amplitude, (int, float)) and math.isfinite(self.amplitude)
                and abs(self.amplitude) < 0.1 * self.radius):
            raise InputError(f"the imperfection amplitude must be a number below R/10 in size, "
                             f"got {self.amplitude!r}")
        _positive("width", self.width)
        if not (isinstance(self.degree, int) and 0 <= self.degree <= 1000):
            raise InputError(f"the mode degree must be an integer in [0, 1000], got "
                             f"{self.degree!r}")

    def _profile(self, c: Any, t: Any, exp: Any, cos: Any = None) -> Any:
        """f(t) from cos t (``c``), t and an exp function: numpy or UFL alike. With ``cos`` (the
        UFL path) the mode's P_n(cos t) is its cosine series (``legendre_cosine_series``): the
        recurrence's expression, differentiated twice in the energy, took the form compiler
        over 45 minutes at n = 44."""
        if self.profile == "dimple":
            return exp(-((t / self.width) ** 2))
        if cos is not None:
            return sum(a * cos(j * t) for j, a in legendre_cosine_series(self.degree))
        p0, p1 = 1.0 + 0.0 * c, c  # Legendre recurrence
        if self.degree == 0:
            return p0
        for k in range(1, self.degree):
            p0, p1 = p1, ((2 * k + 1) * c * p1 - k * p0) / (k + 1)
        return p1

    def _rho(self, t: np.ndarray) -> np.ndarray:
        return self.radius - self.amplitude * self._profile(np.cos(t), t, np.exp)

    def meridian(self, t):
        rho = self._rho(np.asarray(t, dtype=float))
        return rho * np.sin(t), rho * np.cos(t)

    def meridian_derivative(self, t):
        t = np.asarray(t, dtype=float)
        eps = 1e-6
        drho = (self._rho(t + eps) - self._rho(t - eps)) / (2 * eps)
        rho = self._rho(t)
        return drho * np.sin(t) + rho * np.cos(t), drho * np.cos(t) - rho * np.sin(t)

    def area(self) -> float:
        return Shape.area(self)

    def meridian_ufl(self, t: Any, amplitude: Any = None) -> tuple[Any, Any]:
        """(r°(t), z°(t)) as UFL expressions of the mesh coordinate t; ``amplitude``: a UFL
        value (a Constant) standing for ``self.amplitude``."""
        import ufl

        amp = self.amplitude if amplitude is None else amplitude
        rho = self.radius - amp * self._profile(ufl.cos(t), t, ufl.exp, ufl.cos)
        return rho * ufl.sin(t), rho * ufl.cos(t)

    def normal(self, x):
        raise InputError("imperfect spheres are for the axisymmetric model (--model axisym)")

    def principal_curvatures(self, x):
        raise InputError("imperfect spheres are for the axisymmetric model (--model axisym)")

    def normal_ufl(self, x):
        """n = (ρ e_r - ρ' e_β)/√(ρ² + ρ'²) at x on the surface (β = acos(z/|x|)), written
        with s e_β = (cos β x/|x|, cos β y/|x|, -sin² β) and ρ'/sin β, both smooth at the poles
        (ρ' vanishes there for both profiles)."""
        import ufl

        r = ufl.sqrt(ufl.dot(x, x))
        c = x[2] / r
        beta = ufl.variable(ufl.acos(c))
        rho = self.radius - self.amplitude * self._profile(ufl.cos(beta), beta, ufl.exp,
                                                           ufl.cos)
        drho_over_s = ufl.diff(rho, beta) / ufl.sin(beta)
        s_ebeta = ufl.as_vector([c * x[0] / r, c * x[1] / r, -(1 - c * c)])
        n = rho * x / r - drho_over_s * s_ebeta
        return n / ufl.sqrt(ufl.dot(n, n))

    def describe(self) -> dict[str, Any]:
        return {"shape": self.kind, "R": self.radius, "theta": self.theta,
                "amplitude": self.amplitude, "profile": self.profile, "width": self.width,
                "degree": self.degree}


#: largest degree n of a harmonic imperfection (the thinnest spheres of the knock-down tables
#: buckle into n = 50 at h/R = 0.002; Q_m^m = (2m-1)!! stays a double far beyond)
HARMONIC_DEGREE_MAX = 100


def _harmonic_parts(n: int, m: int, ux: Any, uy: Any, uz: Any) -> tuple[Any, Any]:
    """(C_m, Q_n^m) with P_n^m(cos θ) cos(mφ) = C_m(u) Q_n^m(u_z) on the unit sphere:
    C_m = Re((u_x + i u_y)^m) (= sin^m θ cos mφ) and Q_n^m = d^m P_n / dc^m (c = u_z), both by
    their stable recurrences, NumPy arrays or UFL expressions alike (no Condon-Shortley phase:
    Q_n^m(1) > 0). Q_m^m = (2m-1)!!, Q_(m+1)^m = (2m+1) c Q_m^m,
    (l - m) Q_l^m = (2l-1) c Q_(l-1)^m - (l+m-1) Q_(l-2)^m."""
    cm, sm = 1.0 + 0.0 * ux, 0.0 * ux
    for _ in range(m):
        cm, sm = cm * ux - sm * uy, sm * ux + cm * uy
    q0 = float(math.prod(range(1, 2 * m, 2))) + 0.0 * uz
    if n == m:
        return cm, q0
    q1 = (2 * m + 1) * uz * q0
    for ll in range(m + 2, n + 1):
        q0, q1 = q1, ((2 * ll - 1) * uz * q1 - (ll + m - 1) * q0) / (ll - m)
    return cm, q1


def _harmonic_q_and_derivative(n: int, m: int, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Q_n^m(c) and dQ_n^m/dc (NumPy), by the recurrence of ``_harmonic_parts`` and its
    derivative."""
    q0 = np.full_like(c, float(math.prod(range(1, 2 * m, 2))))
    d0 = np.zeros_like(c)
    if n == m:
        return q0, d0
    q1, d1 = (2 * m + 1) * c * q0, (2 * m + 1) * q0
    for ll in range(m + 2, n + 1):
        q0, q1, d0, d1 = (q1, ((2 * ll - 1) * c * q1 - (ll + m - 1) * q0) / (ll - m), d1,
                          ((2 * ll - 1) * (q1 + c * d1) - (ll + m - 1) * d0) / (ll - m))
    return q1, d1


@dataclass(frozen=True)
class HarmonicImperfectSphere(Shape):
    """A closed sphere whose stress-free reference surface is displaced along the radius by a
    spherical harmonic: ρ(θ, φ) = R - ``amplitude`` f, f = P_n^m(cos θ) cos(mφ) / max|P_n^m|
    (n = ``degree``, m = ``order``; θ from the pole +z, φ the azimuth from +x; max |f| = 1,
    P_n^m without the Condon-Shortley phase, so f > 0 next to the pole's meridian φ = 0).
    Amplitude > 0 is inward where f > 0. m = 0 is ``ImperfectSphere``'s "mode" profile
    P_n(cos β) (P_n(1) = 1 = max |P_n|); m > 0 is not a surface of revolution: the surface model
    only (``shells.surface.mesh`` meshes the sphere and moves its nodes radially onto ρ, as for
    ``ImperfectSphere``). The exact normal is the normalised gradient of F(x) = |x| - ρ(x/|x|),
    f a polynomial in u = x/|x| (``_harmonic_parts``): ``normal`` (NumPy) and ``normal_ufl``.
    The surface model interpolates ``normal`` (``has_ufl_normal`` False: Lagrange of one degree
    above the state's, b° = -∇n° from it): the UFL normal in its Jacobian took FFCx 140 s to
    compile for n = 2 (P2) and 600 s for n = 4, once per amplitude (the interpolated one: the
    forms of every sphere, cached). On the default mesh (P3, size 0.21) the interpolated b°
    differs from the exact one by 1.1e-3 (RMS) of the imperfection's own b° - b°_sphere at
    n = 9, m = 2 (P5: 7.8e-5). ``meridian`` is the one at φ = 0 (its poles are the surface's:
    the rigid-motion gauge and the apex read them)."""

    radius: float = 1.0
    amplitude: float = 0.0
    degree: int = 2
    order: int = 0
    kind = "harmonic-sphere"
    has_ufl_normal = False

    def __post_init__(self) -> None:
        _positive("radius", self.radius)
        for name, v in (("degree n", self.degree), ("order m", self.order)):
            if not (isinstance(v, int) and not isinstance(v, bool)
                    and 0 <= v <= HARMONIC_DEGREE_MAX):
                raise InputError(f"the harmonic's {name} must be an integer in [0, "
                                 f"{HARMONIC_DEGREE_MAX}], got {v!r}")
        if self.order > self.degree:
            raise InputError(f"the harmonic's order m must not exceed its degree n (0 <= m <= "
                             f"n), got n = {self.degree}, m = {self.order}")
        if not (isinstance(self.amplitude, (int, float)) and math.isfinite(self.amplitude)
                and abs(self.amplitude) < 0.1 * self.radius):
            raise InputError(f"the imperfection amplitude must be a number below R/10 in size, "
                             f"got {self.amplitude!r}")
        object.__setattr__(self, "_fmax", self._max_abs())

    def _max_abs(self) -> float:
        """max over θ of |P_n^m(cos θ)| (1 for m = 0: P_n(1) = 1 bounds |P_n|): the largest of
        20001 samples, refined by a bounded scalar search next to it."""
        n, m = self.degree, self.order
        if m == 0:
            return 1.0
        from scipy.optimize import minimize_scalar

        def g(t: Any) -> Any:
            t = np.asarray(t, dtype=float)
            return np.abs(np.sin(t) ** m * _harmonic_q_and_derivative(n, m, np.cos(t))[0])

        t = np.linspace(0.0, math.pi, 20001)
        i = int(np.argmax(g(t)))
        lo, hi = t[max(i - 1, 0)], t[min(i + 1, len(t) - 1)]
        r = minimize_scalar(lambda s: -float(g(s)), bounds=(lo, hi), method="bounded",
                            options={"xatol": 1e-13})
        return float(max(g(t[i]), g(r.x)))

    # -- the profile ------------------------------------------------------------------------
    def profile(self, u: np.ndarray) -> np.ndarray:
        """f at unit vectors u (shape (3, N) or (3,))."""
        u = np.asarray(u, dtype=float)
        cm, q = _harmonic_parts(self.degree, self.order, u[0], u[1], u[2])
        return cm * q / self._fmax  # type: ignore[attr-defined]

    def profile_gradient(self, u: np.ndarray) -> np.ndarray:
        """The ambient gradient ∂f/∂u of the polynomial f(u) (shape (3, N)); its tangential
        part is f's gradient on the unit sphere."""
        u = np.asarray(u, dtype=float)
        m = self.order
        q, dq = _harmonic_q_and_derivative(self.degree, m, u[2])
        z = np.zeros_like(u[0])
        cm, sm = 1.0 + z, z.copy()
        cm1, sm1 = 1.0 + z, z.copy()  # Re, Im of (u_x + i u_y)^(m-1)
        for k in range(m):
            if k == m - 1:
                cm1, sm1 = cm.copy(), sm.copy()
            cm, sm = cm * u[0] - sm * u[1], sm * u[0] + cm * u[1]
        # d/du_x (u_x + i u_y)^m = m (.)^(m-1), d/du_y = i m (.)^(m-1)
        dx, dy = (m * cm1, -m * sm1) if m > 0 else (z, z)
        return np.stack([dx * q, dy * q, cm * dq]) / self._fmax  # type: ignore[attr-defined]

    def rho(self, u: np.ndarray) -> np.ndarray:
        """ρ = R - amplitude f at unit vectors u."""
        return self.radius - self.amplitude * self.profile(u)

    # -- reference quantities -----------------------------------------------------------------
    @property
    def closed(self) -> bool:
        return True

    @property
    def t_max(self) -> float:
        return math.pi

    @property
    def R(self) -> float:  # noqa: N802
        return self.radius

    @property
    def theta(self) -> float:
        return math.pi

    def meridian(self, t):
        t = np.asarray(t, dtype=float)
        u = np.stack([np.sin(t), 0.0 * t, np.cos(t)])
        rho = self.rho(u)
        return rho * np.sin(t), rho * np.cos(t)

    def meridian_derivative(self, t):
        t = np.asarray(t, dtype=float)
        eps = 1e-6
        r1, z1 = self.meridian(t + eps)
        r0, z0 = self.meridian(t - eps)
        return (r1 - r0) / (2 * eps), (z1 - z0) / (2 * eps)

    def area(self, points: int | None = None) -> float:
        """∬ ρ √(ρ² + |∇ρ|²) dΩ (∇ on the unit sphere): Gauss-Legendre in θ, the trapezoidal
        rule in φ (spectral for the periodic integrand), ``points`` per direction (default
        4 (n + 10))."""
        k = points or 4 * (self.degree + 10)
        c, w = np.polynomial.legendre.leggauss(k)  # c = cos θ
        phi = np.linspace(0.0, 2 * math.pi, 2 * k, endpoint=False)
        C, P = np.meshgrid(c, phi, indexing="ij")
        S = np.sqrt(1 - C**2)
        u = np.stack([S * np.cos(P), S * np.sin(P), C]).reshape(3, -1)
        rho = self.rho(u)
        g = -self.amplitude * self.profile_gradient(u)
        g_t = g - u * np.sum(g * u, axis=0)  # the tangential part: ∇ρ on the unit sphere
        dA = rho * np.sqrt(rho**2 + np.sum(g_t**2, axis=0))
        return float(np.sum(dA.reshape(C.shape) * w[:, None]) * (2 * math.pi / (2 * k)))

    # -- differential geometry ----------------------------------------------------------------
    def normal(self, x):
        """∇F/|∇F|, F = |x| - ρ(x/|x|): ∇F = u + (amplitude/|x|)(I - u u) ∂f/∂u."""
        x = np.asarray(x, dtype=float)
        r = np.linalg.norm(x, axis=0)
        u = x / r
        g = self.profile_gradient(u)
        g = g - u * np.sum(g * u, axis=0)
        nv = u + self.amplitude * g / r
        return nv / np.linalg.norm(nv, axis=0)

    def principal_curvatures(self, x):
        raise InputError("a harmonic imperfect sphere has no closed-form principal curvatures "
                         "(the surface model takes b° = -P grad(n) P from normal_ufl)")

    def normal_ufl(self, x):
        """∇F/|∇F| with F = |x| - ρ(x/|x|), differentiated by UFL (f is a polynomial in
        u = x/|x|: smooth at the poles). Exact; for checks (the surface model interpolates
        ``normal``, see the class)."""
        import ufl

        r = ufl.sqrt(ufl.dot(x, x))
        u = x / r
        cm, q = _harmonic_parts(self.degree, self.order, u[0], u[1], u[2])
        F = r - self.radius + (self.amplitude / self._fmax) * cm * q  # type: ignore[attr-defined]
        g = ufl.grad(F)
        return g / ufl.sqrt(ufl.dot(g, g))

    def describe(self) -> dict[str, Any]:
        return {"shape": self.kind, "R": self.radius, "amplitude": self.amplitude,
                "degree": self.degree, "order": self.order}


@dataclass(frozen=True)
class EllipsoidalCap(_AngleShape):
    """Cap of the spheroid x^2/R^2 + y^2/R^2 + z^2/r3^2 = 1 down to parametric colatitude theta."""

    radius: float = 1.0
    r3: float = 1.5
    theta: float = math.pi / 2
    kind = "ellipsoid"

    def __post_init__(self) -> None:
        _positive("radius", self.radius)
        _positive("r3", self.r3)
        _check_theta(self.theta)

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
        _positive("radius", self.radius)
        _positive("ring", self.ring)
        if not self.ring > self.radius * (1 + 1e-9):
            raise InputError(f"a torus needs its ring radius ({self.ring:g}) above its tube "
                             f"radius ({self.radius:g}): the tube would cross the axis")

    @property
    def closed(self) -> bool:
        return True

    @property
    def t_max(self) -> float:
        return 2 * math.pi

    @property
    def R(self) -> float:  # noqa: N802
        return self.radius

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
        _positive("radius", self.radius)

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
        """Rows "r z" (spaces or commas; # comments), from the pole to the rim."""
        from shells.files import read_number_rows

        return cls(read_number_rows(path, "the meridian file", "'r z'"))


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
    """The length of κR: the pole radius of curvature R of spheres and caps; the ellipsoid's
    equatorial radius r1 (the paper's R = r1 = r2); the disk's radius."""
    if isinstance(shape, EllipsoidalCap):
        return shape.radius
    return shape.R if math.isfinite(shape.R) else shape.characteristic_size()


SHAPES = ("sphere", "cap", "ellipsoid", "disk", "torus")


def make_shape(kind: str, *, radius: float = 1.0, theta: float | None = None,
               r3: float | None = None, ring: float | None = None) -> Shape:
    """Build a shape from its name and parameters (the CLI and the mesh sidecar use this)."""
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
    """Inverse of ``Shape.describe``."""
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
