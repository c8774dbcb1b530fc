"""Imperfect spheres (geometry layer): a sphere or cap whose stress-free reference surface is
displaced along its normal by an axisymmetric dimple or mode (``ImperfectSphere``), or by a
spherical harmonic that breaks the rotational symmetry (``HarmonicImperfectSphere``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from shells.errors import InputError
from shells.geometry.shapes import Shape, SphericalCap, check_positive

__all__ = ["HARMONIC_DEGREE_MAX", "HarmonicImperfectSphere", "ImperfectSphere", "check_amplitude",
           "harmonic_parts", "legendre_cosine_series"]


def check_amplitude(amplitude: float, radius: float) -> None:
    """Refuse (``InputError``) an imperfection amplitude that is not a number below R/10 in
    size (a larger one is no imperfection of the sphere)."""
    if not (isinstance(amplitude, (int, float)) and math.isfinite(amplitude)
            and abs(amplitude) < 0.1 * radius):
        raise InputError(f"the imperfection amplitude must be a number below R/10 in size, "
                         f"got {amplitude!r}")


def legendre_cosine_series(n: int) -> list[tuple[int, float]]:
    """P_n(cos t) = Σ_j a_j cos(j t): the pairs (j, a_j), from P_n(cos t) = Σ_k g_k g_(n-k)
    cos((n - 2k) t), g_k = C(2k, k) / 4^k (the terms of k and n - k merged).

    Args:
        n: the degree.

    Returns:
        The pairs (j, a_j), j ascending (of n's parity).
    """
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
        check_positive("radius", self.radius)
        if not (0 < self.theta <= math.pi * (1 + 1e-12)):
            raise InputError(f"theta must lie in (0, pi], got {self.theta!r}")
        if self.profile not in ("dimple", "mode"):
            raise InputError(f"imperfection profile must be 'dimple' or 'mode', got "
                             f"{self.profile!r}")
        check_amplitude(self.amplitude, self.radius)
        check_positive("width", self.width)
        if not (isinstance(self.degree, int) and 0 <= self.degree <= 1000):
            raise InputError(f"the mode degree must be an integer in [0, 1000], got "
                             f"{self.degree!r}")

    def profile_expression(self, c: Any, t: Any, exp: Any, cos: Any = None) -> Any:
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

    def radius_at(self, t: np.ndarray) -> np.ndarray:
        """ρ(t) = R - δ f(t): the reference surface's distance from the centre at the angle t
        from the pole."""
        return self.radius - self.amplitude * self.profile_expression(np.cos(t), t, np.exp)

    def meridian(self, t):
        rho = self.radius_at(np.asarray(t, dtype=float))
        return rho * np.sin(t), rho * np.cos(t)

    def meridian_derivative(self, t):
        t = np.asarray(t, dtype=float)
        eps = 1e-6
        drho = (self.radius_at(t + eps) - self.radius_at(t - eps)) / (2 * eps)
        rho = self.radius_at(t)
        return drho * np.sin(t) + rho * np.cos(t), drho * np.cos(t) - rho * np.sin(t)

    def area(self) -> float:
        return Shape.area(self)

    def meridian_ufl(self, t: Any, amplitude: Any = None) -> tuple[Any, Any]:
        """(r°(t), z°(t)) as UFL expressions of the mesh coordinate t; ``amplitude``: a UFL
        value (a Constant) standing for ``self.amplitude``."""
        import ufl

        amp = self.amplitude if amplitude is None else amplitude
        rho = self.radius - amp * self.profile_expression(ufl.cos(t), t, ufl.exp, ufl.cos)
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
        rho = self.radius - self.amplitude * self.profile_expression(ufl.cos(beta), beta, ufl.exp,
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


def harmonic_parts(n: int, m: int, ux: Any, uy: Any, uz: Any) -> tuple[Any, Any]:
    """(C_m, Q_n^m) with P_n^m(cos θ) cos(mφ) = C_m(u) Q_n^m(u_z) on the unit sphere:
    C_m = Re((u_x + i u_y)^m) (= sin^m θ cos mφ) and Q_n^m = d^m P_n / dc^m (c = u_z), both by
    their stable recurrences, NumPy arrays or UFL expressions alike (no Condon-Shortley phase:
    Q_n^m(1) > 0). Q_m^m = (2m-1)!!, Q_(m+1)^m = (2m+1) c Q_m^m,
    (l - m) Q_l^m = (2l-1) c Q_(l-1)^m - (l+m-1) Q_(l-2)^m.

    Args:
        n: the degree.
        m: the order (0 <= m <= n).
        ux, uy, uz: the components of the unit vector u (arrays or UFL expressions).

    Returns:
        (C_m, Q_n^m), of the inputs' kind.
    """
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
    """Q_n^m(c) and dQ_n^m/dc (NumPy), by the recurrence of ``harmonic_parts`` and its
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
    f a polynomial in u = x/|x| (``harmonic_parts``): ``normal`` (NumPy) and ``normal_ufl``.
    The surface model interpolates ``normal`` (``has_ufl_normal`` False: Lagrange of one degree
    above the state's, b° = -∇n° from it): the UFL normal in its Jacobian takes FFCx minutes
    to compile, once per amplitude, while the interpolated one's forms are those of every
    sphere, cached; its error and cost: docs/imperfections.md, the harmonic imperfection, and
    docs/design-notes.md, "The harmonic imperfection's normal".
    ``meridian`` is the one at φ = 0 (its poles are the surface's: the rigid-motion gauge and
    the apex read them)."""

    kind = "harmonic-sphere"
    has_ufl_normal = False
    radius: float = 1.0
    amplitude: float = 0.0
    degree: int = 2
    order: int = 0

    def __post_init__(self) -> None:
        check_positive("radius", self.radius)
        for name, v in (("degree n", self.degree), ("order m", self.order)):
            if not (isinstance(v, int) and not isinstance(v, bool)
                    and 0 <= v <= HARMONIC_DEGREE_MAX):
                raise InputError(f"the harmonic's {name} must be an integer in [0, "
                                 f"{HARMONIC_DEGREE_MAX}], got {v!r}")
        if self.order > self.degree:
            raise InputError(f"the harmonic's order m must not exceed its degree n (0 <= m <= "
                             f"n), got n = {self.degree}, m = {self.order}")
        check_amplitude(self.amplitude, self.radius)
        object.__setattr__(self, "f_max", self._max_abs())

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
        cm, q = harmonic_parts(self.degree, self.order, u[0], u[1], u[2])
        return cm * q / self.f_max  # type: ignore[attr-defined]

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
        return np.stack([dx * q, dy * q, cm * dq]) / self.f_max  # type: ignore[attr-defined]

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
        cm, q = harmonic_parts(self.degree, self.order, u[0], u[1], u[2])
        F = r - self.radius + (self.amplitude / self.f_max) * cm * q  # type: ignore[attr-defined]
        g = ufl.grad(F)
        return g / ufl.sqrt(ufl.dot(g, g))

    def describe(self) -> dict[str, Any]:
        return {"shape": self.kind, "R": self.radius, "amplitude": self.amplitude,
                "degree": self.degree, "order": self.order}
