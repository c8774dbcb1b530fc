"""The rigid-motion gauge of a surface known only by its mesh (``shells.surface.gauge``), on
node sets alone (no model, milliseconds): a cap's nodes get the caps' azimuthal gauge, which an
axisymmetric displacement meets with a translation only; a flat set of nodes, on which that
gauge cannot fix the tilts, gets a 3-2-1 gauge; both fix every rigid motion.
The surface model on such meshes: tests/test_surface_fit.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from shells.surface.gauge import (
    RING_CONDITIONING_MIN,
    mesh_gauge,
    rotation_conditioning,
    three_two_one_gauge,
)


def _cap_nodes(theta_max: float, rings: int = 12, seed: int = 0) -> np.ndarray:
    """Nodes of the unit sphere's cap: the pole and rings of points at random azimuths
    (a node on no particular azimuth, as on a user's mesh)."""
    rng = np.random.default_rng(seed)
    pts = [np.array([0.0, 0.0, 1.0])]
    for k in range(1, rings + 1):
        t = theta_max * k / rings
        n = 6 * k
        phi = 2 * math.pi * (np.arange(n) + rng.uniform(-0.3, 0.3, n)) / n
        pts += list(np.column_stack([np.sin(t) * np.cos(phi), np.sin(t) * np.sin(phi),
                                     np.full(n, np.cos(t))]))
    return np.array(pts)


def _axisymmetric_field(x: np.ndarray) -> np.ndarray:
    """A displacement symmetric about the z axis: radial and vertical parts of the colatitude,
    minus its value at the pole (the translation the gauge asks for)."""
    rho = np.hypot(x[:, 0], x[:, 1])
    t = np.arctan2(rho, x[:, 2])
    ur, uz = 0.3 * t**2, 0.2 - 0.5 * t**2
    er = np.where(rho[:, None] > 0, x * [1, 1, 0] / np.maximum(rho, 1e-300)[:, None], 0.0)
    u = ur[:, None] * er + uz[:, None] * [0, 0, 1]
    return u - u[np.argmax(x[:, 2])]


def _residuals(gauge, x: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The constraints' values u_comp(point) for the field u at the nodes x."""
    idx = [int(np.argmin(np.linalg.norm(x - p, axis=1))) for p in gauge.points]
    return np.array([u[idx[i], comp] for i, comp in gauge.constraints])


@pytest.mark.parametrize("theta_deg", [5.0, 30.0, 90.0])
def test_a_cap_gets_the_azimuthal_gauge_that_an_axisymmetric_state_meets(theta_deg):
    """On caps of 5° to 90°: the azimuthal gauge (A the pole; B, C, D within 0.2 rad of
    azimuths 0, π/2, π at about half the rim's radius), fixing every rigid motion. An
    axisymmetric displacement meets its constraints up to the nodes' angular offsets (the
    radial displacement times sin δ), where it does not meet the 3-2-1 gauge's (a rotation
    would be needed): below 0.02 of the 3-2-1's largest (measured 0.002-0.005)."""
    x = _cap_nodes(math.radians(theta_deg))
    g = mesh_gauge(x)
    assert g.kind == "azimuthal" and len(g.constraints) == 6
    assert np.allclose(g.points[0], [0, 0, 1])
    rim = math.sin(math.radians(theta_deg))
    for p, az in zip(g.points[1:], (0.0, math.pi / 2, math.pi), strict=True):
        assert abs(math.remainder(math.atan2(p[1], p[0]) - az, 2 * math.pi)) < 0.2
        assert 0.3 * rim < math.hypot(p[0], p[1]) < 0.7 * rim
    assert rotation_conditioning(g.points, g.constraints) > 0
    u = _axisymmetric_field(x)
    other = three_two_one_gauge(x)  # the fallback, which the same state meets only turned
    assert rotation_conditioning(other.points, other.constraints) > 0
    met = np.abs(_residuals(g, x, u)).max()
    missed = np.abs(_residuals(other, x, u)).max()
    assert met < 0.02 * missed, (met, missed)


def test_a_flat_mesh_gets_a_3_2_1_gauge_that_fixes_every_rigid_motion():
    """Nodes of a flat disk (z = 0): the ring lies at A's height, so the azimuthal gauge would
    leave the tilts free (conditioning 0); the 3-2-1 gauge fixes every rigid motion."""
    x = _cap_nodes(math.radians(30))
    x[:, 2] = 0.0
    g = mesh_gauge(x)
    assert g.kind == "3-2-1" and len(g.constraints) == 6 and len(g.points) == 3
    assert rotation_conditioning(g.points, g.constraints) > 0.05


def test_conditioning_is_zero_when_a_rigid_motion_meets_every_constraint():
    """u = 0 at A and the z components at two more points leave the turn about z free; the
    azimuthal constraints of points at A's height leave the tilts free: both 0 (to round-off),
    below ``RING_CONDITIONING_MIN`` of any gauge's."""
    a, b, c = np.zeros(3), np.array([1.0, 0, 0]), np.array([0, 1.0, 0])
    free_turn = [(0, 0), (0, 1), (0, 2), (1, 2), (2, 2), (1, 2)]
    assert rotation_conditioning([a, b, c], free_turn) < 1e-12
    d = np.array([-1.0, 0, 0])
    flat_ring = [(0, 0), (0, 1), (0, 2), (1, 1), (2, 0), (3, 1)]
    assert rotation_conditioning([a, b, c, d], flat_ring) < 1e-12 * RING_CONDITIONING_MIN
