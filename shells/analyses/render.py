"""Off-screen pictures of surface meshes and of the surface model's states, deformed and coloured
by a field, with pyvista (PNG; the state also as VTU for ParaView), and of a surface deforming
over time (``render_animation``: an animated GIF, written with Pillow) (output layer).

One style for every 3D figure (``render_surface``; the benchmarks' renders use it too): the
deformed shape itself, lit and smooth-shaded, the camera fitted to the whole shape and to the
reference shape (drawn as a thin grey outline: its silhouette and rim), the white margins
cropped, and a matplotlib colour bar beside it whose label names the field and its unit
(``FIELD_LABELS``). An animation's frames share one camera, colour range and crop.

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

__all__ = ["FIELD_LABELS", "ensure_display", "gather_fields", "gather_vtk_mesh",
           "render_animation", "render_mesh", "render_state", "render_surface"]

#: the colour bar's label of each field a state is coloured by: the quantity and its unit.
#: Energies are the paper's dimensionless ones, 8(1-ν²)/(Eh) times the energy (the scaling of
#: the pressure term, ``shells.surface.model``); lengths are in units of the shape's R.
FIELD_LABELS = {
    "bending_energy_density": "bending energy density $e_b$  [$Eh/8(1-\\nu^2)$]",
    "stretching_energy_density": "stretching energy density $e_s$  [$Eh/8(1-\\nu^2)$]",
    "mean_curvature_change": "mean curvature change $H - H^\\circ$  [$1/R$]",
    "natural_curvature_mismatch": "mismatch with the natural curvature  [$1/R$]",
    "normal_displacement": "normal displacement $\\Psi_3$  [$R$]",
}
#: the style: window (pixels), figure width (inches) and resolution, colours
WINDOW = (1200, 960)
FIGURE_WIDTH = 6.4
DPI = 150
SURFACE_COLOUR = "#8fb8de"
REFERENCE_COLOUR = "#7f7f7f"
REFERENCE_OPACITY = 0.15
#: animations (``render_animation``): the window (pixels), the resolution (the figure's width
#: as above) and speed
ANIMATION_WINDOW = (800, 640)
ANIMATION_DPI = 100
ANIMATION_FPS = 10.0
#: how long an animation's last frame stays, in seconds
ANIMATION_HOLD = 1.5

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


def _surface(dataset: Any) -> Any:
    """The dataset's surface as polygons (second-order cells subdivided twice), its coincident
    points merged (the processes' shared nodes, a surface of revolution's seam)."""
    import pyvista

    if isinstance(dataset, pyvista.PolyData):
        surf = dataset
    elif isinstance(dataset, pyvista.UnstructuredGrid):
        surf = dataset.extract_surface(nonlinear_subdivision=2)
    else:
        surf = dataset.extract_surface()
    return surf.clean(tolerance=1e-12, absolute=False)


def _crop(img: np.ndarray, margin: float = 0.03) -> np.ndarray:
    """The image without its white margins, but for ``margin`` of its size."""
    ink = np.any(img[..., :3] < 250, axis=-1)
    rows, cols = np.flatnonzero(ink.any(axis=1)), np.flatnonzero(ink.any(axis=0))
    if rows.size == 0:
        return img
    pad = int(margin * max(img.shape[:2]))
    r0, r1 = max(rows[0] - pad, 0), min(rows[-1] + pad + 1, img.shape[0])
    c0, c1 = max(cols[0] - pad, 0), min(cols[-1] + pad + 1, img.shape[1])
    return img[r0:r1, c0:c1]


def render_surface(surface: Any, png: str | os.PathLike, *, scalars: str | None = None,
                   label: str | None = None, cmap: str | None = None,
                   clim: tuple[float, float] | None = None, symmetric: bool = False,
                   reference: Any = None, ghost: bool = False, edges: Any = None,
                   title: str | None = None, view: str = "xz", elevation: float = 25.0,
                   azimuth: float = 30.0) -> None:
    """Draw a surface in the renders' style and write it as PNG (on the calling process).

    The shape is lit and smooth-shaded; the camera looks along ``view`` (a pyvista camera
    plane: "xz" looks along y), turned up by ``elevation`` and around the axis by ``azimuth``
    degrees, and is fitted to the whole of the shape and the reference; the colour bar is a
    matplotlib one beside the shape, labelled with the field and its unit.

    Args:
        surface: the (deformed) shape, a pyvista dataset (its surface is drawn).
        png: the image file.
        scalars: the point array that colours it (None: one colour).
        label: the colour bar's label (default: ``FIELD_LABELS`` or the array's name).
        cmap: a matplotlib colour map (default: viridis; with ``symmetric``: RdBu_r).
        clim: the colour range (default: the array's range).
        symmetric: a range symmetric about zero (signed fields: displacements).
        reference: the reference shape, drawn as a thin grey outline (its silhouette seen
            from the camera, and its rim).
        ghost: also draw the reference as a faint translucent surface.
        edges: lines drawn over the shape (e.g. the mesh's edges).
        title: the figure's title.
        view, elevation, azimuth: the camera.
    """
    import pyvista

    ensure_display()
    pyvista.OFF_SCREEN = True
    surf = _surface(surface)
    cmap = cmap or ("RdBu_r" if symmetric else "viridis")
    if scalars is not None and clim is None:
        clim = _colour_range(np.asarray(surf.point_data[scalars]), symmetric)
    Path(png).parent.mkdir(parents=True, exist_ok=True)
    pl = pyvista.Plotter(off_screen=True, window_size=WINDOW)
    pl.set_background("white")
    look = {"smooth_shading": True, "ambient": 0.2, "diffuse": 0.8, "specular": 0.15,
            "specular_power": 20}
    if scalars is not None:
        pl.add_mesh(surf, scalars=scalars, cmap=cmap, clim=clim, show_scalar_bar=False,
                    **look)
    else:
        pl.add_mesh(surf, color=SURFACE_COLOUR, **look)
    bounds = np.array(surf.bounds, dtype=float)
    lines = []
    ref = None
    if reference is not None:
        ref = _surface(reference)
        bounds = _with_reference(pl, ref, bounds, ghost, lines)
    if edges is not None:
        lines.append((edges, "#203040", 0.6))
    pl.camera_position = view
    pl.camera.elevation = elevation
    pl.camera.azimuth = azimuth
    pl.reset_camera(bounds=bounds)
    if ref is not None:
        _add_silhouette(pl, ref, lines)
    _add_lines(pl, lines, bounds)
    img = _crop(pl.screenshot(return_img=True))
    pl.close()
    _figure(img, png, scalars=scalars, clim=clim, cmap=cmap, title=title,
            label=label or (FIELD_LABELS.get(scalars, scalars.replace("_", " "))
                            if scalars is not None else None))


def _colour_range(values: np.ndarray, symmetric: bool) -> tuple[float, float]:
    """The values' range (symmetric about zero if asked), widened where it is empty."""
    lo, hi = float(values.min()), float(values.max())
    if symmetric:
        lo, hi = -max(abs(lo), abs(hi)), max(abs(lo), abs(hi))
    if hi <= lo:
        lo, hi = lo - 0.5 * (abs(lo) or 1.0), hi + 0.5 * (abs(hi) or 1.0)
    return lo, hi


def _with_reference(pl: Any, ref: Any, bounds: np.ndarray, ghost: bool,
                    lines: list[tuple[Any, str, float]]) -> np.ndarray:
    """Draw the reference's ghost (if asked), queue its rim, and return the bounds of the
    shape and the reference together (the camera frames both)."""
    if ghost:
        pl.add_mesh(ref, color=REFERENCE_COLOUR, opacity=REFERENCE_OPACITY,
                    smooth_shading=True)
        pl.enable_depth_peeling()  # the translucent ghost where it meets the shape
    rim = ref.extract_feature_edges(boundary_edges=True, feature_edges=False,
                                    manifold_edges=False, non_manifold_edges=False)
    if rim.n_points:
        lines.append((rim, REFERENCE_COLOUR, 2.0))
    rb = np.array(ref.bounds, dtype=float)
    return np.concatenate([np.minimum(bounds[::2], rb[::2])[:, None],
                           np.maximum(bounds[1::2], rb[1::2])[:, None]], axis=1).ravel()


def _add_silhouette(pl: Any, ref: Any, lines: list[tuple[Any, str, float]]) -> None:
    """Queue the reference's outline as seen from the camera (set before)."""
    import pyvista
    from vtkmodules.vtkFiltersHybrid import vtkPolyDataSilhouette

    sil = vtkPolyDataSilhouette()
    sil.SetInputData(ref)
    sil.SetCamera(pl.renderer.GetActiveCamera())
    sil.SetEnableFeatureAngle(False)
    sil.Update()
    outline = pyvista.wrap(sil.GetOutput())
    if outline.n_points:
        lines.append((outline, REFERENCE_COLOUR, 1.5))


def _add_lines(pl: Any, lines: list[tuple[Any, str, float]], bounds: np.ndarray) -> None:
    """Draw the queued lines. They lie on surfaces (a rim where the shape has not moved, the
    mesh's edges): moved a hair towards the camera, so that the surfaces do not hide them in
    stripes."""
    towards = np.subtract(pl.camera.position, pl.camera.focal_point)
    towards *= 2e-3 * np.linalg.norm(bounds[1::2] - bounds[::2]) / np.linalg.norm(towards)
    for mesh, colour, width in lines:
        shifted = mesh.copy()
        shifted.points = shifted.points + towards
        pl.add_mesh(shifted, color=colour, line_width=width)


def _figure(img: np.ndarray, png: str | os.PathLike, *, scalars: str | None,
            clim: tuple[float, float] | None, cmap: str, title: str | None,
            label: str | None) -> None:
    """The rendered image in a matplotlib figure with its colour bar and title, as PNG."""
    fig = _compose(img, scalars=scalars, clim=clim, cmap=cmap, title=title, label=label,
                   dpi=DPI)
    fig.savefig(png, dpi=DPI, facecolor="white")


def _compose(img: np.ndarray, *, scalars: str | None, clim: tuple[float, float] | None,
             cmap: str, title: str | None, label: str | None, dpi: float,
             interpolation: str = "lanczos") -> Any:
    """The matplotlib figure of ``_figure``: its size depends on the image's aspect only."""
    import matplotlib.colors as mcolors
    from matplotlib import cm
    from matplotlib.figure import Figure

    h_px, w_px = img.shape[:2]
    bar = 0.9 if scalars is not None else 0.0
    width = FIGURE_WIDTH
    height = min(max((width - bar) * h_px / w_px + (0.45 if title else 0.15), 2.5), 7.5)
    fig = Figure(figsize=(width, height), dpi=dpi, layout="constrained")
    ax = fig.add_subplot()
    ax.imshow(img, interpolation=interpolation)
    ax.set_axis_off()
    if scalars is not None and clim is not None:
        mappable = cm.ScalarMappable(mcolors.Normalize(*clim), cmap)
        cb = fig.colorbar(mappable, ax=ax, shrink=0.8, aspect=25, pad=0.02)
        cb.set_label(label or "", fontsize=9)
        cb.ax.tick_params(labelsize=8)
        cb.formatter.set_powerlimits((-2, 3))
        cb.update_ticks()
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


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
    render_surface(grid, png, edges=grid.extract_all_edges(), title=title, view="iso",
                   elevation=15.0, azimuth=0.0)


def gather_fields(funcs: dict[str, Any]) -> Any:
    """Functions on one Lagrange space (``FieldWriter.update``'s) as a pyvista grid on rank 0
    (collective).

    Args:
        funcs: name -> dolfinx Function, all on the same mesh and nodes (vector ones of any
            block size).

    Returns:
        On rank 0 an unstructured grid of the whole mesh, its points the nodes at their
        reference positions, each function a point array of its name; None elsewhere.
    """
    local = {k: f.x.array.reshape(-1, f.function_space.dofmap.index_map_bs)
             for k, f in funcs.items()}
    V = next(iter(funcs.values())).function_space
    n = next(iter(local.values())).shape[0]
    stacked = np.concatenate([local[k].reshape(n, -1) for k in funcs], axis=1)
    data = gather_vtk_mesh(V, stacked)
    if data is None:
        return None
    grid, vals = _unstructured(data), data[3]
    col = 0
    for k in funcs:
        width = local[k].reshape(n, -1).shape[1]
        grid.point_data[k] = vals[:, col:col + width] if width > 1 else vals[:, col]
        col += width
    return grid


def render_state(model: Any, png: str | os.PathLike | None, *, vtu: str | os.PathLike | None = None,
                 color_by: str = "bending_energy_density", title: str | None = None,
                 view: str = "xz", reference: bool = True) -> None:
    """Render the surface model's current state, deformed (collective; rank 0 writes).

    Args:
        model: the surface model, holding the state.
        png: the image file (None: no image).
        vtu: also write the deformed surface with every field as VTK XML (``.vtu``,
            ParaView's default reader).
        color_by: the field that colours it (``shells.surface.fields.FieldWriter``'s arrays;
            its colour bar's label: ``FIELD_LABELS``).
        title: a title drawn on the image.
        view: the camera's plane ("xz", ...), turned 25° up and 30° around.
        reference: draw the reference shape as a faint ghost.
    """
    from shells.surface.fields import FieldWriter

    grid = gather_fields(FieldWriter(model, None).update())
    if grid is None:
        return
    warped = grid.warp_by_vector("displacement", factor=1.0)
    if vtu is not None:
        Path(vtu).parent.mkdir(parents=True, exist_ok=True)
        warped.save(str(vtu))
    if png is None:
        return
    render_surface(warped, png, scalars=color_by, title=title, view=view,
                   reference=grid if reference else None)


def render_animation(grid: Any, frames: list[tuple[np.ndarray, np.ndarray, str]],
                     path: str | os.PathLike, *, scalars: str, label: str | None = None,
                     cmap: str | None = None, view: str = "xz", elevation: float = 25.0,
                     azimuth: float = 30.0, fps: float = ANIMATION_FPS) -> int:
    """Draw a deforming surface as an animated GIF in the renders' style (on the calling
    process).

    Every frame is drawn alike: the same camera (as ``render_surface``'s, fitted to the shape
    in all the frames and to the reference), the same colour range (the field's over all the
    frames), the reference shape as a thin grey outline, the same crop (the white margins of
    all the frames), the frame's title above and the colour bar beside. The last frame stays
    ``ANIMATION_HOLD`` seconds; the colours are one palette for all frames.

    Args:
        grid: the reference shape (a pyvista dataset; its points the reference positions).
        frames: per frame (the displacement of each of ``grid``'s points, n × 3; the values
            of the colouring field at them, n; the title), at least one.
        path: the GIF file.
        scalars: the colouring field's name (its label: ``FIELD_LABELS``).
        label: the colour bar's label (default from ``scalars``).
        cmap: a matplotlib colour map (default viridis).
        view, elevation, azimuth: the camera, as ``render_surface``'s.
        fps: frames per second.

    Returns:
        The number of frames written.
    """
    import io

    import pyvista
    from PIL import Image

    ensure_display()
    pyvista.OFF_SCREEN = True
    cmap = cmap or "viridis"
    label = label or FIELD_LABELS.get(scalars, scalars.replace("_", " "))
    clim = _colour_range(np.concatenate([np.ravel(c) for _, c, _ in frames]), False)
    ref = _surface(grid)
    x0 = np.asarray(grid.points)
    lo = np.min([np.min(x0 + u, axis=0) for u, _, _ in frames], axis=0)
    hi = np.max([np.max(x0 + u, axis=0) for u, _, _ in frames], axis=0)
    bounds = np.column_stack([lo, hi]).ravel()
    look = {"smooth_shading": True, "ambient": 0.2, "diffuse": 0.8, "specular": 0.15,
            "specular_power": 20}

    def shape(u: np.ndarray, c: np.ndarray) -> Any:
        g = grid.copy()
        g.points = x0 + u
        g.point_data[scalars] = c
        return _surface(g)

    pl = pyvista.Plotter(off_screen=True, window_size=ANIMATION_WINDOW)
    pl.set_background("white")
    lines: list[tuple[Any, str, float]] = []
    actor = pl.add_mesh(shape(*frames[0][:2]), scalars=scalars, cmap=cmap, clim=clim,
                        show_scalar_bar=False, **look)
    bounds = _with_reference(pl, ref, bounds, False, lines)
    pl.camera_position = view
    pl.camera.elevation = elevation
    pl.camera.azimuth = azimuth
    pl.reset_camera(bounds=bounds)
    _add_silhouette(pl, ref, lines)
    _add_lines(pl, lines, bounds)
    # the screenshots (kept compressed), and the box holding the ink of them all
    shots, box = [], None
    for k, (u, c, _) in enumerate(frames):
        if k:
            pl.remove_actor(actor, render=False)
            actor = pl.add_mesh(shape(u, c), scalars=scalars, cmap=cmap, clim=clim,
                                show_scalar_bar=False, reset_camera=False, render=False,
                                **look)
        img = pl.screenshot(return_img=True)
        ink = np.any(img[..., :3] < 250, axis=-1)
        rows, cols = np.flatnonzero(ink.any(axis=1)), np.flatnonzero(ink.any(axis=0))
        if rows.size:
            b = (rows[0], rows[-1], cols[0], cols[-1])
            box = b if box is None else (min(box[0], b[0]), max(box[1], b[1]),
                                         min(box[2], b[2]), max(box[3], b[3]))
        buf = io.BytesIO()
        Image.fromarray(img[..., :3]).save(buf, format="PNG", compress_level=1)
        shots.append(buf.getvalue())
    pl.close()
    images = [_animation_frame(shot, box, title, scalars=scalars, clim=clim, cmap=cmap,
                               label=label) for shot, (_, _, title) in zip(shots, frames,
                                                                           strict=True)]
    _write_gif(images, path, fps)
    return len(images)


def _animation_frame(shot: bytes, box: tuple[int, int, int, int] | None, title: str, *,
                     scalars: str, clim: Any, cmap: str, label: str) -> Any:
    """One frame of ``render_animation``: its screenshot cropped to ``box`` (the ink of all
    the frames, padded) and composed with its title and colour bar, as a PIL image."""
    import io

    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from PIL import Image

    img = np.asarray(Image.open(io.BytesIO(shot)).convert("RGB"))
    if box is not None:
        pad = int(0.03 * max(img.shape[:2]))
        img = img[max(box[0] - pad, 0):box[1] + pad + 1, max(box[2] - pad, 0):box[3] + pad + 1]
    fig = _compose(img, scalars=scalars, clim=clim, cmap=cmap, title=title, label=label,
                   dpi=ANIMATION_DPI, interpolation="antialiased")
    canvas = FigureCanvasAgg(fig)
    fig.set_facecolor("white")
    canvas.draw()
    return Image.fromarray(np.asarray(canvas.buffer_rgba())[..., :3].copy())


def _write_gif(images: list[Any], path: str | os.PathLike, fps: float) -> None:
    """The frames as a looping GIF with one palette for all (taken from a strip of up to 8 of
    them, so that colours stay put), the background pure white, the last frame held
    ``ANIMATION_HOLD`` seconds."""
    from PIL import Image

    sample = images[:: max(1, len(images) // 8)][:8]
    strip = Image.new("RGB", (sample[0].width, sample[0].height * len(sample)))
    for k, im in enumerate(sample):
        strip.paste(im, (0, k * im.height))
    palette = strip.quantize(colors=256)
    colours = np.array(palette.getpalette()[:768], dtype=int).reshape(-1, 3)
    colours[np.argmin(np.abs(colours - 255).sum(axis=1))] = 255  # the background white
    palette.putpalette(colours.astype(np.uint8).ravel().tolist())
    frames_p = [im.quantize(palette=palette, dither=Image.Dither.NONE) for im in images]
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    step_ms = int(round(1000.0 / fps))
    frames_p[0].save(path, save_all=True, append_images=frames_p[1:], loop=0,
                     duration=[step_ms] * (len(frames_p) - 1) + [int(1000 * ANIMATION_HOLD)])
