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
    equilibrium. ``field``: f(u) of the natural curvature (None: 1)."""

    def __init__(self, theta: float, h: float, nu: float = 0.5, n: int = 40,
                 field: Callable[[np.ndarray], np.ndarray] | None = None,
                 quad: int | None = None) -> None:
        self.theta, self.h, self.nu, self.n = theta, h, nu, n
        nq = quad or 3 * n + 20
        t, w = np.polynomial.legendre.leggauss(nq)
        self.u = 0.5 * theta * (t + 1.0)
        self.w = 0.5 * theta * w * np.sin(self.u)  # area element sin u du
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
        # the height H = -int psi_u du = int sin u (1 + Q) du: affine in x
        self.height_row = np.concatenate([np.zeros(n + 1),
                                          (0.5 * theta * w * np.sin(self.u)) @ self.V[0]])
        self.height0 = float(np.sum(0.5 * theta * w * np.sin(self.u)))  # 1 - cos(theta)

    # -- the energy density and its derivatives ------------------------------------------------
    def density(self, y, kappa):
        """The integrand over sin u du at the quadrature points (complex-safe)."""
        P, dP, ddP, Q, dQ = y
        s, c = np.sin(self.u), np.cos(self.u)
        phi_u = c * (1 + P) + s * dP
        phi_uu = -s * (1 + P) + 2 * c * dP + s * ddP
        psi_u = -s * (1 + Q)
        psi_uu = -c * (1 + Q) - s * dQ
        L2 = phi_u**2 + psi_u**2
        L = np.sqrt(L2)
        E1, E2 = L2 - 1.0, (1 + P) ** 2 - 1.0
        nat = kappa * self.f - 1.0  # b̄ in mixed components
        K1 = (psi_uu * phi_u - phi_uu * psi_u) / L - nat
        K2 = -(1 + P) * (1 + Q) / L - nat  # phi psi_u / (L sin^2 u)
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
