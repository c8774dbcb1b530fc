"""Off-screen pictures of surface meshes and of the surface model's states, deformed and coloured
by a field, with pyvista (PNG; the state also as VTU for ParaView) (output layer).

VTK needs an X display for OpenGL here; without one, a private Xvfb is started once per process
(``xvfb`` is in the package list). Rendering happens on rank 0 from data gathered to it.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from shells.surface.mesh import ShellMesh

__all__ = ["ensure_display", "gather_vtk_mesh", "render_mesh", "render_state"]

_xvfb: subprocess.Popen | None = None


def ensure_display() -> None:
    """Make sure VTK has a display: keep $DISPLAY, else start a private Xvfb."""
    global _xvfb
    if os.environ.get("DISPLAY") or _xvfb is not None:
        return
    exe = shutil.which("Xvfb")
    if exe is None:
        return  # let VTK try its own off-screen path
    for num in range(99, 140):
        if os.path.exists(f"/tmp/.X{num}-lock"):
            continue
        proc = subprocess.Popen([exe, f":{num}", "-screen", "0", "1280x1024x24", "-nolisten",
                                 "tcp"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        for _ in range(50):
            if os.path.exists(f"/tmp/.X11-unix/X{num}") or proc.poll() is not None:
                break
            time.sleep(0.05)
        if proc.poll() is None:
            _xvfb = proc
            os.environ["DISPLAY"] = f":{num}"
            import atexit

            atexit.register(proc.terminate)
            return


def gather_vtk_mesh(mesh: Any, values: np.ndarray | None = None
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None] | None:
    """Gather the whole mesh's VTK arrays on rank 0 (collective).

    Args:
        mesh: a dolfinx mesh, or a Lagrange function space (points: its DOF nodes).
        values: per-point values (local, owned + ghost) as from ``dolfinx.plot.vtk_mesh``.

    Returns:
        (cells, cell types, points, point values or None) on rank 0, None elsewhere.
    """
    from dolfinx import plot

    topology, cell_types, x = plot.vtk_mesh(mesh)
    mesh = getattr(mesh, "mesh", mesh)
    comm = mesh.comm
    num_cells_local = mesh.topology.index_map(mesh.topology.dim).size_local
    # keep owned cells only; their point indices are local: offset them per rank
    npc = topology[0]
    topo = topology.reshape(-1, npc + 1)[:num_cells_local]
    parts = comm.gather((topo, cell_types[:num_cells_local], x, values), root=0)
    if comm.rank != 0:
        return None
    cells, types, pts, vals, offset = [], [], [], [], 0
    for t, ct, xx, vv in parts:
        t = t.copy()
        t[:, 1:] += offset
        cells.append(t)
        types.append(ct)
        pts.append(xx)
        if vv is not None:
            vals.append(vv)
        offset += xx.shape[0]
    return (np.concatenate(cells).ravel(), np.concatenate(types), np.concatenate(pts),
            np.concatenate(vals) if vals else None)


def _unstructured(data: tuple) -> Any:
    """A pyvista grid of ``gather_vtk_mesh``'s cells and points, with a display for VTK."""
    import pyvista

    ensure_display()
    pyvista.OFF_SCREEN = True
    cells, types, pts, _ = data
    return pyvista.UnstructuredGrid(cells, types, pts)


def _plotter(png: str | os.PathLike) -> Any:
    import pyvista

    Path(png).parent.mkdir(parents=True, exist_ok=True)
    pl = pyvista.Plotter(off_screen=True, window_size=(900, 700))
    pl.set_background("white")
    return pl


def render_mesh(sm: ShellMesh, png: str | os.PathLike, *, title: str | None = None) -> None:
    """Render the surface with its edges (collective; rank 0 writes).

    Args:
        sm: the mesh.
        png: the image file.
        title: a title drawn on the image.
    """
    data = gather_vtk_mesh(sm.mesh)
    if data is None:
        return
    grid = _unstructured(data)
    surf = grid.extract_surface(nonlinear_subdivision=2)
    pl = _plotter(png)
    pl.add_mesh(surf, color="#8fb8de", show_edges=False, smooth_shading=True)
    pl.add_mesh(grid.extract_all_edges(), color="#203040", line_width=0.5)
    if title:
        pl.add_text(title, font_size=10, color="black")
    pl.camera_position = "iso"
    pl.camera.elevation = 15
    pl.screenshot(str(png))
    pl.close()


def render_state(model: Any, png: str | os.PathLike | None, *, vtu: str | os.PathLike | None = None,
                 color_by: str = "bending_energy_density", title: str | None = None,
                 view: str = "xz") -> None:
    """Render the surface model's current state, deformed (collective; rank 0 writes).

    Args:
        model: the surface model, holding the state.
        png: the image file (None: no image).
        vtu: also write the deformed surface with every field as VTK XML (``.vtu``,
            ParaView's default reader).
        color_by: the field that colours it (``shells.surface.fields.FieldWriter``'s arrays).
        title: a title drawn on the image.
        view: the camera's plane ("xz", ...).
    """
    from shells.surface.fields import FieldWriter

    funcs = FieldWriter(model, None).update()
    V = funcs["displacement"].function_space
    local = {k: f.x.array.reshape(-1, f.function_space.dofmap.index_map_bs)
             for k, f in funcs.items()}
    n = local["displacement"].shape[0]
    stacked = np.concatenate([local[k].reshape(n, -1) for k in funcs], axis=1)
    data = gather_vtk_mesh(V, stacked)
    if data is None:
        return
    grid, vals = _unstructured(data), data[3]
    col = 0
    for k in funcs:
        width = local[k].reshape(n, -1).shape[1]
        grid.point_data[k] = vals[:, col:col + width] if width > 1 else vals[:, col]
        col += width
    warped = grid.warp_by_vector("displacement", factor=1.0)
    if vtu is not None:
        Path(vtu).parent.mkdir(parents=True, exist_ok=True)
        warped.save(str(vtu))
    if png is None:
        return
    surf = warped.extract_surface(nonlinear_subdivision=2)
    pl = _plotter(png)
    pl.add_mesh(surf, scalars=color_by, cmap="viridis", smooth_shading=True,
                scalar_bar_args={"title": color_by.replace("_", " "), "color": "black"})
    if title:
        pl.add_text(title, font_size=10, color="black")
    pl.camera_position = view
    pl.camera.elevation = 25
    pl.camera.azimuth = 30
    pl.screenshot(str(png))
    pl.close()
