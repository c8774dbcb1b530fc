"""Closed-form results of the paper (and its references) that the computations are checked against.

All lengths are in units of the sphere radius R unless stated; ``nu`` is the Poisson ratio.

* ``sphere_radius_ratio``: the exact uniformly shrunk sphere of the Koiter energy with natural
  curvature, λ(λ² - 1) = (h²/6R)((1 - λ)/R - κ), and ``sphere_psi3_linear``, its first-order law
  Ψ3/h = -(κh/12)/(1 + (h/R)²/12).
* ``dispersion_kappa_h``: the critical κh of the spherical-harmonic degree n (x = n(n+1)) from the
  supplement's 2×2 determinant, exactly (``exact=True``, the smallest positive root of a quadratic
  in κh) or in the paper's x ≫ 1 form (its Eq. "kappacri").
* ``sphere_kappa_b_h`` = 4√(3(1-ν)/((1+ν)(5+4ν))), ``sphere_mode_x``: the minimising x.
* ``plate_a`` = √(10 + 7√2) (Pezzulla 2016): a disk of radius r bifurcates at |κ| r²/h = a.
  ``plate_a_uniform_curvature``: the same threshold in the Föppl-von Kármán plate with the
  uniform-curvature (Mansfield) ansatz, 8/(1+ν)^{3/2}, a second reduced-model reference.
* ``snap_kappa_R`` (α, β) and ``buckling_kappa_R`` (Eq. 4, a, b, c) with the paper's fitted values.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "PAPER",
    "sphere_radius_ratio",
    "sphere_psi3_linear",
    "dispersion_kappa_h",
    "sphere_kappa_b_h",
    "sphere_mode_x",
    "sphere_mode_n",
    "plate_a",
    "plate_a_uniform_curvature",
    "snap_kappa_R",
    "buckling_kappa_R",
    "mirrored_buckling_kappa_R",
]

#: The paper's numbers (ν = 1/2 unless stated).
PAPER = {
    "alpha": 0.67,
    "beta": 0.85,
    "b": 3.6,
    "c": -0.98,
    "thetabar_s": 2.09,
    "thetabar_c": 3.85,
    "thetabar_c_experiment": 3.95,
    "thetabar_c_experiment_error": 0.26,
    "kappa_b_h_nu_half": 4.0 / math.sqrt(7.0),
}


def sphere_radius_ratio(kappa: float, h_over_r: float, R: float = 1.0) -> float:
    """Radius ratio λ of the uniformly shrunk sphere: λ(λ² - 1) = (h²/6R)((1 - λ)/R - κ).

    Args:
        kappa: the natural curvature κ (absolute).
        h_over_r: thickness over radius.
        R: the radius.

    Returns:
        The real root λ nearest 1.
    """
    h = h_over_r * R
    c = h * h / (6.0 * R)
    # λ³ + (c/R - 1) λ - c (1/R - κ) = 0: the real root near 1
    roots = np.roots([1.0, 0.0, c / R - 1.0, -c * (1.0 / R - kappa)])
    real = roots[np.abs(roots.imag) < 1e-12].real
    return float(real[np.argmin(np.abs(real - 1.0))])


def sphere_psi3_linear(kappa_h: float, h_over_r: float) -> float:
    """Ψ3/h of the closed sphere to first order in κ: -(κh/12)/(1 + (h/R)²/12).

    Args:
        kappa_h: κh.
        h_over_r: thickness over radius.

    Returns:
        Ψ3/h.
    """
    return -(kappa_h / 12.0) / (1.0 + h_over_r**2 / 12.0)


def _det_coefficients(x: float, h_over_r: float, nu: float) -> tuple[float, float, float]:
    """det of the supplement's system as A (κh)² + B κh + C."""
    e = h_over_r
    # first row:  -[(1+ν) + (1+ν)/12 e k x] C + [x - (1-ν)] D
    a0, a1 = -(1 + nu), -(1 + nu) / 12 * e * x
    b0 = x - (1 - nu)
    # second row: [e²x²/12 + (1+ν)/12 e k x + 2(1+ν)] C - (1+ν)[x + e k x²/12] D
    c0, c1 = e * e * x * x / 12 + 2 * (1 + nu), (1 + nu) / 12 * e * x
    d0, d1 = -(1 + nu) * x, -(1 + nu) * e * x * x / 12
    # det = (a0 + a1 k)(d0 + d1 k) - b0 (c0 + c1 k)
    return a1 * d1, a0 * d1 + a1 * d0 - b0 * c1, a0 * d0 - b0 * c0


def dispersion_kappa_h(x: float | np.ndarray, h_over_r: float, nu: float = 0.5,
                       exact: bool = True) -> float | np.ndarray:
    """Critical κh at which the degree-n perturbation (x = n(n+1)) of the sphere is neutral.

    Args:
        x: n(n+1), a number or an array.
        h_over_r: thickness over radius.
        nu: Poisson's ratio.
        exact: the smallest positive root of the full 2×2 determinant (quadratic in κh);
            False: the paper's x ≫ 1 formula
            2 (R/h) [-3(1+2ν) + √(3(15 + (h/R)²x² + 12ν))] / ((1+ν) x).

    Returns:
        κh (of x's shape; NaN where there is no positive root).
    """
    xs = np.atleast_1d(np.asarray(x, dtype=float))
    out = np.empty_like(xs)
    for i, xi in enumerate(xs):
        if not exact:
            out[i] = (2.0 / h_over_r * (-3 * (1 + 2 * nu)
                      + math.sqrt(3 * (15 + h_over_r**2 * xi**2 + 12 * nu))) / ((1 + nu) * xi))
            continue
        A, B, C = _det_coefficients(xi, h_over_r, nu)
        r = np.roots([A, B, C]) if A != 0 else np.array([-C / B])
        r = r[(np.abs(r.imag) < 1e-12) & (r.real > 0)].real
        out[i] = float(r.min()) if r.size else math.nan
    return out if np.ndim(x) else float(out[0])


def sphere_kappa_b_h(nu: float = 0.5) -> float:
    """The thin-shell limit of the closed sphere's buckling: 4 √(3(1-ν)/((1+ν)(5+4ν))).

    Args:
        nu: Poisson's ratio.

    Returns:
        κ_b h.
    """
    return 4.0 * math.sqrt(3.0 * (1 - nu) / ((1 + nu) * (5 + 4 * nu)))


def sphere_pressure_kappa_h(nu: float = 0.5) -> float:
    """The classical buckling pressure p_c = 2E/√(3(1-ν²)) (h/R)² of a sphere as its equivalent
    curvature (the paper's Eq. (5), κh = 6 (1-ν) (R/h)² p/E).

    Args:
        nu: Poisson's ratio.

    Returns:
        κh = 12 (1-ν)/√(3(1-ν²)).
    """
    return 12.0 * (1 - nu) / math.sqrt(3.0 * (1 - nu * nu))


def sphere_mode_x(h_over_r: float, nu: float = 0.5) -> float:
    """x = n(n+1) = 2/(1+2ν) (R/h) √(3(5+4ν)(1-ν²)) minimising the dispersion relation.

    Args:
        h_over_r: thickness over radius.
        nu: Poisson's ratio.

    Returns:
        x.
    """
    return 2.0 / (1 + 2 * nu) / h_over_r * math.sqrt(3 * (5 + 4 * nu) * (1 - nu * nu))


def sphere_mode_n(h_over_r: float, nu: float = 0.5) -> float:
    """The (real) degree n of the sphere's critical mode, n(n+1) = ``sphere_mode_x``.

    Args:
        h_over_r: thickness over radius.
        nu: Poisson's ratio.

    Returns:
        n (not rounded).
    """
    x = sphere_mode_x(h_over_r, nu)
    return (-1 + math.sqrt(1 + 4 * x)) / 2


def plate_a() -> float:
    """The plate constant a = √(10 + 7√2) = 4.4609 (Pezzulla et al. 2016).

    Returns:
        a, the |κ| r²/h at which a free disk bifurcates.
    """
    return math.sqrt(10 + 7 * math.sqrt(2))


def plate_a_uniform_curvature(nu: float = 0.5) -> float:
    """|κ| r²/h at the m = 2 bifurcation of a free disk with uniform principal curvatures.

    Föppl-von Kármán plate, w = (k₁x² + k₂y²)/2: per unit area the bending energy is
    (D/2)[(k₁-κ)² + (k₂-κ)² + 2ν(k₁-κ)(k₂-κ)] and the stretching energy of a free disk with
    Gaussian curvature K = k₁k₂ is Y K² r⁴/384 (Y = Eh, D = Y h²/12(1-ν²)). On the symmetric
    branch k₁ = k₂ = c the antisymmetric direction k₁,₂ = c ± ε has stiffness
    D(1-ν) - Y c² r⁴/192, zero at c r²/h = 4/√(1+ν); equilibrium κ = c + c³r⁴(1-ν)/(16h²) then
    gives κ r²/h = 8/(1+ν)^{3/2} (4.354 at ν = 1/2, 5.397 at 0.3, 8 at 0). The ansatz is a
    restriction of the plate problem, so it is a reference for the trend in ν, not a bound.

    Args:
        nu: Poisson's ratio.

    Returns:
        8/(1+ν)^{3/2}.
    """
    return 8.0 / (1.0 + nu) ** 1.5


def snap_kappa_R(thetabar: float, alpha: float = PAPER["alpha"], beta: float = PAPER["beta"]
                 ) -> float:
    """The paper's snapping line κ_s R = β θ̄ - α (valid above θ̄_s).

    Args:
        thetabar: θ̄ = θ/√(h/R).
        alpha, beta: the line's coefficients (default: the paper's fit).

    Returns:
        κ_s R.
    """
    return beta * thetabar - alpha


def buckling_kappa_R(thetabar: float, h_over_r: float, b: float = PAPER["b"],
                     c: float = PAPER["c"]) -> float:
    """The paper's Eq. (4): κ_b R = -a/θ̄² + 1 + b/(θ̄ - π √(R/h)) + c (κ < 0).

    Args:
        thetabar: θ̄ = θ/√(h/R).
        h_over_r: thickness over radius.
        b, c: the law's coefficients (default: the paper's fit).

    Returns:
        κ_b R of the cap's loss of symmetry going down.
    """
    return -plate_a() / thetabar**2 + 1 + b / (thetabar - math.pi / math.sqrt(h_over_r)) + c


def mirrored_buckling_kappa_R(thetabar: float, h_over_r: float, b: float = PAPER["b"],
                              c: float = PAPER["c"]) -> float:
    """Eq. (4) mirrored about κR = 1: the loss of symmetry of the everted branch (κ > 0).

    Args:
        thetabar: θ̄ = θ/√(h/R).
        h_over_r: thickness over radius.
        b, c: as for ``buckling_kappa_R``.

    Returns:
        2 - ``buckling_kappa_R``.
    """
    return 2.0 - buckling_kappa_R(thetabar, h_over_r, b, c)
