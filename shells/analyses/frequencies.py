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

__all__ = ["STEP_KAPPA_H", "STEP_KAPPA_R", "along", "critical_estimate", "make_figure",
           "modes_along", "run"]

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
    _check(h_over_r, nu, model, count, m_max, [kappa_R])
    problem, options, blocks = _problem(shape, h_over_r, nu, model, m_max, cells, size,
                                        degree, shear_penalty, comm)
    return _at(problem, shape, h_over_r, nu, model, kappa_R, count, options, blocks)


def _check(h_over_r: float, nu: float, model: str, count: int, m_max: int,
           kappas: list[float]) -> None:
    """The parameters' ranges (``InputError``)."""
    check_h_over_r(h_over_r)
    check_nu(nu)
    check_model(model)
    if not (isinstance(count, int) and count >= 1):
        raise InputError(f"count must be a positive integer, got {count!r}")
    if not (isinstance(m_max, int) and m_max >= 0):
        raise InputError(f"m_max must be a non-negative integer, got {m_max!r}")
    if not kappas or not all(isinstance(k, (int, float)) and math.isfinite(k) for k in kappas):
        raise InputError(f"kappa_R must be finite numbers, got {kappas!r}")


def _problem(shape: Any, h_over_r: float, nu: float, model: str, m_max: int,
             cells: int | None, size: float | None, degree: int | None, shear_penalty: float,
             comm: Any) -> tuple[Any, Any, tuple[Any, ...]]:
    """The model at κ = 0, its Newton options and its stability blocks."""
    from mpi4py import MPI

    h = h_over_r * shape.characteristic_size()
    if model == "axisym":
        from shells.analyses.axisym_runs import default_cells
        from shells.axisym import SNES_OPTIONS, AxisymModel, AxisymParameters

        n_cells = default_cells(shape, h_over_r) if cells is None else int(cells)
        problem: Any = AxisymModel(shape, AxisymParameters(h=h, nu=nu, cells=n_cells),
                                   comm=MPI.COMM_SELF)
        problem.modes = tuple(range(m_max + 1))
        return problem, SNES_OPTIONS, tuple(problem.modes)
    from shells.surface.mesh import MeshSpec, generate
    from shells.surface.model import ModelParameters, ShellModel, default_discretisation

    deg, sz = default_discretisation(shape, h_over_r, degree, size, nu=nu)
    sm = generate(MeshSpec(shape, h=h, size=sz), MPI.COMM_WORLD if comm is None else comm)
    problem = ShellModel(sm, ModelParameters(h=h, nu=nu, degree=deg, quadrature_degree=2 * deg,
                                             shear_penalty=shear_penalty))
    return problem, None, (None,)


def _at(problem: Any, shape: Any, h_over_r: float, nu: float, model: str, kappa_R: float,
        count: int, options: Any, blocks: tuple[Any, ...]) -> dict[str, Any]:
    """Newton from the problem's state to κR = ``kappa_R``, and the frequencies there."""
    from shells.algorithms.frequencies import natural_frequencies
    from shells.algorithms.newton import NewtonSolver
    from shells.geometry.shapes import kappa_length

    L = shape.characteristic_size()
    h = h_over_r * L
    kappa = kappa_R / kappa_length(shape)
    if kappa != problem.get_kappa():
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


def along(shape: Any, h_over_r: float, nu: float = 0.5, *, kappa_R: Any = (0.0,),  # noqa: N803
          model: str = "axisym", count: int = 4, m_max: int = 6, cells: int | None = None,
          size: float | None = None, degree: int | None = None,
          shear_penalty: float = 1.0e3, comm: Any = None) -> dict[str, Any]:
    """The frequencies at several κ, in the order given, along one Newton path.

    Followed along κ, the frequency of the mode that goes unstable falls to zero at the
    critical point (ω² is, to first order, linear in κ there): the vibration-correlation
    technique predicts a buckling load from frequencies measured below it. Arguments as
    ``run``'s, ``kappa_R`` a sequence (ascending in size, on the fundamental branch).

    Returns:
        ``run``'s keys of the last κ, ``points`` (``run``'s record at each κ) and
        ``critical_estimate`` (``critical_estimate``).

    Raises:
        InputError: a parameter out of range, or no κ given.
        RuntimeError: Newton failed on the way.
    """
    kappas = list(kappa_R)
    _check(h_over_r, nu, model, count, m_max, kappas)
    problem, options, blocks = _problem(shape, h_over_r, nu, model, m_max, cells, size, degree,
                                        shear_penalty, comm)
    points = [_at(problem, shape, h_over_r, nu, model, float(k), count, options, blocks)
              for k in kappas]
    return {**points[-1], "points": points, "critical_estimate": critical_estimate(points)}


def modes_along(points: list[dict[str, Any]]) -> dict[tuple[Any, Any], list[float | None]]:
    """Each mode's ω² along the points: {(block, n): [ω² or None, ...]}, a mode named by its
    block (m on the 1D model) and its degree n (closed spheres; None otherwise), the lowest
    ω² of that name at each point."""
    out: dict[tuple[Any, Any], list[float | None]] = {}
    for i, p in enumerate(points):
        for f in p["frequencies"]:
            key = (f["block"], f["mode_n"])
            row = out.setdefault(key, [None] * len(points))
            if row[i] is None or f["omega2"] < row[i]:
                row[i] = f["omega2"]
    return out


def critical_estimate(points: list[dict[str, Any]]) -> dict[str, Any] | None:
    """The vibration-correlation estimate of the next critical point: each mode's ω²
    extrapolated linearly from its last two points to zero, the first zero beyond the last
    κ (None: no mode's ω² falls there).

    Returns:
        {"kappa_R", "block", "mode_n"} of the first mode to reach ω² = 0, or None.
    """
    ks = [p["kappa_R"] for p in points]
    best = None
    for (block, n), w2 in modes_along(points).items():
        known = [(k, w) for k, w in zip(ks, w2, strict=True) if w is not None]
        if len(known) < 2:
            continue
        (k1, w1), (k2, w2_) = known[-2], known[-1]
        slope = (w2_ - w1) / (k2 - k1)
        if slope * (k2 - k1) >= 0 or k2 != ks[-1]:
            continue  # not falling towards zero, or not seen at the last point
        at = k2 - w2_ / slope
        if best is None or abs(at - ks[-1]) < abs(best["kappa_R"] - ks[-1]):
            best = {"kappa_R": at, "block": block, "mode_n": n}
    return best


def make_figure(result: dict[str, Any], path: Any) -> None:
    """ω² of each block's lowest mode against κR (``along``'s result), as PNG."""
    from matplotlib.figure import Figure

    points = result["points"]
    ks = [p["kappa_R"] for p in points]
    fig = Figure(figsize=(6.0, 4.0), layout="constrained")
    ax = fig.add_subplot()
    for (block, n), w2 in sorted(modes_along(points).items(), key=str):
        xs = [k for k, w in zip(ks, w2, strict=True) if w is not None]
        ys = [w for w in w2 if w is not None]
        name = ", ".join(x for x in ((f"m = {block}" if block is not None else ""),
                                     (f"n = {n}" if n is not None else "")) if x)
        ax.plot(xs, ys, "o-", ms=3, label=name or None)
    est = result.get("critical_estimate")
    if est is not None:
        ax.axvline(est["kappa_R"], color="0.3", ls="--", lw=0.8)
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.set_xlabel("κR")
    ax.set_ylabel("ω² [E/(ρR²)]")
    ax.legend(fontsize=7, ncol=2)
    fig.savefig(path, dpi=150)
