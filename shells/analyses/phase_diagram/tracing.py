"""Tracing one branch of the phase diagram (driver layer, on
``shells.algorithms.following.follow``): the axisymmetric model's first critical points up and down
with the curvatures there, the surface model's for spot checks, and the everted branch followed
through the snap."""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Iterator
from typing import Any

import numpy as np

from shells.theory import buckling_kappa_R, mirrored_buckling_kappa_R, snap_kappa_R

__all__ = ["compute_task", "everted_check"]

from shells.analyses.phase_diagram.config import PhaseDiagramConfig, Task

log = logging.getLogger("shells")


# ------------------------------------------------------------------------------------------------
# one branch on the axisymmetric model
# ------------------------------------------------------------------------------------------------
class _Curvatures:
    """Total curvatures b_11 R, b_22 R (orthonormal frame) of the model's state at the pole and
    at the rim of a spherical cap of radius 1 (b° = -a°)."""

    def __init__(self, model: Any) -> None:
        from dolfinx import fem

        self.model = model
        db = model.strains(model.base_jet(model.w))["b"]
        X = np.array([[0.0], [1.0]])
        self.expr = fem.Expression(_ufl_vector([db[0] - 1.0, db[2] - 1.0]), X)
        x = model.mesh.geometry.x[:, 0]
        dm = model.mesh.geometry.dofmap
        self.where: dict[str, tuple[int, int]] = {}
        # the pole itself is singular (r° = 0): the first node off the axis stands for it
        for name, t in (("pole", float(np.unique(x)[1])), ("rim", float(x.max()))):
            for c in range(dm.shape[0]):
                ends = x[dm[c]]
                hit = np.nonzero(np.abs(ends - t) < 1e-12 * max(1.0, abs(t)))[0]
                if hit.size:
                    self.where[name] = (c, int(hit[0]))  # geometry node i sits at X = i
                    break

    def __call__(self) -> dict[str, float]:
        out = {}
        for name, (cell, i) in self.where.items():
            v = self.expr.eval(self.model.mesh, np.array([cell], dtype=np.int32)).reshape(2, 2)
            out[f"b11_{name}_R"], out[f"b22_{name}_R"] = float(v[i, 0]), float(v[i, 1])
        return out


def _ufl_vector(items: list[Any]) -> Any:
    import ufl

    return ufl.as_vector(items)


class BranchTracer:
    """Model and Newton solver of one axisymmetric run, and the curvatures of its state."""

    def __init__(self, theta: float, h_over_r: float, nu: float, cfg: PhaseDiagramConfig
                 ) -> None:
        from shells.algorithms.newton import NewtonSolver
        from shells.axisym import AxisymModel
        from shells.geometry.shapes import SphericalCap

        self.shape = SphericalCap(1.0, theta)
        self.model = AxisymModel(self.shape, cfg.discretisation.axisym_parameters(h_over_r, nu))
        self.ns = NewtonSolver(self.model, options={"snes_rtol": 1e-9, "snes_atol": 1e-11,
                                                    "snes_stol": 1e-12, "snes_max_it": 30})
        self.modes = list(range(cfg.m_max + 1))
        self.model.modes = tuple(self.modes)
        self.curv = _Curvatures(self.model)
        self.settings = cfg.discretisation.continuation_settings(self.shape, h_over_r)

    def follow(self, kappa_end: float, crit: Any, **kw: Any) -> Iterator[tuple]:
        """``critical.follow`` from κ = 0 to ``kappa_end`` (R = 1: κ = κR), all m checked."""
        from shells.algorithms.following import follow

        return follow(self.model, self.settings, kappa_end, crit, solver=self.ns,
                      blocks=self.modes, **kw)

    def curvatures_at(self, cp: Any) -> dict[str, float]:
        """The curvatures of a critical point's state (the model's state is kept)."""
        from shells.problem.interface import get_state, set_state

        keep = get_state(self.model)
        set_state(self.model, cp.state)
        try:
            return self.curv()
        finally:
            set_state(self.model, keep)

    def destroy(self) -> None:
        self.ns.destroy()


def _bifurcation_record(br: BranchTracer, cp: Any, step_modes: list[int]) -> dict[str, Any]:
    return {"kappa_R": cp.kappa, "bracket": [cp.kappa_lo, cp.kappa_hi], "mode_m": cp.mode_m,
            "modes": [cp.mode_m], "modes_at_step_end": step_modes, "accuracy": cp.accuracy,
            **br.curvatures_at(cp)}


def _trace_axisym(task: Task, cfg: PhaseDiagramConfig) -> dict[str, Any]:
    """Follow one branch; returns its first critical point, the fold and the first bifurcation.

    Going down the first bifurcation ends the run; going up the branch is followed past its
    first bifurcation (folds only) up to the snap fold, unless the cap is inverted (pole
    curvature b11 R > 0) there: a smoothly inverting cap has no fold to look for."""
    from shells.algorithms.settings import CriticalSettings

    h = task.h_over_r
    tb = task.thetabar
    sign = 1.0 if task.direction == "up" else -1.0
    if task.direction == "up":
        bound = 1.6 * max(snap_kappa_R(tb), mirrored_buckling_kappa_R(tb, h), 1.0) + 0.5
    else:
        bound = 2.5 * max(-buckling_kappa_R(tb, h), 1.0) + 1.0
    br = BranchTracer(task.theta, h, cfg.nu, cfg)
    out: dict[str, Any] = {"fold": None, "bifurcation": None, "inverted_at_bifurcation": None,
                           "kappa_R_end": sign * bound, "branch_points": 0,
                           "dofs": br.model.num_dofs()}
    crit = CriticalSettings(rel_tol=cfg.rel_tol, stop_at_fold=True,
                            stop_at_first=task.direction == "down",
                            folds_only_after_first=True)
    prev_counts: dict[int, int] | None = None
    try:
        for _, res, cps in br.follow(sign * bound, crit):
            out["branch_points"] += 1
            stop = False
            for c in cps:
                if c.kind == "fold":
                    out["fold"] = {"kappa_R": c.kappa, **br.curvatures_at(c)}
                elif out["bifurcation"] is None:
                    step = ([m for m in br.modes if res.counts[m] != prev_counts[m]]
                            if res.counts and prev_counts else [c.mode_m])
                    bif = _bifurcation_record(br, c, step)
                    out["bifurcation"] = bif
                    inverted = bif.get("b11_pole_R", -1.0) > 0.0
                    out["inverted_at_bifurcation"] = inverted
                    stop = task.direction == "down" or inverted
            if res.counts is not None:
                prev_counts = res.counts
            if stop:
                break
    finally:
        br.destroy()
    fold, bif = out["fold"], out["bifurcation"]
    if bif is not None and (fold is None or sign * bif["kappa_R"] <= sign * fold["kappa_R"]):
        first = {"kind": "bifurcation", "kappa_R": bif["kappa_R"], "mode_m": bif["mode_m"]}
    elif fold is not None:
        first = {"kind": "fold", "kappa_R": fold["kappa_R"], "mode_m": 0}
    else:
        first = {"kind": "none", "kappa_R": None, "mode_m": None}
    out["first"] = first
    return out


# ------------------------------------------------------------------------------------------------
# one branch on the surface model (spot checks)
# ------------------------------------------------------------------------------------------------
def _trace_surface(task: Task, cfg: PhaseDiagramConfig) -> dict[str, Any]:
    from mpi4py import MPI

    from shells.algorithms.following import follow
    from shells.algorithms.settings import ContinuationSettings, CriticalSettings
    from shells.analyses.critical import REUSE_SURFACE
    from shells.geometry.shapes import SphericalCap
    from shells.surface.mesh import generate
    from shells.surface.model import ModelParameters, ShellModel

    h, tb = task.h_over_r, task.thetabar
    shape = SphericalCap(1.0, task.theta)
    sm = generate(cfg.discretisation.mesh_spec(shape, h), MPI.COMM_SELF)
    model = ShellModel(sm, ModelParameters(h=h, nu=cfg.nu))
    if task.direction == "up":
        bound = 1.3 * max(snap_kappa_R(tb), mirrored_buckling_kappa_R(tb, h), 1.0) + 0.3
    else:
        bound = -(1.3 * min(buckling_kappa_R(tb, h), -1.0) - 0.3)
    sign = 1.0 if task.direction == "up" else -1.0
    st = ContinuationSettings(ds=bound / 16, ds_max=bound / 10, ds_min=1e-7 * bound,
                              ds_unit="kappa", factor_reuse=REUSE_SURFACE)
    crit = CriticalSettings(rel_tol=max(cfg.rel_tol, 1e-4), stop_at_first=task.direction == "down")
    found, n = [], 0
    for _, _, cps in follow(model, st, sign * bound, crit):
        n += 1
        found.extend(cps)
    fold = next(({"kappa_R": c.kappa} for c in found if c.kind == "fold"), None)
    bifs = [c for c in found if c.kind != "fold"]
    bif = ({"kappa_R": bifs[0].kappa, "mode_m": bifs[0].mode_m, "modes": [bifs[0].mode_m]}
           if bifs else None)
    if found:
        c = found[0]
        first = {"kind": "fold" if c.kind == "fold" else "bifurcation", "kappa_R": c.kappa,
                 "mode_m": 0 if c.kind == "fold" else c.mode_m}
    else:
        first = {"kind": "none", "kappa_R": None, "mode_m": None}
    return {"fold": fold, "bifurcation": bif, "first": first, "inverted_at_bifurcation": None,
            "kappa_R_end": sign * bound, "branch_points": n, "dofs": model.num_dofs()}


def compute_task(task: Task, cfg: PhaseDiagramConfig) -> dict[str, Any]:
    """Follow one branch of the diagram.

    Args:
        task: the branch: (h/R, θ̄, direction).
        cfg: the diagram.

    Returns:
        Its JSON record, with ``status`` "ok" or "failed" (and the ``error``: a failure is
        recorded, not raised, so the diagram goes on without the point).
    """
    t0 = time.perf_counter()
    rec: dict[str, Any] = {"h_over_R": task.h_over_r, "thetabar": task.thetabar,
                           "theta_deg": math.degrees(task.theta), "direction": task.direction,
                           "tag": task.tag, **cfg.numerics()}
    try:
        trace = _trace_axisym if cfg.model == "axisym" else _trace_surface
        rec.update(trace(task, cfg))
        rec["status"] = "ok"
    except Exception as e:  # noqa: BLE001 - recorded, the diagram goes on without this point
        rec.update(status="failed", error=f"{type(e).__name__}: {e}")
    rec["wall_time"] = time.perf_counter() - t0
    return rec


def everted_check(h_over_r: float, thetabar: float, cfg: PhaseDiagramConfig,
                  kappa_max: float | None = None) -> dict[str, Any]:
    """Check κ_e R = 2 - κ_b R (mirror symmetry) on the everted branch directly.

    Follows the up-branch through the snap fold and its second fold onto the everted branch
    and locates the loss of symmetry there (the first count change after the branch is stable
    again). Costly for deep caps.

    Args:
        h_over_r: the cap's h/R.
        thetabar: its θ̄.
        cfg: the diagram (its numerics).
        kappa_max: the end of the range in κR (default from Eq. (4)'s mirror, with a margin).

    Returns:
        {"h_over_R", "thetabar", "folds" (κR of the folds passed), "everted_bifurcation"
        (None if not found), ...}.
    """
    from shells.algorithms.settings import CriticalSettings

    task = Task(h_over_r, thetabar, "up", tag="everted")
    bound = kappa_max or 2.0 - 1.5 * buckling_kappa_R(thetabar, h_over_r) + 1.0
    br = BranchTracer(task.theta, h_over_r, cfg.nu, cfg)
    folds: list[float] = []
    stable_again = [False]
    result: dict[str, Any] = {"h_over_R": h_over_r, "thetabar": thetabar, "folds": folds,
                              "everted_bifurcation": None}

    def everted_loss(p: Any, before: dict[int, int], after: dict[int, int]) -> bool:
        # the only step searched for a crossing: the first instability of the everted branch
        return stable_again[0] and not any(before.values()) and any(after.values())

    crit = CriticalSettings(rel_tol=cfg.rel_tol, stop_at_fold=False)
    prev_counts: dict[int, int] | None = None
    try:
        for _, res, cps in br.follow(bound, crit, locate_when=everted_loss):
            folds += [c.kappa for c in cps if c.kind == "fold"]
            bifs = [c for c in cps if c.kind != "fold"]
            if bifs:
                step = [m for m in br.modes if prev_counts and res.counts[m] != prev_counts[m]]
                result["everted_bifurcation"] = _bifurcation_record(br, bifs[0], step)
                break
            if len(folds) >= 2 and not any(res.counts.values()):
                stable_again[0] = True
            prev_counts = res.counts
    finally:
        br.destroy()
    return result
