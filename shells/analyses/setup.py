"""What the analyses share in setting up a run (analyses layer): the κ range a run covers when
the user gives none.

The shell parameters themselves are checked by ``shells.parameters``, the one check every
entry point uses.
"""

from __future__ import annotations

import math
from typing import Any

from shells.errors import InputError
from shells.geometry.shapes import Disk, Sphere, SphericalCap, kappa_length
from shells.theory import (
    buckling_kappa_R,
    mirrored_buckling_kappa_R,
    plate_a,
    snap_kappa_R,
    sphere_kappa_b_h,
)

__all__ = ["KAPPA_H_LIMIT", "default_kappa_range", "kappa_end", "open_shell_kappa_R_max"]


def default_kappa_range(shape: object, h_over_r: float, nu: float, direction: str) -> float:
    """A κ range (absolute, signed) that contains the first critical point with a margin.

    Built from the paper's laws (sphere and any closed shell: κ_b h; caps: the snap line, the
    mirrored Eq. (4) and Eq. (4); disk: the plate limit), widened by 60 %; other shapes 8/R.

    Args:
        shape: the shell.
        h_over_r: thickness over the shape's length scale.
        nu: Poisson's ratio.
        direction: "up" (κ > 0) or "down" (κ < 0).

    Returns:
        The signed end of the range, an absolute κ.
    """
    sign = 1.0 if direction == "up" else -1.0
    L = shape.characteristic_size()  # type: ignore[attr-defined]
    h = h_over_r * L
    if isinstance(shape, Sphere) or getattr(shape, "closed", False):
        # any closed shell (a spheroid, a closed meridian table): the sphere's buckling law
        return sign * 1.6 * sphere_kappa_b_h(nu) / h
    if isinstance(shape, Disk):
        return sign * 1.6 * plate_a() * h / L**2
    if isinstance(shape, SphericalCap):
        tb = shape.theta / math.sqrt(h_over_r)
        if direction == "up":
            kr = max(snap_kappa_R(tb), mirrored_buckling_kappa_R(tb, h_over_r))
            return (1.6 * max(kr, 1.0) + 0.5) / shape.R
        return (1.6 * min(buckling_kappa_R(tb, h_over_r), -1.0) - 0.5) / shape.R
    return sign * 8.0 / kappa_length(shape)  # type: ignore[arg-type]


def open_shell_kappa_R_max(shape: Any, h_over_r: float) -> float:  # noqa: N802 - κR
    """|κ| R up to which the 1D runs and ``snap`` follow an open shell: 2 θ̄ + 6.

    Every cap's first critical point lies below it in both directions (the snap line and
    Eq. (4) of the paper are below 2 θ̄ + 2 for θ̄ ≥ 1), with room for the branch beyond.

    Args:
        shape: the shell's shape; its opening angle θ (radians) where it has one, else θ = 1.
        h_over_r: thickness over the shape's length scale.

    Returns:
        2 θ̄ + 6 with θ̄ = θ / √(h/R).
    """
    return 2.0 * getattr(shape, "theta", 1.0) / math.sqrt(h_over_r) + 6.0


def kappa_end(shape: Any, h_over_r: float, kappa_h: float | None, kappa_r: float | None,
              direction: str | None = None) -> float | None:
    """The end of a κ range given as κh or κR, as an absolute κ in the shape's units.

    Args:
        shape: the shell's shape.
        h_over_r: thickness over the shape's length scale.
        kappa_h, kappa_r: the end as κh or as κR (at most one is used; κh first).
        direction: "up" or "down": the sign of the result; None: the given sign.

    Returns:
        κ, or None when neither is given.

    Raises:
        InputError: |κ| h beyond ``KAPPA_H_LIMIT``.
    """
    L = shape.characteristic_size()
    if kappa_h is not None:
        k = kappa_h / (h_over_r * L)
    elif kappa_r is not None:
        k = kappa_r / kappa_length(shape)
    else:
        return None
    if not abs(k) * h_over_r * L <= KAPPA_H_LIMIT:
        raise InputError(f"the kappa range's end, |kappa| h = {abs(k) * h_over_r * L:.3g}, "
                         f"exceeds {KAPPA_H_LIMIT:g}: it would strain the faces by "
                         "|kappa| h / 2, far beyond a thin shell's range")
    return k if direction is None else abs(k) if direction == "up" else -abs(k)


#: largest |kappa| h of a kappa range (--kappa-h-max, or --kappa-r-max times h/R): the natural
#: curvature strains the faces by kappa h / 2, and the paper's instabilities all lie below
#: kappa h = 2 (closed spheres 1.5, caps' snap-through less)
KAPPA_H_LIMIT = 100.0
