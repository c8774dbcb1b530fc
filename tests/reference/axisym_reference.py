"""An independent reference for open caps: the axisymmetric equilibrium of a spherical cap with
natural curvature, by a Chebyshev-Ritz spectral method in numpy/scipy alone.

It shares no code, no discretisation and no formulation with ``shells`` (FEniCSx, finite
elements, the displacement as unknown): it starts from the paper's text. The energy is the
paper's Eq. (1) in the 1D form of its supplement ("1D model and 2D model"): the meridian
u -> (phi(u), psi(u)) of the cap of radius R = 1, u in [0, theta] the reference polar angle,

    a = diag(phi_u^2 + psi_u^2, phi^2),
    b = diag(psi_uu phi_u - phi_uu psi_u, phi psi_u) / sqrt(phi_u^2 + psi_u^2),

the reference a° = diag(1, sin^2 u), b° = -a° (phi = sin u, psi = cos u), and the natural
curvature b̄ = b° + kappa f(u) a° (f = 1: uniform). With the mixed strains E = a°^-1 (a - a°)
and K = a°^-1 (b - b̄), the energy per 2 pi is

    U = int_0^theta { (1-nu)(E1^2 + E2^2) + nu (E1 + E2)^2
                      + h^2/3 [(1-nu)(K1^2 + K2^2) + nu (K1 + K2)^2] } sin u du.

Unknowns: phi = sin u (1 + P(u)) and psi_u = -sin u (1 + Q(u)), P and Q polynomials of degree
``n`` in the Chebyshev basis on [0, theta] (phi(0) = 0 and psi_u(0) = 0 by construction, no
singular term at the pole; psi itself enters only through its derivatives, so the rigid
translation is gone; the free rim's conditions are natural). U is integrated by Gauss-Legendre
quadrature; its gradient is exact (the pointwise derivatives by complex steps), its Hessian a
central difference of the gradient (it only steers Newton's method).

The snap-through fold of the fundamental branch is found without any stability computation: the
branch is parametrised by the cap's height H = psi(0) - psi(theta) (one more equation, kappa one
more unknown), and the fold is the maximum of kappa(H), located by Brent's method. Its accuracy is
measured by the difference between two polynomial degrees (``fold_kappa`` returns both).

Bifurcations (``ModeStability``, ``bifurcation_kappa``): the block m of the Hessian of the full
2D energy at an axisymmetric state, for the perturbation a(u) cos(mv) e_r + b(u) sin(mv) e_v +
c(u) cos(mv) e_z (a, b ~ u^(m-1), c ~ u^m at the pole, times Chebyshev polynomials), the
azimuth integrated exactly; the bifurcation into m is where its smallest eigenvalue (against
the displacements' L2 metric) crosses zero along the branch, located by Brent's root finder.

Run as a script for the 30° cap at h/R = 0.04: ``python3 tests/reference/axisym_reference.py``.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.polynomial import chebyshev as cheb
from scipy.optimize import minimize_scalar


class CapReference:
    """The discrete energy of one cap (R = 1) and Newton's method on the height-constrained
    equilibrium. ``field``: f(u) of the natural curvature (None: 1). ``disk=True``: the flat
    disk of radius 1 instead (u in [0, 1] the radius, ``theta`` ignored: a° = diag(1, u^2),
    b° = 0, phi = u (1 + P), psi_u = u Q)."""

    def __init__(self, theta: float, h: float, nu: float = 0.5, n: int = 40,
                 field: Callable[[np.ndarray], np.ndarray] | None = None,
                 quad: int | None = None, disk: bool = False) -> None:
        theta = 1.0 if disk else theta
        self.theta, self.h, self.nu, self.n, self.disk = theta, h, nu, n, disk
        nq = quad or 3 * n + 20
        t, w = np.polynomial.legendre.leggauss(nq)
        self.u = 0.5 * theta * (t + 1.0)
        # the reference meridian's radius rho0 and its derivatives, psi_u = rho0 (q0 + Q), and
        # b° = b0 a° (the sphere of radius 1: b0 = -1; the plane: 0)
        if disk:
            self.rho = [self.u, np.ones_like(self.u), np.zeros_like(self.u)]
            self.q0, self.b0 = 0.0, 0.0
        else:
            self.rho = [np.sin(self.u), np.cos(self.u), -np.sin(self.u)]
            self.q0, self.b0 = -1.0, -1.0
        self.w = 0.5 * theta * w * self.rho[0]  # the area element rho0 du
        self.f = np.ones_like(self.u) if field is None else np.asarray(field(self.u), float)
        # Chebyshev basis on [0, theta]: values, first and second derivatives in u
        tt = 2.0 * self.u / theta - 1.0
        eye = np.eye(n + 1)
        self.V = [np.stack([cheb.chebval(tt, cheb.chebder(eye[k], d)) * (2.0 / theta) ** d
                            for k in range(n + 1)], axis=1) for d in (0, 1, 2)]
        z = np.zeros_like(self.V[0])
        # the pointwise quantities y = (P, P', P'', Q, Q') from x = (p, q)
        self.B = [np.hstack([self.V[0], z]), np.hstack([self.V[1], z]),
                  np.hstack([self.V[2], z]), np.hstack([z, self.V[0]]),
                  np.hstack([z, self.V[1]])]
        # the height H = -int psi_u du = -int rho0 (q0 + Q) du: affine in x
        self.height_row = np.concatenate([np.zeros(n + 1),
                                          -(0.5 * theta * w * self.rho[0]) @ self.V[0]])
        self.height0 = float(-self.q0 * np.sum(0.5 * theta * w * self.rho[0]))  # 1 - cos(theta)

    def meridian(self, y):
        """phi, phi_u, phi_uu, psi_u, psi_uu at the quadrature points from y = (P, P', P'',
        Q, Q')."""
        P, dP, ddP, Q, dQ = y
        r, dr, ddr = self.rho
        phi = r * (1 + P)
        phi_u = dr * (1 + P) + r * dP
        phi_uu = ddr * (1 + P) + 2 * dr * dP + r * ddP
        psi_u = r * (self.q0 + Q)
        psi_uu = dr * (self.q0 + Q) + r * dQ
        return phi, phi_u, phi_uu, psi_u, psi_uu

    # -- the energy density and its derivatives ------------------------------------------------
    def density(self, y, kappa):
        """The integrand over sin u du at the quadrature points (complex-safe)."""
        P, Q = y[0], y[3]
        _, phi_u, phi_uu, psi_u, psi_uu = self.meridian(y)
        L2 = phi_u**2 + psi_u**2
        L = np.sqrt(L2)
        E1, E2 = L2 - 1.0, (1 + P) ** 2 - 1.0
        nat = kappa * self.f + self.b0  # b̄ in mixed components
        K1 = (psi_uu * phi_u - phi_uu * psi_u) / L - nat
        K2 = (1 + P) * (self.q0 + Q) / L - nat  # phi psi_u / (L rho0^2)
        nu = self.nu
        stretch = (1 - nu) * (E1**2 + E2**2) + nu * (E1 + E2) ** 2
        bend = (1 - nu) * (K1**2 + K2**2) + nu * (K1 + K2) ** 2
        return stretch + self.h**2 / 3.0 * bend

    def _y(self, x):
        return np.stack([B @ x for B in self.B])

    def _dW(self, y, kappa):
        """Pointwise derivatives dW/dy_k, exact (complex steps), shape (5, nq)."""
        step = 1e-30
        out = np.empty_like(y)
        for k in range(5):
            yc = y.astype(complex)
            yc[k] += 1j * step
            out[k] = self.density(yc, kappa).imag / step
        return out

    def energy(self, x, kappa) -> float:
        return float(self.w @ self.density(self._y(x), kappa))

    def gradient(self, x, kappa):
        d = self._dW(self._y(x), kappa) * self.w
        return sum(B.T @ d[k] for k, B in enumerate(self.B))

    def hessian(self, x, kappa):
        y = self._y(x)
        H = np.zeros((x.size, x.size))
        for ell in range(5):
            eps = 1e-6 * max(1.0, float(np.max(np.abs(y[ell]))))
            yp, ym = y.copy(), y.copy()
            yp[ell] += eps
            ym[ell] -= eps
            dd = (self._dW(yp, kappa) - self._dW(ym, kappa)) / (2 * eps) * self.w
            for k in range(5):
                H += self.B[k].T @ (dd[k][:, None] * self.B[ell])
        return 0.5 * (H + H.T)

    def dgrad_dkappa(self, x, kappa):
        e = 1e-6
        return (self.gradient(x, kappa + e) - self.gradient(x, kappa - e)) / (2 * e)

    # -- equilibria -----------------------------------------------------------------------------
    def solve_at_height(self, height: float, x0, kappa0: float, tol: float = 1e-12,
                        maxit: int = 30):
        """The equilibrium whose height is ``height``: (x, kappa), Newton from (x0, kappa0)."""
        x, kappa = np.array(x0, float), float(kappa0)
        m = x.size
        for _ in range(maxit):
            g = self.gradient(x, kappa)
            r = np.concatenate([g, [self.height0 + self.height_row @ x - height]])
            if np.linalg.norm(r) < tol:
                return x, kappa
            J = np.zeros((m + 1, m + 1))
            J[:m, :m] = self.hessian(x, kappa)
            J[:m, m] = self.dgrad_dkappa(x, kappa)
            J[m, :m] = self.height_row
            d = np.linalg.solve(J, -r)
            x, kappa = x + d[:m], kappa + d[m]
        raise RuntimeError(f"Newton did not converge at height {height} (|r| = "
                           f"{np.linalg.norm(r):.2e})")

    def fold(self, step: float = 0.02, xtol: float = 1e-10, which: int = 1) -> dict:
        """Follow the fundamental branch from kappa = 0 by decreasing the height in steps of
        ``step`` times the initial height, to its ``which``-th turning point in kappa (1: the
        snap-through fold, a maximum of kappa(H); 2: the next, a minimum, where the everted
        branch turns back), located by Brent's method: {"kappa_R", "height", "min_eig"}
        (min_eig: the smallest |eigenvalue| of the Hessian at fixed kappa there over the
        largest, ~0 at a fold)."""
        x = np.zeros(2 * (self.n + 1))
        kappa, H = 0.0, self.height0
        hist = [(H, kappa, x)]
        sign, found = 1.0, 0  # +1: looking for a maximum, -1: a minimum
        while True:
            Hn = H - step * self.height0
            if len(hist) >= 2:  # secant predictor
                (H1, k1, x1), (H2, k2, x2) = hist[-2], hist[-1]
                a = (Hn - H2) / (H2 - H1)
                xg, kg = x2 + a * (x2 - x1), k2 + a * (k2 - k1)
            else:
                xg, kg = x, kappa
            x, kappa = self.solve_at_height(Hn, xg, kg)
            H = Hn
            hist.append((H, kappa, x))
            if len(hist) >= 3 and sign * (hist[-1][1] - hist[-2][1]) < 0:
                found += 1
                if found == which:
                    break
                sign = -sign
            if H < -self.height0:
                raise RuntimeError(f"no turning point {which} on the fundamental branch")
        (Ha, _, _), (Hb, kb, xb), (Hc, _, _) = hist[-3], hist[-2], hist[-1]
        cache = {"x": xb, "k": kb}

        def objective(Hq):
            xq, kq = self.solve_at_height(Hq, cache["x"], cache["k"])
            cache.update(x=xq, k=kq)
            return -sign * kq

        res = minimize_scalar(objective, bracket=(Ha, Hb, Hc), method="brent",
                              options={"xtol": xtol})
        xf, kf = self.solve_at_height(res.x, cache["x"], cache["k"])
        ev = np.linalg.eigvalsh(self.hessian(xf, kf))
        return {"kappa_R": float(kf), "height": float(res.x),
                "min_eig": float(np.min(np.abs(ev)) / np.max(np.abs(ev)))}


def fold_kappa(theta: float, h: float, nu: float = 0.5, n: int = 40,
               field: Callable[[np.ndarray], np.ndarray] | None = None,
               which: int = 1) -> tuple[float, float]:
    """The ``which``-th fold's kappa R (``CapReference.fold``) at polynomial degree ``n`` and
    its accuracy, estimated as the difference from degree ``n - 10``:
    (kappa_R, |kappa_R(n) - kappa_R(n - 10)|)."""
    k = CapReference(theta, h, nu, n, field).fold(which=which)["kappa_R"]
    k_low = CapReference(theta, h, nu, n - 10, field).fold(which=which)["kappa_R"]
    return k, abs(k - k_low)


if __name__ == "__main__":
    import time

    for n in (20, 30, 40, 50):
        t0 = time.perf_counter()
        r = CapReference(math.radians(30), 0.04, 0.5, n).fold()
        print(f"30° cap, h/R = 0.04, n = {n}: fold kappa R = {r['kappa_R']:.9f} (height "
              f"{r['height']:.6f}, min |eig|/max {r['min_eig']:.1e}), "
              f"{time.perf_counter() - t0:.1f} s")


# ------------------------------------------------------------------------------------------------
# Stability of the axisymmetric state against a Fourier mode m: the second variation of the full
# 2D energy, X(u, v) = X0(u, v) + a(u) cos(mv) e_r + b(u) sin(mv) e_v + c(u) cos(mv) e_z
# ------------------------------------------------------------------------------------------------
def _density_2d(y, s, nat, h, nu):
    """The energy density over s du dv of the surface whose local derivatives are
    y = (X_u, X_v, X_uu, X_uv, X_vv) (each (3, ...)), on the reference a° = diag(1, s²),
    b̄ = nat a° (complex-safe)."""
    Xu, Xv, Xuu, Xuv, Xvv = y[0:3], y[3:6], y[6:9], y[9:12], y[12:15]

    def dot(p, q):
        return p[0] * q[0] + p[1] * q[1] + p[2] * q[2]

    N = np.stack([Xu[1] * Xv[2] - Xu[2] * Xv[1], Xu[2] * Xv[0] - Xu[0] * Xv[2],
                  Xu[0] * Xv[1] - Xu[1] * Xv[0]])
    n = N / np.sqrt(dot(N, N))
    a11, a12, a22 = dot(Xu, Xu), dot(Xu, Xv), dot(Xv, Xv)
    b11, b12, b22 = dot(Xuu, n), dot(Xuv, n), dot(Xvv, n)
    s2 = s * s
    E11, E12, E21, E22 = a11 - 1.0, a12, a12 / s2, a22 / s2 - 1.0
    K11, K12, K21, K22 = b11 - nat, b12, b12 / s2, b22 / s2 - nat
    trE2 = E11 * E11 + 2 * E12 * E21 + E22 * E22
    trK2 = K11 * K11 + 2 * K12 * K21 + K22 * K22
    return ((1 - nu) * trE2 + nu * (E11 + E22) ** 2
            + h * h / 3.0 * ((1 - nu) * trK2 + nu * (K11 + K22) ** 2))


class ModeStability:
    """The block m of the Hessian of the 2D energy at an axisymmetric state of ``cap``
    (a ``CapReference``): Ritz basis a = u^p T_k, b = u^p T_k (m > 0), c = u^q T_k (p = m - 1,
    q = m; m = 0: p = 1, q = 2, which removes the rigid translation), degree ``n``; the
    azimuth integrated exactly by ``4 m + 12`` equispaced points. m = 1 (rigid motions) is
    not handled."""

    def __init__(self, cap: CapReference, m: int, n: int = 24) -> None:
        if m == 1:
            raise ValueError("m = 1 holds rigid motions: not handled")
        self.cap, self.m = cap, m
        u, theta = cap.u, cap.theta
        nv = 4 * m + 12
        self.v = 2 * np.pi * np.arange(nv) / nv
        self.wv = 2 * np.pi / nv
        tt = 2.0 * u / theta - 1.0
        eye = np.eye(n + 1)
        T = [np.stack([cheb.chebval(tt, cheb.chebder(eye[k], d)) * (2.0 / theta) ** d
                       for k in range(n + 1)]) for d in (0, 1, 2)]  # (n+1, nq)

        def times_power(p):  # u^p T_k and its first two derivatives
            g = [u**p, p * u ** max(p - 1, 0), p * (p - 1) * u ** max(p - 2, 0)]
            return [g[0] * T[0], g[1] * T[0] + g[0] * T[1],
                    g[2] * T[0] + 2 * g[1] * T[1] + g[0] * T[2]]

        p, q = (1, 2) if m == 0 else (m - 1, m)
        comps = ["a", "c"] if m == 0 else ["a", "b", "c"]
        self.basis = [(comp, f) for comp in comps
                      for f in zip(*times_power(q if comp == "c" else p), strict=True)]
        # the L2 Gram matrix of the displacements (the metric of the eigenvalue problem)
        vals = np.array([f[0] for _, f in self.basis])
        same = np.array([[ci == cj for cj, _ in self.basis] for ci, _ in self.basis])
        self.M = (vals * cap.w) @ vals.T * same

    def _base(self, x):
        """The axisymmetric state's local derivatives, (15, nq, nv)."""
        cap = self.cap
        phi, phi_u, phi_uu, psi_u, psi_uu = cap.meridian(cap._y(x))
        cv, sv = np.cos(self.v), np.sin(self.v)
        er = np.stack([cv, sv, 0 * cv])[:, None, :]
        et = np.stack([-sv, cv, 0 * cv])[:, None, :]
        ez = np.array([0.0, 0.0, 1.0])[:, None, None]

        def col(f):
            return f[None, :, None]

        return np.concatenate([col(phi_u) * er + col(psi_u) * ez, col(phi) * et,
                               col(phi_uu) * er + col(psi_uu) * ez, col(phi_u) * et,
                               -col(phi) * er])

    def _variations(self):
        """Each basis function's local derivatives, (nbasis, 15, nq, nv)."""
        m = self.m
        cv, sv = np.cos(self.v), np.sin(self.v)
        cm, sm = np.cos(m * self.v), np.sin(m * self.v)
        er = np.stack([cv, sv, 0 * cv])[:, None, :]
        et = np.stack([-sv, cv, 0 * cv])[:, None, :]
        ez = np.array([0.0, 0.0, 1.0])[:, None, None]
        out = []
        for comp, (f, df, ddf) in self.basis:
            F, dF, ddF = (g[None, :, None] for g in (f, df, ddf))
            if comp == "a":
                d_v = -m * sm * er + cm * et
                parts = [dF * cm * er, F * d_v, ddF * cm * er, dF * d_v,
                         F * (-(m * m + 1) * cm * er - 2 * m * sm * et)]
            elif comp == "b":
                d_v = m * cm * et - sm * er
                parts = [dF * sm * et, F * d_v, ddF * sm * et, dF * d_v,
                         F * (-(m * m + 1) * sm * et - 2 * m * cm * er)]
            else:
                parts = [dF * cm * ez, -m * F * sm * ez, ddF * cm * ez, -m * dF * sm * ez,
                         -m * m * F * cm * ez]
            out.append(np.concatenate(parts))
        return np.stack(out)

    def hessian(self, x, kappa):
        """The block's Hessian at the state x (a ``CapReference`` solution) and kappa."""
        cap = self.cap
        y0 = self._base(x)
        s = cap.rho[0][:, None]
        nat = (kappa * cap.f + cap.b0)[:, None]

        def grad(y):  # pointwise gradient in y, exact (complex steps)
            out = np.empty_like(y)
            for k in range(15):
                yc = y.astype(complex)
                yc[k] += 1e-30j
                out[k] = _density_2d(yc, s, nat, cap.h, cap.nu).imag / 1e-30
            return out

        W2 = np.empty((15, 15) + y0.shape[1:])
        for ell in range(15):
            eps = 1e-6 * max(1.0, float(np.max(np.abs(y0[ell]))))
            yp, ym = y0.copy(), y0.copy()
            yp[ell] += eps
            ym[ell] -= eps
            W2[:, ell] = (grad(yp) - grad(ym)) / (2 * eps)
        W2 = 0.5 * (W2 + W2.transpose(1, 0, 2, 3))
        weight = cap.w[:, None] * self.wv  # sin u du dv
        D = self._variations()
        T = np.einsum("klqv,jlqv->jkqv", W2 * weight, D)
        H = np.einsum("ikqv,jkqv->ij", D, T)
        return 0.5 * (H + H.T)

    def lowest(self, x, kappa) -> float:
        """The smallest eigenvalue of H v = lambda M v (M: the L2 Gram matrix)."""
        from scipy.linalg import eigh

        return float(eigh(self.hessian(x, kappa), self.M, eigvals_only=True,
                          subset_by_index=[0, 0])[0])


def solve_at_kappa(cap: CapReference, kappa: float, x0, tol: float = 1e-12, maxit: int = 30):
    """The axisymmetric equilibrium at ``kappa`` by Newton's method from ``x0``."""
    x = np.array(x0, float)
    for _ in range(maxit):
        g = cap.gradient(x, kappa)
        if np.linalg.norm(g) < tol:
            return x
        x = x - np.linalg.solve(cap.hessian(x, kappa), g)
    raise RuntimeError(f"Newton did not converge at kappa {kappa}")


def bifurcation_kappa(cap: CapReference, m: int, kappas, n_mode: int = 24,
                      xtol: float = 1e-10) -> float:
    """Follow the axisymmetric branch from kappa = 0 through the values ``kappas`` (natural
    continuation: they must stay short of any fold) to where the block m first loses positive
    definiteness; that kappa R by Brent's root finder on its smallest eigenvalue."""
    from scipy.optimize import brentq

    block = ModeStability(cap, m, n_mode)
    x = np.zeros(2 * (cap.n + 1))
    k_prev, lam_prev, x_prev = 0.0, block.lowest(x, 0.0), x
    for k in kappas:
        x = solve_at_kappa(cap, k, x_prev)
        lam = block.lowest(x, k)
        if lam < 0 < lam_prev:
            def f(kq, cache={"x": x_prev}):  # noqa: B006 (the last state, the next guess)
                cache["x"] = solve_at_kappa(cap, kq, cache["x"])
                return block.lowest(cache["x"], kq)

            return float(brentq(f, k_prev, k, xtol=xtol))
        k_prev, lam_prev, x_prev = k, lam, x
    raise RuntimeError(f"block m = {m} stays positive definite up to kappa R = {k_prev}")
