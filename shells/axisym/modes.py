"""Stability of the axisymmetric model against every Fourier mode m (problem layer): the
mode Hessians H_m of ``AxisymModel``, one compiled form for all m.

Stability. Perturbations U(t) cos mφ e_r + V(t) sin mφ e_φ + W(t) cos mφ e_z about the base
state. For an axisymmetric base state the φ-integral of the second-variation density Q equals
π [Q(mφ = 0) + Q(mφ = π/2)] for m ≥ 1 and 2π Q for m = 0, so one UFL form (the second derivative
of the density at base + perturbation, at two phases) with m and the phases as Constants gives
every Hessian H_m: one compilation, no recompiles. The unknowns are (S, D, W) with U = S + D,
V = S - D for m ≥ 1 (U = S, V = D for m = 0), which turns the axis conditions into Dirichlet
conditions on each pole (∂: the slope field): m = 0: S = D = 0, ∂W = 0; m = 1: S = 0, W = 0,
∂S = ∂D = 0; m = 2: S = D = W = 0, ∂S = ∂W = 0; m ≥ 3: all values and slopes zero. A free
rim needs no condition. Rigid motions are exact null vectors of the continuum Hessians and
are removed by value constraints that they violate (restriction to such a hyperplane keeps the
inertia): m = 0: W = 0 at the top pole (z-translation), D = 0 on the widest parallel (rotation
about z); m = 1: D = 0 at the top pole (translation) and W = 0 on the widest parallel (tilt). A
slope constraint at the pole would do for the tilt in principle, but a point has no capacity
for slopes in 2D: it leaves a spurious near-zero eigenvalue. Inertia per m by MUMPS LDLᵀ.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from shells.axisym.model import JIT_OPTIONS, AxisymModel, Jet, _dirichlet
from shells.errors import InputError

__all__ = ["ModeForms"]


# ------------------------------------------------------------------------------------------------
# stability against Fourier modes
# ------------------------------------------------------------------------------------------------
class ModeForms:
    """The Fourier-mode Hessians H_m of the energy about the model's (axisymmetric) state.

    Unknowns (S, D, W; P_S, P_D, P_W) in P3³ x P2³: U = S + D, V = S - D for m ≥ 1 and U = S,
    V = D for m = 0 (see the module docstring for the axis conditions). One compiled form for
    every m: m and the phases are Constants (``set_mode``).
    """

    def __init__(self, model: AxisymModel) -> None:
        import basix.ufl
        import ufl
        from dolfinx import default_scalar_type, fem

        self.model = model
        mesh = model.mesh
        cell = mesh.basix_cell()
        P3 = basix.ufl.element("Lagrange", cell, 3, shape=(3,))
        P2 = basix.ufl.element("Lagrange", cell, 2, shape=(3,))
        self.V = fem.functionspace(mesh, basix.ufl.mixed_element([P3, P2]))
        self.pert = fem.Function(self.V)  # stays zero: the Hessian is taken at the base state
        c = {k: fem.Constant(mesh, default_scalar_type(0.0))
             for k in ("m", "a0", "b0", "a1", "b1", "cSU", "cDU", "cSV", "cDV")}
        self.c = c
        q, Pq = ufl.split(self.pert)
        S, D, W = q[0], q[1], q[2]
        PS, PD, PW = Pq[0], Pq[1], Pq[2]
        U, V = c["cSU"] * S + c["cDU"] * D, c["cSV"] * S + c["cDV"] * D
        PU, PV = c["cSU"] * PS + c["cDU"] * PD, c["cSV"] * PS + c["cDV"] * PD
        m = c["m"]

        def jet(a: Any, b: Any) -> Jet:
            d = lambda f: f.dx(0)  # noqa: E731
            return Jet(val=(U * a, V * b, W * a), t=(d(U) * a, d(V) * b, d(W) * a),
                       ph=(-m * U * b, m * V * a, -m * W * b),
                       tph=(-m * d(U) * b, m * d(V) * a, -m * d(W) * b),
                       phph=(-m**2 * U * a, -m**2 * V * b, -m**2 * W * a),
                       p=(PU * a, PV * b, PW * a), pt=(d(PU) * a, d(PV) * b, d(PW) * a),
                       pph=(-m * PU * b, m * PV * a, -m * PW * b))

        base = model.base_jet(model.w)
        dens = (model.energy_density(base + jet(c["a0"], c["b0"]))["total"]
                + model.energy_density(base + jet(c["a1"], c["b1"]))["total"])
        energy = math.pi * dens * model.r0 * model.g * model.dx
        v, v_ = ufl.TestFunction(self.V), ufl.TrialFunction(self.V)
        self.hessian_ufl = ufl.derivative(ufl.derivative(energy, self.pert, v), self.pert, v_)
        self.form = fem.form(self.hessian_ufl, jit_options=JIT_OPTIONS)
        self.mass = fem.form(ufl.inner(v_, v) * model.r0 * model.g * model.dx)
        self._bcs = {k: self._conditions(k) for k in (0, 1, 2, 3)}

    def radial_axial(self, f: Any) -> tuple[Any, Any]:
        """(u_r, u_z) amplitudes of a mode ``f`` in ``V`` (U and W; phases as last set)."""
        import ufl

        q, _ = ufl.split(f)
        return self.c["cSU"] * q[0] + self.c["cDU"] * q[1], q[2]

    def _conditions(self, mclass: int) -> list[Any]:
        V, model = self.V, self.model
        S, D, W = V.sub(0).sub(0), V.sub(0).sub(1), V.sub(0).sub(2)
        PS, PD, PW = V.sub(1).sub(0), V.sub(1).sub(1), V.sub(1).sub(2)
        poles, top = model.axis_vertices(), model.vertices_at(0.0)
        widest = model.widest_vertex()
        if mclass == 0:
            pairs = [(S, poles), (D, poles), (PW, poles), (W, top), (D, widest)]
        elif mclass == 1:
            pairs = [(S, poles), (PS, poles), (PD, poles), (W, poles), (D, top), (W, widest)]
        elif mclass == 2:
            pairs = [(S, poles), (D, poles), (W, poles), (PS, poles), (PW, poles)]
        else:
            pairs = [(S, poles), (D, poles), (W, poles), (PS, poles), (PD, poles), (PW, poles)]
        return [bc for sub, verts in pairs for bc in _dirichlet(sub, verts)]

    def conditions(self, m: int) -> list[Any]:
        """The Dirichlet conditions of mode m (axis conditions and rigid-motion gauges)."""
        return self._bcs[min(int(m), 3)]

    def set_mode(self, m: int) -> list[Any]:
        """Set the Constants of mode m; returns its Dirichlet conditions."""
        if not (isinstance(m, (int, np.integer)) and m >= 0):
            raise InputError(f"the azimuthal wavenumber m must be a non-negative integer, "
                             f"got {m!r}")
        c = self.c
        c["m"].value = float(m)
        if m == 0:
            vals = dict(a0=1.0, b0=1.0, a1=1.0, b1=1.0, cSU=1.0, cDU=0.0, cSV=0.0, cDV=1.0)
        else:
            vals = dict(a0=1.0, b0=0.0, a1=0.0, b1=1.0, cSU=1.0, cDU=1.0, cSV=1.0, cDV=-1.0)
        for k, v in vals.items():
            c[k].value = v
        return self.conditions(m)
