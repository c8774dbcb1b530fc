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
* The free circular Kirchhoff plate's natural frequencies, ω = (λ²/a²) √(D/(ρh)):
  ``free_plate_lambda2`` (λ² from the free edge's characteristic equation),
  ``free_plate_rotary_inertia`` (Rayleigh's rotary-inertia correction), and the free shallow
  spherical cap's approach to them, ``free_cap_membrane_factor`` and ``free_cap_omega2``.
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
    "free_plate_lambda2",
    "free_plate_rotary_inertia",
    "free_cap_membrane_factor",
    "free_cap_omega2",
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


# ------------------------------------------------------------------------------------------------
# the free circular plate and the free shallow spherical cap
# ------------------------------------------------------------------------------------------------
def _check_plate_mode(n: int, nu: float, root: int) -> None:
    """Refuse a plate mode out of range (``InputError``)."""
    from shells.errors import InputError

    if not (isinstance(n, int) and n >= 0):
        raise InputError(f"n must be a non-negative integer, got {n!r}")
    if not (isinstance(root, int) and root >= 1):
        raise InputError(f"root must be a positive integer, got {root!r}")
    if not (isinstance(nu, (int, float)) and -1.0 < nu <= 0.5):
        raise InputError(f"nu must lie in (-1, 0.5], got {nu!r}")


def _free_edge_rows(x: float, n: int, nu: float) -> tuple[float, float, float, float]:
    """The free edge's conditions on w = A J_n(x r) + B I_n(x r) at r = 1 (radius a = 1):
    (M_J, M_I, V_J, V_I), M_r ∝ A M_J + B M_I and V_r ∝ A V_J + B V_I.

    M_r ∝ w'' + ν (w' - n² w) and V_r ∝ (∇²w)' - (1-ν) n² (w' - w) at r = 1; with Bessel's
    equation J'' = -J'/x - (1 - n²/x²) J, I'' = -I'/x + (1 + n²/x²) I and ∇² J_n(x r) =
    -x² J_n, ∇² I_n(x r) = x² I_n. The I column is scaled by e^(-x) (``ive``): the rows'
    ratios and the determinant's sign are unchanged."""
    from scipy import special

    jn, jp = special.jv(n, x), special.jvp(n, x)
    i_n = special.ive(n, x)
    ip = 0.5 * (special.ive(n - 1, x) + special.ive(n + 1, x))
    m_j = -(x * x * jn + (1 - nu) * (x * jp - n * n * jn))
    m_i = x * x * i_n - (1 - nu) * (x * ip - n * n * i_n)
    v_j = -(x**3 * jp + (1 - nu) * n * n * (x * jp - jn))
    v_i = x**3 * ip - (1 - nu) * n * n * (x * ip - i_n)
    return m_j, m_i, v_j, v_i


def _free_plate_det(x: float, n: int, nu: float) -> float:
    """The characteristic function M_J V_I - M_I V_J of the free plate, divided by |J_n(x)| +
    |J_n'(x)| (never zero) so that it has no other zeros and a moderate size."""
    from scipy import special

    m_j, m_i, v_j, v_i = _free_edge_rows(x, n, nu)
    return (m_j * v_i - m_i * v_j) / (abs(special.jv(n, x)) + abs(special.jvp(n, x)))


def _free_plate_mode(n: int, nu: float, root: int) -> tuple[float, float]:
    """(λ, B): the root-th positive root λ of the characteristic equation, and the mode
    w(r) = J_n(λ r) + B I_n(λ r) (r in units of a)."""
    from scipy.optimize import brentq

    _check_plate_mode(n, nu, root)
    step, lo = 0.05, 0.05  # consecutive roots lie about π apart; λ = 0 (n ≤ 1: rigid) skipped
    f_lo, found = _free_plate_det(lo, n, nu), 0
    while True:
        hi = lo + step
        f_hi = _free_plate_det(hi, n, nu)
        if f_lo == 0.0 or f_lo * f_hi < 0:
            found += 1
            if found == root:
                lam = lo if f_lo == 0.0 else brentq(_free_plate_det, lo, hi, args=(n, nu),
                                                    xtol=1e-14, rtol=1e-15)
                break
        lo, f_lo = hi, f_hi
    m_j, m_i, _, _ = _free_edge_rows(lam, n, nu)
    # M_r = 0: A M_J + B M_I = 0 with A = 1, M_I = e^λ times its scaled value
    return lam, -m_j / m_i * math.exp(-lam)


def _plate_integrals(n: int, nu: float, root: int) -> tuple[float, float, float, float]:
    """λ² and, over the unit disk (the cos nφ factor dropped), ∫ w² r dr, ∫ |∇w|² r dr
    (|∇w|² = w'² + n² w²/r²) and ∫ w rⁿ r dr of the mode, by 64-point Gauss-Legendre (the
    integrands are entire: exact to round-off for the low modes)."""
    from scipy import special

    lam, B = _free_plate_mode(n, nu, root)
    xg, wg = np.polynomial.legendre.leggauss(64)
    r, wg = 0.5 * (xg + 1.0), 0.5 * wg
    w = special.jv(n, lam * r) + B * special.iv(n, lam * r)
    dw = lam * (special.jvp(n, lam * r) + B * special.ivp(n, lam * r))
    ww = float(np.sum(wg * w * w * r))
    grad = float(np.sum(wg * (dw * dw + n * n * w * w / (r * r)) * r))
    proj = float(np.sum(wg * w * r ** (n + 1)))
    return lam * lam, ww, grad, proj


def free_plate_lambda2(n: int, nu: float = 0.5, root: int = 1) -> float:
    """λ² of the free circular Kirchhoff plate: ω = (λ²/a²) √(D/(ρh)), D = E h³/(12(1-ν²)).

    The modes w = [J_n(λr/a) + B I_n(λr/a)] cos nφ (n nodal diameters) with the free edge's
    M_r = 0 and Kirchhoff shear V_r = Q_r + ∂_φ M_rφ / a = 0 at r = a; λ the roots of their
    2×2 determinant (Leissa, Vibration of Plates, NASA SP-160, 1969, Eq. 2.23), found by a
    scan for sign changes and ``scipy.optimize.brentq``. λ = 0 (the rigid translation, n = 0,
    and tilt, n = 1) is not counted.

    ν = 0.33: 5.26204 (n = 2), 9.06890 (n = 0, one nodal circle), 12.2439 (n = 3); the 1D
    model's flat disk (h/a = 1e-3, 40 cells, penalty 10) gives 5.262033, 9.068891, 12.243882,
    low by its rotary inertia (``free_plate_rotary_inertia``, 1e-6). Leissa's table (after
    older sources) has 5.253, 9.084, 12.23, 0.1-0.2 % off; its n = 1 values (20.52, 59.86)
    agree with these (20.513, 59.859).

    Args:
        n: nodal diameters (the azimuthal wavenumber m of the 1D model).
        nu: Poisson's ratio.
        root: which positive root: the mode has root - 1 nodal circles for n ≥ 2 and root
            nodal circles for n = 0, 1.

    Returns:
        λ².

    Raises:
        InputError: n, root or ν out of range.
    """
    lam, _ = _free_plate_mode(n, nu, root)
    return lam * lam


def free_plate_rotary_inertia(n: int, nu: float = 0.5, root: int = 1) -> float:
    """G = a² ∫ |∇w|² dA / ∫ w² dA of the free plate's mode (``free_plate_lambda2``).

    The kinetic energy with the rotary inertia of the normal, ½ ∫ (ρh ẇ² + ρh³/12 |∇ẇ|²) dA
    (Rayleigh's plate; the models' kinetic mass is that), lowers ω² to first order by the
    factor 1 - G (h/a)²/12, the error O((h/a)⁴): at h/a = 0.01 the 1D model's flat disk gives
    the corrected λ² of n = 0, 2, 3 (ν = 1/2) to 1e-7.

    Args:
        n, nu, root: the mode, as for ``free_plate_lambda2``.

    Returns:
        G (18.245, 11.161, 21.004 for n = 0, 2, 3 at ν = 1/2).

    Raises:
        InputError: as ``free_plate_lambda2``.
    """
    _, ww, grad, _ = _plate_integrals(n, nu, root)
    return grad / ww


def free_cap_membrane_factor(n: int, nu: float = 0.5, root: int = 1) -> float:
    """q: the stretching of a free shallow spherical cap in its plate mode,
    ω² = ω²_plate + q E/(ρR²) to first order in 1/R².

    Shallow-shell theory (E. Reissner, Q. Appl. Math. 13, 169, 1955), in-plane inertia
    neglected: the Airy function F of the membrane stresses solves ∇⁴F = (Eh/R) ∇²w with a
    free edge (N_rr = N_rφ = 0), and the stretching energy ∫ w ∇²F dA / (2R) adds q E/(ρR²)
    to ω², q = ∫ w ∇²f dA / ∫ w² dA (∇⁴f = ∇²w, units of a). With f = f_p + C₁ rⁿ +
    C₂ r^(n+2), ∇²f_p = w, the edge conditions give ∇²f = w - 2(n + 1) P rⁿ, P = ∫₀¹ w
    r^(n+1) dr, so

        q = 1 - 2(n + 1) P² / ∫₀¹ w² r dr,

    one minus the squared cosine (in ∫ · r dr) between the mode and rⁿ, the only regular
    harmonic w with n diameters: the shallow sphere's inextensional deformation. n = 0, 1:
    q = 1 (the mode is orthogonal to the rigid motion rⁿ: Reissner's ω² = ω²_plate +
    E/(ρR²)); n ≥ 2: the lowest modes are nearly rⁿ cos nφ, q = 1.0698e-3 (n = 2) and
    4.5073e-3 (n = 3) at ν = 1/2.

    Args:
        n, nu, root: the mode, as for ``free_plate_lambda2``.

    Returns:
        q.

    Raises:
        InputError: as ``free_plate_lambda2``.
    """
    _, ww, _, proj = _plate_integrals(n, nu, root)
    return 1.0 - 2.0 * (n + 1) * proj * proj / ww


def free_cap_omega2(thetabar: float, h_over_r: float, n: int, nu: float = 0.5,
                    root: int = 1) -> float:
    """The free spherical cap's ω² R² ρ/E near the plate limit (θ̄ small, a/h large).

    In the plate's units Ω² = ω² a⁴ ρh/D (a = R sin θ, θ = θ̄ √(h/R)):

        Ω² = λ⁴ (1 - G (h/a)²/12) + q 12 (1-ν²) θ̄⁴,

    λ² of ``free_plate_lambda2``, G of ``free_plate_rotary_inertia``, q of
    ``free_cap_membrane_factor`` (q E/(ρR²) in these units is q 12 (1-ν²) θ̄⁴, to O(θ²)).
    Left out: O((h/a)⁴), O(θ̄⁸) and the non-shallow O(θ²) = O(θ̄² h/R), relative to λ⁴ (a
    = R θ in place of R sin θ moves Ω² by (2/3) θ² of itself): for n ≥ 2, whose q is small,
    that matters to the stretching term unless h/R ≪ q θ̄².

    Args:
        thetabar: θ̄ = θ / √(h/R).
        h_over_r: h/R.
        n, nu, root: the mode, as for ``free_plate_lambda2``.

    Returns:
        ω² in units of E/(ρR²).

    Raises:
        InputError: as ``free_plate_lambda2``.
    """
    lam2 = free_plate_lambda2(n, nu, root)
    a = math.sin(thetabar * math.sqrt(h_over_r))
    big = (lam2 * lam2 * (1 - free_plate_rotary_inertia(n, nu, root) * (h_over_r / a) ** 2 / 12)
           + free_cap_membrane_factor(n, nu, root) * 12 * (1 - nu * nu) * thetabar**4)
    return big * h_over_r**2 / (12 * (1 - nu * nu) * a**4)
