"""The natural curvature of a bilayer (a shared leaf): two bonded layers with a mismatch strain
(differential swelling, or thermal expansion) bend to the curvature of Timoshenko's bimetal
formula (S. Timoshenko, "Analysis of bi-metal thermostats", J. Opt. Soc. Am. 11, 233, 1925).

With layer thicknesses h1, h2 (h = h1 + h2), m = h1/h2, moduli ratio n = M1/M2 and mismatch
Δε (layer 1 expands by Δε relative to layer 2), the free strip bends to

    κ_T = 6 Δε (1 + m)² / (h [3 (1 + m)² + (1 + m n)(m² + 1/(m n))]),

layer 1 on its convex side. A shell's mismatch is equal-biaxial, so each layer's modulus is
its biaxial modulus M = E/(1 - ν) (the plate correction): the curvature is then the same in
every direction, as the paper's κ a° is. Limits: equal layers (m = n = 1) give κ h = 3Δε/2;
a thin film on a thick substrate (h1 ≪ h2) gives Stoney's κ = 6 M1 h1 Δε / (M2 h2²).

Sign. ``shells`` writes b̄ = b° + κ a° with b = n·∂a, the normal pointing outward (a sphere has
b° = -a°/R). A layer on the normal's side (``outer``) that expands more makes that side convex,
which is how a sphere bends: κ = -κ_T. A positive κ (the paper's snap-through of caps) needs
the inner layer to expand more (or the outer to shrink).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from shells.errors import InputError

__all__ = ["Bilayer", "timoshenko_curvature"]


def timoshenko_curvature(h1: float, h2: float, m1: float, m2: float, mismatch: float) -> float:
    """Timoshenko's curvature κ_T of a free bilayer strip, layer 1 on its convex side.

    Args:
        h1, h2: the layers' thicknesses.
        m1, m2: their moduli (Young's for a strip, biaxial E/(1 - ν) for a plate).
        mismatch: Δε, the strain by which layer 1 expands relative to layer 2.

    Returns:
        κ_T in the inverse unit of the thicknesses.
    """
    h = h1 + h2
    m, n = h1 / h2, m1 / m2
    return 6.0 * mismatch * (1 + m) ** 2 / (
        h * (3 * (1 + m) ** 2 + (1 + m * n) * (m * m + 1 / (m * n))))


def _positive(name: str, v: Any) -> float:
    if not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
            and v > 0):
        raise InputError(f"the bilayer's {name} must be a positive number, got {v!r}")
    return float(v)


@dataclass(frozen=True)
class Bilayer:
    """Two bonded layers with a mismatch strain, and the shell they make.

    Attributes:
        outer: (thickness, Young's modulus, Poisson ratio) of the layer on the normal's side
            (the outer layer of a cap or sphere), in any consistent units.
        inner: the same for the other layer.
        mismatch: Δε, the equal-biaxial strain by which the outer layer expands relative to
            the inner one (differential swelling, or α Δ T).
    """

    outer: tuple[float, float, float]
    inner: tuple[float, float, float]
    mismatch: float

    def __post_init__(self) -> None:
        for name, layer in (("outer layer", self.outer), ("inner layer", self.inner)):
            if len(layer) != 3:
                raise InputError(f"the {name} is (thickness, E, nu), got {layer!r}")
            _positive(f"{name}'s thickness", layer[0])
            _positive(f"{name}'s modulus", layer[1])
            nu = layer[2]
            if not (isinstance(nu, (int, float)) and -1.0 < nu <= 0.5):
                raise InputError(f"the {name}'s nu must lie in (-1, 0.5], got {nu!r}")
        if not (isinstance(self.mismatch, (int, float)) and math.isfinite(self.mismatch)
                and abs(self.mismatch) < 1):
            raise InputError(f"the mismatch strain must be a number below 1 in size, got "
                             f"{self.mismatch!r}")

    @property
    def thickness(self) -> float:
        """h = h_outer + h_inner."""
        return self.outer[0] + self.inner[0]

    @property
    def kappa(self) -> float:
        """The natural curvature κ (``shells``' sign: b̄ = b° + κ a°, outward normal), in the
        inverse unit of the thicknesses: -κ_T with biaxial moduli."""
        (h1, e1, nu1), (h2, e2, nu2) = self.outer, self.inner
        return -timoshenko_curvature(h1, h2, e1 / (1 - nu1), e2 / (1 - nu2), self.mismatch)

    @property
    def neutral_offset(self) -> float:
        """The bending neutral plane's height above the interface (towards the outer layer),
        with biaxial moduli."""
        (h1, e1, nu1), (h2, e2, nu2) = self.outer, self.inner
        m1, m2 = e1 / (1 - nu1), e2 / (1 - nu2)
        return (m1 * h1 * h1 / 2 - m2 * h2 * h2 / 2) / (m1 * h1 + m2 * h2)

    @property
    def nu(self) -> float:
        """The composite's Poisson ratio: the layers' thickness-weighted mean."""
        return (self.outer[0] * self.outer[2] + self.inner[0] * self.inner[2]) / self.thickness

    @property
    def modulus(self) -> float:
        """The Young's modulus of the homogeneous shell of thickness h with the bilayer's
        bending stiffness: E = 12 (1 - ν) D / h³, D the biaxial bending stiffness about the
        neutral plane (the shell's bending energy is the bilayer's)."""
        (h1, e1, nu1), (h2, e2, nu2) = self.outer, self.inner
        z0 = self.neutral_offset
        d = (e1 / (1 - nu1) * ((h1 - z0) ** 3 + z0 ** 3) / 3
             + e2 / (1 - nu2) * ((h2 + z0) ** 3 - z0 ** 3) / 3)
        return 12 * (1 - self.nu) * d / self.thickness ** 3

    @property
    def stretching_modulus(self) -> float:
        """The Young's modulus of the homogeneous shell with the bilayer's stretching
        stiffness: (E1 h1 + E2 h2)/h (it differs from ``modulus`` unless the layers match)."""
        return (self.outer[0] * self.outer[1] + self.inner[0] * self.inner[1]) / self.thickness

    def describe(self) -> dict[str, Any]:
        """The layers, the mismatch and the composite, as JSON."""
        return {"outer": list(self.outer), "inner": list(self.inner), "mismatch": self.mismatch,
                "thickness": self.thickness, "kappa": self.kappa,
                "kappa_h": self.kappa * self.thickness, "E": self.modulus, "nu": self.nu}
