"""The surface model's default discretisation follows h/R (issue 42): a closed sphere's mesh
resolves the wavelength of its critical degree, a spherical cap's is alike in units of the rim
layer's width sqrt(R h) at every h/R, or the default is refused in one line; no 2D solve here
(the measured errors: docs/design-notes.md, "Surface model defaults")."""

from __future__ import annotations

import math

import pytest

from shells.errors import InputError
from shells.geometry import Sphere, SphericalCap
from shells.surface.mesh import MeshSpec, estimate_cap_cells
from shells.surface.model import (
    CAP_SIZE_H_OVER_R,
    MAX_DEFAULT_DOFS,
    SPHERE_ELEMENTS_PER_WAVELENGTH,
    SPHERE_P3_DOFS,
    cap_default_size,
    default_discretisation,
    default_dofs,
)
from shells.theory import sphere_mode_n


@pytest.mark.parametrize("h", [0.05, 0.02])
def test_sphere_default_resolves_the_critical_wavelength(h):
    """The old default, P3 at 0.21 for every h/R, had 3.55 elements per wavelength 2πR/n at
    h/R = 0.05 (κ_b 0.57 % above the 1D model's), 1.54 at 0.01 (5.8 % high)."""
    degree, size = default_discretisation(Sphere(1.0), h)
    n = sphere_mode_n(h, 0.5)
    assert degree == 3
    assert 2 * math.pi / n / size == pytest.approx(SPHERE_ELEMENTS_PER_WAVELENGTH)
    assert SPHERE_ELEMENTS_PER_WAVELENGTH >= 4.0  # 3.5 measured +0.67 % at h/R = 0.02
    assert SPHERE_P3_DOFS / size**2 <= MAX_DEFAULT_DOFS
    # ν enters through the critical degree
    assert default_discretisation(Sphere(1.0), h, nu=0.3)[1] < size


@pytest.mark.parametrize("h", [0.01, 0.005])
def test_thin_sphere_default_is_refused_naming_the_ways_on(h):
    with pytest.raises(InputError) as e:
        default_discretisation(Sphere(1.0), h)
    msg = str(e.value)
    assert "\n" not in msg and "--model axisym" in msg and "--size" in msg
    # explicit options are the user's choice
    assert default_discretisation(Sphere(1.0), h, 3, 0.065) == (3, 0.065)


def _cap(thetabar: float, h: float) -> SphericalCap:
    return SphericalCap(1.0, thetabar * math.sqrt(h))


@pytest.mark.parametrize("h", [0.04, 0.01])
@pytest.mark.parametrize("thetabar", [2.0, 5.0, 8.0])
def test_cap_defaults(h, thetabar):
    """The caps of the issue's must-hold list: P2 up to θ̄ = 3, P3 deeper (P2 locks), at 0.1
    and 0.2 at h/R = 0.04 and √(h/R / 0.04) times those below; none refused (each measured
    against the 1D model, benchmarks/surface_defaults.py)."""
    degree, size = default_discretisation(_cap(thetabar, h), h)
    scale = math.sqrt(min(1.0, h / CAP_SIZE_H_OVER_R))
    assert (degree, size) == ((2, 0.1 * scale) if thetabar <= 3.0 else (3, 0.2 * scale))
    assert default_dofs(_cap(thetabar, h), h, degree, size) <= MAX_DEFAULT_DOFS


@pytest.mark.parametrize("thetabar", [2.0, 5.0])
def test_cap_mesh_alike_in_rim_layer_widths(thetabar):
    """The bulk size in units of sqrt(R h) is that of h/R = 0.04 at every thinner h/R (the rim
    band's size sqrt(R h)/4 scales so already): the old fixed 0.2 was two layer widths at
    h/R = 0.01, twenty at 1e-4. Thicker shells keep the fixed sizes."""
    ref = default_discretisation(_cap(thetabar, 0.04), 0.04)
    for h in (0.02, 0.01, 1e-3, 1e-4):
        degree, size = default_discretisation(_cap(thetabar, h), h)
        assert degree == ref[0]
        assert size / math.sqrt(h) == pytest.approx(ref[1] / math.sqrt(0.04))
    assert default_discretisation(_cap(thetabar, 0.1), 0.1) == ref


# gmsh's triangles for caps (θ̄, h/R) on their default meshes (`shells mesh`), and the P3 DOFs
# of (8, 0.01): 147,030
GMSH_CELLS = {(2, 0.04): 520, (5, 0.04): 2624, (8, 0.04): 4512, (12, 0.04): 4728,
              (5, 0.01): 2848, (8, 0.01): 5384, (12, 0.01): 8352, (8, 0.0025): 5656,
              (12, 0.0025): 9408}


def test_cap_cell_estimate_follows_gmsh():
    """The cells integrated over the cap's size field lie within 5 % of gmsh's (the general
    ``estimate_cells``, an upper bound, was 1.4 times high on the θ̄ = 8 cap at h/R = 0.01)."""
    for (thetabar, h), cells in GMSH_CELLS.items():
        spec = MeshSpec(_cap(thetabar, h), h=h, size=cap_default_size(h, thetabar > 3))
        est = estimate_cap_cells(spec)
        assert est == pytest.approx(cells, rel=0.05), (thetabar, h)
    assert default_dofs(_cap(8.0, 0.01), 0.01, 3, 0.1) == pytest.approx(147030, rel=0.02)


@pytest.mark.parametrize("thetabar, h", [(12.0, 0.01), (8.0, 1e-3), (20.0, 1e-4)])
def test_deep_thin_cap_default_is_refused_naming_the_ways_on(thetabar, h):
    cap = _cap(thetabar, h)
    with pytest.raises(InputError) as e:
        default_discretisation(cap, h)
    msg = str(e.value)
    assert "\n" not in msg and "--model axisym" in msg and "--size" in msg
    # explicit options are the user's choice
    assert default_discretisation(cap, h, 3, 0.05) == (3, 0.05)


def test_stated_error_covers_the_default_meshes_only():
    """`shells critical` states ``discretisation_error`` for the default mesh of a closed sphere
    or a spherical cap under the uniform stimulus (the measured rules), else null; the note
    says which, and that ``accuracy`` is the locator's bracket."""
    from shells.analyses.critical import discretisation_error_of, discretisation_note_of
    from shells.surface.model import CAP_DEFAULT_ERROR, SPHERE_DEFAULT_ERROR

    cap = _cap(5.0, 0.01)
    assert discretisation_error_of(Sphere(1.0), True) == SPHERE_DEFAULT_ERROR
    assert discretisation_error_of(cap, True) == CAP_DEFAULT_ERROR
    for shape in (Sphere(1.0), cap):
        assert discretisation_error_of(shape, False) is None
        assert discretisation_error_of(shape, True, uniform=False) is None
        assert "locator's bracket" in discretisation_note_of(shape, False)
    assert "default cap mesh" in discretisation_note_of(cap, True)
    assert "not estimated" in discretisation_note_of(cap, True, uniform=False)
