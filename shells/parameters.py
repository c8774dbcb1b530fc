"""The one check of a shell's parameters (a shared leaf), used by every entry point: the
command line, the analyses and the models' own parameter records.

One set of bounds, so that the Python API accepts exactly what the command line accepts:

* ν, the Poisson ratio: (-1, 1/2], the range of an isotropic elastic solid;
* h/R, thickness over the shape's length scale: [``H_OVER_R_MIN``, ``H_OVER_R_MAX``]. The model
  is Koiter's thin-shell energy (bending h³/12, no transverse shear or thickness change), an
  expansion in h/R: at h/R = 0.5 the faces lie at 0.75 R and 1.25 R and the expansion has no
  meaning any more. Below 1e-5 the bending stiffness, (h/R)² of the stretching one, is lost in
  round-off.
* the model: ``"axisym"`` (the 1D model) or ``"surface"`` (the 2D model).

Each check returns the value as a float (or the name) and raises ``InputError`` (the command
line's one-line error, exit status 2) naming the parameter and its range.
"""

from __future__ import annotations

import math
from typing import Any

from shells.errors import InputError

__all__ = ["H_OVER_R_MAX", "H_OVER_R_MIN", "MODELS", "check_h_over_r", "check_model", "check_nu"]

#: largest h/R accepted (the thin-shell expansion's limit)
H_OVER_R_MAX = 0.5
#: smallest h/R accepted (the bending stiffness resolved in double precision)
H_OVER_R_MIN = 1e-5
#: the two models
MODELS = ("axisym", "surface")


def _is_number(value: Any) -> bool:
    return (isinstance(value, (int, float)) and not isinstance(value, bool)
            and math.isfinite(value))


def check_nu(nu: Any, name: str = "nu") -> float:
    """The Poisson ratio ``nu``, checked.

    Args:
        nu: the value.
        name: how the error names it (e.g. ``"--nu"``).

    Returns:
        ``nu`` as a float.

    Raises:
        InputError: unless -1 < nu <= 1/2.
    """
    if not (_is_number(nu) and -1.0 < nu <= 0.5):
        raise InputError(f"{name} must lie in (-1, 0.5], got {nu!r}")
    return float(nu)


def check_h_over_r(h_over_r: Any, name: str = "h/R") -> float:
    """The thickness ratio ``h_over_r``, checked.

    Args:
        h_over_r: the value (thickness over the shape's length scale).
        name: how the error names it (e.g. ``"--h-over-r"``).

    Returns:
        ``h_over_r`` as a float.

    Raises:
        InputError: unless ``H_OVER_R_MIN`` <= h/R <= ``H_OVER_R_MAX``.
    """
    if not (_is_number(h_over_r) and H_OVER_R_MIN <= h_over_r <= H_OVER_R_MAX):
        raise InputError(f"{name} must lie in [{H_OVER_R_MIN:g}, {H_OVER_R_MAX:g}] (a thin "
                         f"shell, not thinner than double precision resolves), got {h_over_r!r}")
    return float(h_over_r)


def check_model(model: Any) -> str:
    """The model's name, checked.

    Args:
        model: "axisym" or "surface".

    Returns:
        ``model``.

    Raises:
        InputError: unless it is one of ``MODELS``.
    """
    if model not in MODELS:
        raise InputError(f"model must be 'axisym' or 'surface', got {model!r}")
    return str(model)
