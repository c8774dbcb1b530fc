"""Physical units where the user gives them (a shared leaf).

Every computation of ``shells`` is dimensionless: lengths in units of the shape's radius R,
curvatures as κR or κh, energies in units of E R² h (the energy's own scale). A user may give
lengths, moduli and curvatures with units (``"25 mm"``, ``"3 MPa"``, ``"40 1/m"``, or a
``pint`` quantity); they are converted here, once, to SI numbers, and results are converted
back. A plain number is dimensionless.

pint is imported on first use (``import shells`` stays light).
"""

from __future__ import annotations

import math
from typing import Any

from shells.errors import InputError

__all__ = ["curvature", "is_quantity", "length", "modulus", "registry", "to_si"]

_REGISTRY: Any = None


def registry() -> Any:
    """The package's pint unit registry (one for every quantity it makes)."""
    global _REGISTRY
    if _REGISTRY is None:
        import pint

        _REGISTRY = pint.UnitRegistry()
    return _REGISTRY


def is_quantity(value: Any) -> bool:
    """Whether ``value`` carries units: a string such as ``"25 mm"`` or a pint quantity."""
    return isinstance(value, str) or hasattr(value, "to_base_units")


def to_si(value: Any, dimension: str, what: str) -> float:
    """``value`` (a string with units or a pint quantity) in SI units of ``dimension``.

    Args:
        value: e.g. ``"25 mm"``, ``"25mm"``, ``"3 MPa"``, ``"40/m"``, or a pint quantity.
        dimension: pint's dimensionality, e.g. ``"[length]"``.
        what: how an error names the value (e.g. ``"the radius"``).

    Returns:
        The magnitude in SI units (m, Pa, 1/m), a finite float.

    Raises:
        InputError: ``value`` cannot be read, is not of ``dimension`` or is not finite.
    """
    import pint

    ureg = registry()
    try:
        q = ureg.Quantity(value.replace("/", " / ") if isinstance(value, str) else value)
        q = ureg.Quantity(q.magnitude, q.units)  # a quantity of another registry, re-made
        right = q.check(dimension)
        si = float(q.to_base_units().magnitude)
    except (pint.errors.PintError, ValueError, TypeError, AttributeError, AssertionError):
        raise InputError(f"cannot read {what} {value!r} as a quantity with units "
                         "(e.g. '25 mm')") from None
    if not right:
        kind = {"[length]": "length", "[pressure]": "pressure (a modulus)",
                "1/[length]": "curvature (1/length)"}.get(dimension, dimension)
        raise InputError(f"{what} must be a {kind}, got {value!r} ({q.dimensionality})")
    if not math.isfinite(si):
        raise InputError(f"{what} must be finite, got {value!r}")
    return si


def length(value: Any, what: str = "the length") -> float | None:
    """A length in metres, or None for a plain (dimensionless) number."""
    return to_si(value, "[length]", what) if is_quantity(value) else None


def modulus(value: Any, what: str = "the modulus") -> float | None:
    """A modulus (a pressure) in pascals, or None for a plain number."""
    return to_si(value, "[pressure]", what) if is_quantity(value) else None


def curvature(value: Any, what: str = "the curvature") -> float | None:
    """A curvature in 1/m, or None for a plain number."""
    return to_si(value, "1/[length]", what) if is_quantity(value) else None
