"""The rigid frame of a deformed shell (the model layer): the state turned rigidly into the
orientation that best fits the reference surface.

The surface model fixes the free shell's rigid motion by a gauge: six point values held at zero
(``ShellModel._supports``' docstring: the pole's displacement, and one displacement component
at each of three points of a parallel). The gauge picks one representative of each class of
states equal up to a rigid motion, and any such choice leaves the energy and the strains alone;
but quantities read in the material frame (the azimuthal spectrum of u·n°, the rim's rotation
from its reference normal, the pole's normal displacement) also see the representative's
rotation. A pattern without axial symmetry (a snapped cap's m = 2 state) meets the three
rotation conditions only tilted, by an angle that depends on how the pattern is turned against
the gauge points: the same state turned about the axis then reads with odd m in its spectrum
and with another rim rotation and Ψ3 at the pole (``benchmarks/snap_landing_reading.py``).

``RigidFrame`` removes that rotation: the proper rotation Q that carries the deformed shell
closest to the reference in the area-weighted least-squares sense (the Kabsch solution:
minimise ∫ |Q (y - c_y) - (x - c_x)|² dA over rotations, y = x + u the deformed point, c the
centroids; the integral by the nodal quadrature of the state's space) is applied to the state
about the point the gauge holds fixed (the pole, where the surface has one; else the deformed
centroid), so that u there stays as the gauge has it. A shell turned inside out (an everted
cap: its heights fall where the reference's rise) fits the reference best turned over, which
would read it upside down; the fit is therefore made against the reference and against its
mirror image through a horizontal plane, and the closer of the two is taken
(``frame_rotation``). Both targets are axisymmetric: an axisymmetric state is its own best fit
(Q = I) and reads as before, and a state with a two-fold symmetry about a deformed axis through
the pole is turned so that this axis is the reference axis, whatever its orientation about it.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np

__all__ = ["RigidFrame", "best_fit_rotation", "frame_rotation", "rotation_angle_deg"]


def best_fit_rotation(H: np.ndarray) -> np.ndarray:
    """The proper rotation Q that maximises tr(Q H) (Kabsch).

    Args:
        H: the 3 x 3 correlation ∫ (y - c_y)(x - c_x)ᵀ dA of the points to turn (y) with their
            targets (x).

    Returns:
        Q (det Q = 1) minimising ∫ |Q (y - c_y) - (x - c_x)|² dA.
    """
    U, _, Vt = np.linalg.svd(H)
    d = 1.0 if np.linalg.det(Vt.T @ U.T) > 0 else -1.0
    return Vt.T @ np.diag([1.0, 1.0, d]) @ U.T


def frame_rotation(H: np.ndarray) -> np.ndarray:
    """The rotation into the best-fit frame: ``best_fit_rotation`` against the reference (H)
    or against its mirror image through a horizontal plane (H diag(1, 1, -1)), whichever fits
    closer (the larger tr(Q H)).

    Args:
        H: as ``best_fit_rotation``'s, against the reference.

    Returns:
        Q (det Q = 1).
    """
    D = np.diag([1.0, 1.0, -1.0])
    Q, Qm = best_fit_rotation(H), best_fit_rotation(H @ D)
    return Q if np.trace(Q @ H) >= np.trace(Qm @ H @ D) else Qm


def rotation_angle_deg(Q: np.ndarray) -> float:
    """The angle of the rotation Q, in degrees (acos((tr Q - 1) / 2), clipped to its domain
    against round-off)."""
    return math.degrees(math.acos(min(1.0, max(-1.0, (float(np.trace(Q)) - 1.0) / 2.0))))


class RigidFrame:
    """The rigid rotation of a surface model's state against its reference (collective).

    Args:
        model: the surface model (``shells.surface.model.ShellModel``) with the free director
            chart (``ModelParameters.director = "free"``, where any rigid rotation of the
            director is a state).

    Raises:
        ValueError: the model uses the tangent director chart.
    """

    def __init__(self, model: Any) -> None:
        import ufl
        from dolfinx import fem, la

        if model.params.director != "free":
            raise ValueError("a rigid rotation of the state needs the free director chart")
        self.model = model
        self._nodes = model.owned_dof_coordinates()
        n = len(self._nodes)
        # the nodal quadrature of the state's space: weight ∫ φ_i dA at node i (row sums of
        # the mass; one form, where integrals of u x would compile nine)
        ones = ufl.as_vector([1.0] * 6)
        lumped = fem.assemble_vector(fem.form(ufl.dot(ufl.TestFunction(model.W), ones)
                                              * model.dx))
        lumped.scatter_reverse(la.InsertMode.add)
        self._weight = lumped.array.reshape(-1, 6)[:n, 0].copy()
        self._area = self._sum(self._weight)
        self._cx = self._sum(self._weight[:, None] * self._nodes) / self._area
        # the reference normal at the state's nodes (u and θ share them), for the director
        normal = fem.Function(model.W)
        n0 = model.n0
        zero = fem.Constant(model.shell.mesh, 0.0)
        normal.interpolate(fem.Expression(ufl.as_vector([n0[0], n0[1], n0[2], zero, zero, zero]),
                                          model.W.element.interpolation_points()))
        self._n0 = normal.x.array.reshape(-1, 6)[:n, :3].copy()
        self._pivot = (np.asarray(model.support_points[0], dtype=float)
                       if getattr(model.shape, "has_pole", False) else None)

    def _sum(self, a: np.ndarray) -> Any:
        """The sum over the nodes of all ranks of a (an array over this rank's nodes)."""
        from mpi4py import MPI

        return self.model.shell.comm.allreduce(np.sum(a, axis=0), op=MPI.SUM)

    def _deformed(self) -> tuple[np.ndarray, np.ndarray]:
        """The current state's owned values (nodes x 6) and deformed nodes y = x + u."""
        from shells.problem.interface import get_state

        w = get_state(self.model).reshape(-1, 6).copy()
        return w, self._nodes + w[:, :3]

    def _correlation(self, y: np.ndarray) -> np.ndarray:
        # Σ w (y - c_y)(x - c_x)ᵀ = Σ w y (x - c_x)ᵀ, as Σ w (x - c_x) = 0
        return self._sum((self._weight[:, None] * y)[:, :, None]
                         * (self._nodes - self._cx)[:, None, :])

    def rotation(self) -> np.ndarray:
        """Q, the rotation that carries the current deformed shell closest to the reference
        or to its mirror image (``frame_rotation`` of ``correlation()``)."""
        return frame_rotation(self.correlation())

    def correlation(self) -> np.ndarray:
        """H = ∫ (y - c_y)(x - c_x)ᵀ dA of the current deformed points y = x + u with the
        reference points x (c: the centroids), by the nodal quadrature (collective)."""
        return self._correlation(self._deformed()[1])

    def aligned_state(self, Q: np.ndarray | None = None) -> np.ndarray:
        """This rank's owned values of the current state turned by Q (default ``rotation()``)
        about the gauge's fixed point (the pole, else the deformed centroid):
        u' = Q (x + u - p) + p - x and, with v = A n° + θ the director's vector (A the model's
        director base), θ' = Q v - A n°. Energy and strains are those of the state up to the
        nodal interpolation of Q A n° - A n° in θ' (the reference normal is not in the
        state's space)."""
        return self._turned(Q)[0]

    def _turned(self, Q: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """(``aligned_state(Q)``, Q), the state read once."""
        w, y = self._deformed()
        Q = frame_rotation(self._correlation(y)) if Q is None else Q
        p = (self._pivot if self._pivot is not None
             else self._sum(self._weight[:, None] * y) / self._area)
        base = self._n0 @ np.asarray(self.model.director_base.value, dtype=float).T
        w[:, :3] = (y - p) @ Q.T + p - self._nodes
        w[:, 3:] = (base + w[:, 3:]) @ Q.T - base
        return w.ravel(), Q

    @contextmanager
    def aligned(self) -> Iterator[np.ndarray]:
        """Hold the aligned state in the model for the block (yields Q), then restore the
        state exactly."""
        from shells.problem.interface import get_state, set_state

        saved = get_state(self.model)
        aligned, Q = self._turned(None)
        set_state(self.model, aligned)
        try:
            yield Q
        finally:
            set_state(self.model, saved)
