"""Surfaces of revolution from the 1D model's meridian: 3D shapes for ParaView and renders
(output layer).

``revolve(profile, m=None, ...)`` turns a meridian state (``AxisymModel.meridian_profile()``)
into a pyvista ``StructuredGrid`` of the deformed surface, with the point arrays of the surface
model's fields where they exist: ``displacement`` (Cartesian, 3 components) and
``normal_displacement`` (u·n°), and where the profile has them, ``bending_energy_density`` and
``stretching_energy_density`` (of the axisymmetric state). ``write_vts`` writes it as VTK XML
structured grid (``.vts``), which ParaView opens with its default reader;
``write_profile_csv`` writes the meridian as CSV. A mode m ≥ 1 can be superposed as
``amplitude`` cos(mφ) times a given meridian mode shape.
"""

from __future__ import annotations

import csv
import os
from typing import Any

import numpy as np

__all__ = ["revolve", "write_profile_csv", "write_vts"]


def revolve(profile: dict[str, np.ndarray], n_phi: int = 97, mode: dict[str, Any] | None = None
            ) -> Any:
    """The deformed surface of revolution of a meridian profile.

    Args:
        profile: arrays with keys t, r0, z0, ur, uz (one entry per meridian node).
        n_phi: the number of azimuths; the first and last φ coincide (closed in φ).
        mode: {"m", "ur", "uz", "amplitude"}: superposes amplitude (u_r, u_z)(t) cos(mφ)
            (on the same meridian nodes).

    Returns:
        A pyvista structured grid.
    """
    import pyvista as pv

    phi = np.linspace(0.0, 2.0 * np.pi, n_phi)
    r0, z0 = profile["r0"][:, None], profile["z0"][:, None]
    ur = np.repeat(profile["ur"][:, None], n_phi, axis=1)
    uz = np.repeat(profile["uz"][:, None], n_phi, axis=1)
    if mode is not None:
        c = mode["amplitude"] * np.cos(mode["m"] * phi)[None, :]
        ur = ur + mode["ur"][:, None] * c
        uz = uz + mode["uz"][:, None] * c
    cos, sin = np.cos(phi)[None, :], np.sin(phi)[None, :]
    X0 = np.stack([r0 * cos, r0 * sin, np.repeat(z0, n_phi, axis=1)], axis=-1)
    U = np.stack([ur * cos, ur * sin, uz], axis=-1)
    # outward reference normal of the meridian (r°(t), z°(t)): (z°', -r°') / |.| rotated; from
    # finite differences of the nodes (exact enough for a field to colour by)
    dr = np.gradient(profile["r0"], profile["t"])
    dz = np.gradient(profile["z0"], profile["t"])
    g = np.hypot(dr, dz)
    nr, nz = (-dz / g)[:, None], (dr / g)[:, None]
    N = np.stack([nr * cos, nr * sin, np.repeat(nz, n_phi, axis=1)], axis=-1)
    X = X0 + U
    grid = pv.StructuredGrid(X[..., 0], X[..., 1], X[..., 2])
    # pyvista orders structured points with the first index fastest (Fortran order)
    grid.point_data["displacement"] = np.stack([U[..., k].ravel(order="F") for k in range(3)],
                                               axis=1)
    grid.point_data["normal_displacement"] = np.sum(U * N, axis=-1).ravel(order="F")
    for key, name in (("eb", "bending_energy_density"), ("es", "stretching_energy_density")):
        if key in profile:
            grid.point_data[name] = np.repeat(profile[key][:, None], n_phi, axis=1).ravel(
                order="F")
    return grid


def write_vts(grid: Any, path: str | os.PathLike) -> str:
    """Write ``grid`` as ``.vts`` (VTK XML structured grid).

    Args:
        grid: the grid (``revolve``'s).
        path: the file.

    Returns:
        The path written.
    """
    path = os.fspath(path)
    if not path.endswith(".vts"):
        path += ".vts"
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    grid.save(path)
    return path


def write_profile_csv(profile: dict[str, np.ndarray], path: str | os.PathLike,
                      h: float) -> None:
    """Write the meridian as CSV: t, r°, z°, r, z (deformed), u_r/h, u_z/h, one row per node.

    Args:
        profile: as for ``revolve``.
        path: the file.
        h: the thickness (the displacements' unit).
    """
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["t", "r0", "z0", "r", "z", "ur_over_h", "uz_over_h"])
        for row in zip(profile["t"], profile["r0"], profile["z0"],
                       profile["r0"] + profile["ur"], profile["z0"] + profile["uz"],
                       profile["ur"] / h, profile["uz"] / h, strict=True):
            w.writerow([f"{v:.10g}" for v in row])
