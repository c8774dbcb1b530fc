"""Natural frequencies of a shell at a natural curvature κ (analysis layer): ``run``.

Newton takes the shell from κ = 0 along its fundamental branch to κ (natural steps, |Δκ h| ≤
``STEP_KAPPA_H`` on closed shells, |Δκ R| ≤ ``STEP_KAPPA_R`` on open ones, halved where Newton
fails), and ``shells.algorithms.frequencies.natural_frequencies`` gives the lowest ω² of the
prestressed shell about that state: the surface model's one block, the 1D model's Fourier blocks
m = 0..``m_max`` (``count`` each). ω is in units of √(E/ρ)/R (R the shape's length scale); the
free shell's rigid motions carry no kinetic energy (``shells.problem.kinetic``).
"""

from __future__ import annotations

import logging
import math
from typing import Any

from shells.errors import InputError
from shells.parameters import check_h_over_r, check_model, check_nu

__all__ = ["STEP_KAPPA_H", "STEP_KAPPA_R", "run"]

log = logging.getLogger("shells")

#: the largest step of κh on a closed shell and of κR on an open one on the way to κ
STEP_KAPPA_H = 0.1
STEP_KAPPA_R = 0.25


def _to_kappa(model: Any, kappa: float, newton: Any, closed: bool, h: float, L: float) -> None:
    """Natural steps of κ from the model's state to ``kappa`` (halving a failed step)."""
    step = STEP_KAPPA_H / h if closed else STEP_KAPPA_R / L
    k0 = model.get_kappa()
    while abs(kappa - k0) > 0:
        dk = math.copysign(min(step, abs(kappa - k0)), kappa - k0)
        saved = model.state.copy()
        model.set_kappa(k0 + dk)
        ok, _ = newton.solve()
        if ok:
            k0 += dk
            saved.destroy()
            continue
        saved.copy(model.state)
        model.sync()
        model.set_kappa(k0)
        saved.destroy()
        step = abs(dk) / 2
        if step < 1e-6 * (1 / h if closed else 1 / L):
            raise RuntimeError(f"Newton failed on the way to kappa = {kappa:g} (stopped at "
                               f"{k0:g}): past a fold of the fundamental branch?")


def run(shape: Any, h_over_r: float, nu: float = 0.5, *, kappa_R: float = 0.0,  # noqa: N803
        model: str = "axisym", count: int = 4, m_max: int = 6, cells: int | None = None,
        size: float | None = None, degree: int | None = None,
        shear_penalty: float = 1.0e3, comm: Any = None) -> dict[str, Any]:
    """The lowest natural frequencies of the shell at κR = ``kappa_R``.

    Args:
        shape: the shell's reference shape.
        h_over_r: thickness over the shape's length scale.
        nu: Poisson's ratio.
        kappa_R: κ R (R: ``kappa_length``) of the state, reached from κ = 0 on the
            fundamental branch.
        model: "axisym" (the 1D model: Fourier blocks 0..``m_max``) or "surface".
        count: frequencies per block (the 1D model's Fourier blocks) or in all (surface).
        m_max: the 1D model's largest wavenumber.
        cells: the 1D mesh's bulk cells (None: ``shells.analyses.axisym_runs.default_cells``).
        size, degree: the surface mesh (None: ``default_discretisation``).
        shear_penalty: the surface model's Kirchhoff-Love penalty.
        comm: the surface model's communicator (default MPI.COMM_WORLD; the 1D model runs on
            MPI.COMM_SELF on every rank).

    Returns:
        ``kappa_R``, ``kappa_h``, ``model``, ``h_over_R``, ``nu``, ``dofs`` and ``frequencies``
        (ascending ω: ``omega`` in √(E/ρ)/R, ``omega2``, ``mode_m``, ``mode_n``, ``block``).

    Raises:
        InputError: a parameter out of range.
        RuntimeError: Newton failed on the way to κ.
    """
    from mpi4py import MPI

    from shells.algorithms.frequencies import natural_frequencies
    from shells.algorithms.newton import NewtonSolver
    from shells.geometry.shapes import kappa_length

    check_h_over_r(h_over_r)
    check_nu(nu)
    check_model(model)
    if not (isinstance(count, int) and count >= 1):
        raise InputError(f"count must be a positive integer, got {count!r}")
    if not (isinstance(m_max, int) and m_max >= 0):
        raise InputError(f"m_max must be a non-negative integer, got {m_max!r}")
    if not math.isfinite(kappa_R):
        raise InputError(f"kappa_R must be finite, got {kappa_R!r}")
    L = shape.characteristic_size()
    h = h_over_r * L
    kappa = kappa_R / kappa_length(shape)
    if model == "axisym":
        from shells.analyses.axisym_runs import default_cells
        from shells.axisym import SNES_OPTIONS, AxisymModel, AxisymParameters

        n_cells = default_cells(shape, h_over_r) if cells is None else int(cells)
        problem: Any = AxisymModel(shape, AxisymParameters(h=h, nu=nu, cells=n_cells),
                                   comm=MPI.COMM_SELF)
        problem.modes = tuple(range(m_max + 1))
        options = SNES_OPTIONS
        blocks: tuple[Any, ...] = tuple(problem.modes)
    else:
        from shells.surface.mesh import MeshSpec, generate
        from shells.surface.model import ModelParameters, ShellModel, default_discretisation

        deg, sz = default_discretisation(shape, h_over_r, degree, size, nu=nu)
        sm = generate(MeshSpec(shape, h=h, size=sz), MPI.COMM_WORLD if comm is None else comm)
        problem = ShellModel(sm, ModelParameters(h=h, nu=nu, degree=deg,
                                                 quadrature_degree=2 * deg,
                                                 shear_penalty=shear_penalty))
        options = None
        blocks = (None,)
    if kappa != 0.0:
        newton = NewtonSolver(problem, options=options)
        try:
            _to_kappa(problem, kappa, newton, bool(shape.closed), h, L)
        finally:
            newton.destroy()
    freqs = natural_frequencies(problem, count=count, blocks=blocks)
    freqs.sort(key=lambda f: f.omega2)
    return {"kappa_R": kappa_R, "kappa_h": kappa * h, "model": model, "h_over_R": h_over_r,
            "nu": nu, "shape": shape.describe(), "dofs": problem.num_dofs(),
            "frequencies": [{"omega": f.omega, "omega2": f.omega2, "mode_m": f.mode_m,
                             "mode_n": f.mode_n, "block": f.block} for f in freqs]}
