"""Cross-validation, κ < 0: the surface and the axisymmetric model find the same first loss of
symmetry (m = 2, κ within 2 %) on a cap of 45°, h/R = 0.04 (see tests/crossval.py). The 30° cap
on the same mesh is checked in tests/test_switching.py, which locates the same point."""

from crossval import check_cap


def test_surface_and_axisym_agree_on_a_cap_going_down():
    check_cap(45, "down")
