"""The surface model's default discretisation follows h/R (issue 42): a closed sphere's mesh
resolves the wavelength of its critical degree, or the default is refused in one line; no 2D
solve here (the measured errors: docs/model.md)."""

from __future__ import annotations

import math

import pytest

from shells.errors import InputError
from shells.geometry import Sphere, SphericalCap
from shells.model import (
    MAX_DEFAULT_DOFS,
    SPHERE_ELEMENTS_PER_WAVELENGTH,
    SPHERE_P3_DOFS,
    default_discretisation,
)
from shells.theory import sphere_mode_n


@pytest.mark.parametrize("h", [0.05, 0.02, 0.01])
def test_sphere_default_resolves_the_critical_wavelength(h):
    degree, size = default_discretisation(Sphere(1.0), h)
    n = sphere_mode_n(h, 0.5)
    assert degree == 3
    assert 2 * math.pi / n / size >= SPHERE_ELEMENTS_PER_WAVELENGTH - 0.06  # 0.05: 0.21 kept
    assert SPHERE_P3_DOFS / size**2 <= MAX_DEFAULT_DOFS
    if h == 0.05:
        assert size == 0.21  # the measured default (κ_b h 1.4908 against 1.484)
    if h == 0.01:
        # the old default 0.21 had 1.5 elements per wavelength: κ_b h 1.5940, 5.8 % high
        assert size < 0.21 / 2.2


def test_thin_sphere_default_is_refused_naming_the_ways_on():
    with pytest.raises(InputError) as e:
        default_discretisation(Sphere(1.0), 0.005)
    msg = str(e.value)
    assert "\n" not in msg and "--model axisym" in msg and "--size" in msg
    # explicit options are the user's choice
    assert default_discretisation(Sphere(1.0), 0.005, 3, 0.065) == (3, 0.065)


@pytest.mark.parametrize("h", [0.04, 0.01])
@pytest.mark.parametrize("thetabar", [2.0, 5.0, 8.0])
def test_cap_defaults(h, thetabar):
    """Caps: P2 at 0.1 up to θ̄ = 3, P3 at 0.2 deeper (P2 locks), the rim layer graded to
    sqrt(R h) / layer_elements by the mesher."""
    degree, size = default_discretisation(SphericalCap(1.0, thetabar * math.sqrt(h)), h)
    assert (degree, size) == ((2, 0.1) if thetabar <= 3.0 else (3, 0.2))
