"""Analytic shapes: closed forms against quadrature and finite differences; input validation."""

import math

import numpy as np
import pytest

from shells.errors import InputError
from shells.geometry.catalogue import make_shape
from shells.geometry.shapes import Disk, EllipsoidalCap, Shape, Sphere, SphericalCap


@pytest.mark.parametrize("theta_deg", [10, 45, 90, 150, 180])
def test_cap_area_closed_form_matches_quadrature(theta_deg):
    cap = SphericalCap(2.0, math.radians(theta_deg))
    assert cap.area() == pytest.approx(Shape.area(cap), rel=1e-12)
    assert cap.rim_length() == pytest.approx(2 * math.pi * 2.0 * math.sin(cap.theta), abs=1e-12)


def test_sphere_is_closed_full_cap():
    s = Sphere(1.5)
    assert s.closed and s.rim_length() == 0.0
    assert s.area() == pytest.approx(4 * math.pi * 1.5**2, rel=1e-14)
    assert SphericalCap(1.0, math.pi).closed


def test_ellipsoid_half_area_and_curvatures():
    a, c = 1.0, 1.5
    e = EllipsoidalCap(a, c, math.pi / 2)
    # half of the prolate spheroid area 2 pi a^2 (1 + c/(a ecc) asin(ecc))
    ecc = math.sqrt(1 - a**2 / c**2)
    area = math.pi * a**2 * (1 + c / (a * ecc) * math.asin(ecc))
    assert e.area() == pytest.approx(area, rel=1e-10)
    # principal curvatures against finite differences of the meridian (r(t), z(t))
    t = np.array([0.3, 0.9, 1.4])
    x = np.stack([a * np.sin(t), 0 * t, c * np.cos(t)])
    k1, k2 = e.principal_curvatures(x)
    dr, dz = a * np.cos(t), -c * np.sin(t)
    ddr, ddz = -a * np.sin(t), -c * np.cos(t)
    k_mer = (dr * ddz - dz * ddr) / (dr**2 + dz**2) ** 1.5  # signed: negative for outward n
    assert np.allclose(k1, k_mer, rtol=1e-12)
    # azimuthal: -n_r / r with n the outward normal
    n = e.normal(x)
    assert np.allclose(k2, -n[0] / (a * np.sin(t)), rtol=1e-12)
    assert e.R == pytest.approx(a**2 / c)


def test_sphere_normal_outward_and_b_negative():
    s = Sphere(2.0)
    x = np.array([[0.0, 2.0], [0.0, 0.0], [2.0, 0.0]])
    assert np.allclose(s.normal(x), x / 2.0)
    k1, k2 = s.principal_curvatures(x)
    assert np.allclose(k1, -0.5) and np.allclose(k2, -0.5)


def test_disk():
    d = Disk(0.5)
    assert d.area() == pytest.approx(math.pi * 0.25)
    assert d.rim_length() == pytest.approx(math.pi)


@pytest.mark.parametrize("kwargs, match", [
    (dict(kind="cap", radius=1.0, theta=0.0), "theta must lie in"),
    (dict(kind="cap", radius=1.0, theta=4.0), "theta must lie in"),
    (dict(kind="cap", radius=-1.0, theta=1.0), "radius must be a positive"),
    (dict(kind="cap", radius=1.0), "needs an opening angle"),
    (dict(kind="cube"), "unknown shape"),
])
def test_bad_shapes_raise_input_error(kwargs, match):
    kind = kwargs.pop("kind")
    with pytest.raises(InputError, match=match):
        make_shape(kind, **kwargs)
