"""Fields for ParaView: displacement, director, curvature and energy densities of a shell state
(output layer).

Energy densities per reference area, dimensionless as the energy: ``bending_energy_density``
e_b, the paper's colouring of its ellipsoids, the last two terms of Eq. (S-energy), (h²/3)
[(1-ν)|b - b°|² + ν tr²(b - b°)] - (2(1+ν)/3) h² κ tr(b - b°) (it can be negative: it is the
bending energy relative to the natural curvature, less a constant), and
``stretching_energy_density`` (1-ν)|a - a°|² + ν tr²(a - a°).

``FieldWriter`` interpolates onto the mesh's own (P2) Lagrange space and writes one time step per
call (the caller's time value: ``shells branch`` uses the point's index). The format is VTX
(ADIOS2 BP4, a ``.bp`` directory): ParaView opens it with its ADIOS2VTXReader ("ADIOS2 VTX
Reader"), including Debian 13's ParaView 5.13 (`pvbatch`), which ``scripts/pv-check`` proves by
opening a real run's fields and checking the arrays against dolfinx.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

__all__ = ["FieldWriter"]


class FieldWriter:
    """VTX (ADIOS2) output of displacement, director and curvature fields for ParaView."""

    def __init__(self, model: Any, path: str | os.PathLike | None) -> None:
        """``path`` None: the fields only (``update``), no file."""
        import basix.ufl
        import ufl
        from dolfinx import fem, io

        mesh = model.shell.mesh
        deg = mesh.geometry.cmap.degree
        Vv = fem.functionspace(mesh, basix.ufl.element("Lagrange", mesh.basix_cell(), deg,
                                                       shape=(3,)))
        Vs = fem.functionspace(mesh, basix.ufl.element("Lagrange", mesh.basix_cell(), deg))
        self.model = model
        self.u = fem.Function(Vv, name="displacement")
        self.d = fem.Function(Vv, name="director")
        self.H = fem.Function(Vs, name="mean_curvature_change")
        self.Hbar = fem.Function(Vs, name="natural_curvature_mismatch")
        self.eb = fem.Function(Vs, name="bending_energy_density")
        self.es = fem.Function(Vs, name="stretching_energy_density")
        k, r = model.kinematics(model.w), model.reference()
        dens = model.energy_density(model.w)
        spts = Vs.element.interpolation_points()
        pts = Vv.element.interpolation_points()
        self._exprs = [
            (self.u, fem.Expression(k["u"], pts)),
            (self.d, fem.Expression(k["d"], pts)),
            (self.H, fem.Expression(0.5 * ufl.tr(k["b"] - r["b"]),
                                    spts)),
            (self.Hbar, fem.Expression(0.5 * ufl.tr(k["b"] - r["b"] - model.kappa * model.P0),
                                       spts)),
            (self.eb, fem.Expression(dens["bending"] + dens["curvature_potential"], spts)),
            (self.es, fem.Expression(dens["stretching"], spts)),
        ]
        self.writer = None
        if path is not None:
            Path(path).parent.mkdir(parents=True, exist_ok=True)
            self.writer = io.VTXWriter(mesh.comm, str(path), [f for f, _ in self._exprs],
                                       engine="BP4")

    def update(self) -> dict[str, Any]:
        """Interpolate the fields of the model's current state; returns name -> dolfinx Function."""
        for f, e in self._exprs:
            f.interpolate(e)
        return {f.name: f for f, _ in self._exprs}

    def write(self, t: float) -> dict[str, Any]:
        """Write the fields of the model's current state as the time step ``t`` (collective);
        returns them as ``update`` does."""
        funcs = self.update()
        self.writer.write(t)
        return funcs

    def close(self) -> None:
        """Close the file."""
        if self.writer is not None:
            self.writer.close()


def write_modes(model: Any, state: Any, modes: list[Any], path: str | os.PathLike) -> None:
    """Eigen/critical modes for ParaView (VTX): ``state_displacement`` (the equilibrium) and
    ``mode_displacement`` (the displacement part of each mode, scaled to a maximum of 1), one
    time step per mode. ``state`` and ``modes`` are local arrays of the model's space."""
    import basix.ufl
    import numpy as np
    from dolfinx import fem, io
    from mpi4py import MPI

    mesh = model.shell.mesh
    Vv = fem.functionspace(mesh, basix.ufl.element("Lagrange", mesh.basix_cell(),
                                                   mesh.geometry.cmap.degree, shape=(3,)))
    w = fem.Function(model.W)
    u_state = fem.Function(Vv, name="state_displacement")
    u_mode = fem.Function(Vv, name="mode_displacement")
    expr = fem.Expression(model.split(w)[0], Vv.element.interpolation_points())
    n = model.W.dofmap.index_map.size_local * model.W.dofmap.index_map_bs
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    writer = io.VTXWriter(mesh.comm, str(path), [u_state, u_mode], engine="BP4")
    w.x.array[:n] = np.asarray(state)[:n]
    w.x.scatter_forward()
    u_state.interpolate(expr)
    for k, mode in enumerate(modes):
        w.x.array[:n] = np.asarray(mode)[:n]
        w.x.scatter_forward()
        u_mode.interpolate(expr)
        big = mesh.comm.allreduce(float(np.abs(u_mode.x.array).max(initial=0.0)), op=MPI.MAX)
        if big > 0:
            u_mode.x.array[:] /= big
        writer.write(float(k))
    writer.close()
