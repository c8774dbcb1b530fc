"""``shells.surface.frame``: a state read in the shell's best-fit rigid frame.

A rigid rotation of a state changes no energy (the director turned with the displacement); the
frame recovers the rotation, so a state and any rigidly turned copy of it read the same there;
an axisymmetric state is its own frame; a pattern with a two-fold symmetry about the axis has no
odd m in its spectrum in that frame, while the same state tilted (as the rigid-motion gauge
holds it at most orientations) has.
"""

import functools
import math

import numpy as np
import pytest
from mpi4py import MPI


@functools.cache
def _mesh():
    from shells.geometry.shapes import SphericalCap
    from shells.surface.mesh import MeshSpec, generate

    return generate(MeshSpec(SphericalCap(1.0, 0.8), h=0.04, size=0.35, layer_elements=2.0),
                    MPI.COMM_WORLD)


def _model(everted: bool = False):
    from shells.surface.model import ModelParameters, ShellModel

    model = ShellModel(_mesh(), ModelParameters(h=0.04, nu=0.5, degree=2, quadrature_degree=4))
    if everted:
        model.set_everted_guess()
    model.set_kappa(2.0)
    return model


def _set(model, a2: float, a0: float = 0.05) -> np.ndarray:
    """Add to the model's state the normal displacement a0 (1 - z) + a2 (x² - y²) + a2 x y
    (zero at the pole; a2 ≠ 0: an m = 2 pattern, turned off the axes, symmetric under the half
    turn about z) and a small director increment; returns the owned values."""
    import ufl
    from dolfinx import fem

    from shells.problem.interface import get_state

    x = ufl.SpatialCoordinate(model.shell.mesh)
    n0 = model.n0
    f = a0 * (1 - x[2]) + a2 * (x[0] ** 2 - x[1] ** 2 + x[0] * x[1])
    g = fem.Function(model.W)
    g.interpolate(fem.Expression(ufl.as_vector([f * n0[0], f * n0[1], f * n0[2],
                                                0.1 * f * x[1], -0.1 * f * x[0], 0.0 * f]),
                                 model.W.element.interpolation_points()))
    model.w.x.array[:] += g.x.array
    model.w.x.scatter_forward()
    return get_state(model)


def _tilt(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _odd(model, w: np.ndarray) -> float:
    """The largest odd-m amplitude of u·n° over the m = 0 one."""
    v = model.create_vector()
    v.array_w[:] = w
    a = np.sqrt(model.azimuthal_spectrum(v))
    v.destroy()
    return float(max(a[1::2]) / a[0])


@pytest.mark.parametrize("everted", [False, True])
def test_a_rigidly_turned_state_has_the_same_energy_and_frame(everted):
    """Turned by 25° about a horizontal axis through the pole (the director with it, in the
    original and in the everted director chart): the energy agrees to the nodal interpolation
    of the turned reference normal (1e-5 on this P2 mesh; with the director left unturned it
    changes by far more), and the frame's aligned states to 1e-10 h; a pattern symmetric
    about z is its own frame, so the frame turns the tilted copy by exactly the tilt back."""
    from shells.problem.interface import set_state

    model = _model(everted)
    frame = model.rigid_frame()
    w = _set(model, 0.1)
    e0 = model.total_energy()
    Q0 = frame.rotation()
    aligned = frame.aligned_state()
    R = _tilt(math.radians(25.0))
    turned = frame.aligned_state(R)
    set_state(model, turned)
    assert model.total_energy() == pytest.approx(e0, rel=1e-5)
    stiff = turned.reshape(-1, 6).copy()
    stiff[:, 3:] = w.reshape(-1, 6)[:, 3:]
    set_state(model, stiff.ravel())
    assert abs(model.total_energy() - e0) > 1e-2 * abs(e0)
    set_state(model, turned)
    assert np.linalg.norm(frame.rotation() - R.T @ Q0) < 1e-8
    diff = np.abs(frame.aligned_state() - aligned).max(initial=0.0)
    assert MPI.COMM_WORLD.allreduce(diff, op=MPI.MAX) < 1e-10 * 0.04
    assert np.linalg.norm(Q0 - np.eye(3)) < 1e-8, Q0


def test_an_axisymmetric_state_is_its_own_frame():
    """To the mesh's departure from axial symmetry (its unstructured bulk)."""
    model = _model()
    _set(model, 0.0)
    Q = model.rigid_frame().rotation()
    assert np.linalg.norm(Q - np.eye(3)) < 1e-8


def test_a_state_turned_inside_out_is_not_turned_over():
    """An axisymmetric state whose heights fall steeply where the reference's rise (u such that
    y = (x/3, y/3, 10 (1 - z))): against the reference alone the least-squares rotation is
    the half turn about a horizontal axis; against its mirror image, the identity, which the
    frame takes."""
    import ufl
    from dolfinx import fem

    from shells.surface.frame import best_fit_rotation

    model = _model()
    x = ufl.SpatialCoordinate(model.shell.mesh)
    y = ufl.as_vector([x[0] / 3, x[1] / 3, 10 * (1 - x[2])])
    zero = 0.0 * x[0]
    model.w.interpolate(fem.Expression(ufl.as_vector([*(y[i] - x[i] for i in range(3)),
                                                      zero, zero, zero]),
                                       model.W.element.interpolation_points()))
    model.w.x.scatter_forward()
    frame = model.rigid_frame()
    assert np.linalg.norm(frame.rotation() - np.eye(3)) < 1e-12
    H = frame.correlation()
    assert np.trace(best_fit_rotation(H)) < -0.9  # a half turn: trace -1


def test_the_frame_removes_the_odd_m_of_a_tilted_two_fold_pattern():
    """The m = 2 pattern read as the gauge may hold it (tilted by 10°) shows odd m (a tilt is
    an m = 1 displacement, and it mixes m = 2 into m = 1 and 3); in the frame they are gone,
    to round-off, and classifying it leaves the model's state as it was."""
    from shells.problem.interface import get_state, set_state

    model = _model()
    frame = model.rigid_frame()
    w = _set(model, 0.1)
    odd_straight = _odd(model, w)
    set_state(model, frame.aligned_state(_tilt(math.radians(10.0))))
    tilted = get_state(model)
    assert _odd(model, tilted) > 1e-2 > 1e6 * odd_straight
    with frame.aligned() as Q:
        assert _odd(model, get_state(model)) < 1e-8
        assert math.degrees(math.acos((np.trace(Q) - 1) / 2)) == pytest.approx(10.0, rel=1e-9)
    assert np.array_equal(get_state(model), tilted)
