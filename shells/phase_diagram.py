"""Phase diagram of open spherical caps under natural curvature κ (the paper's Fig. 3), in one run.

For every (h/R, θ̄ = θ/√(h/R)) two branches of the axisymmetric model (``shells.axisym``) are
followed from κ = 0 with the Hessian inertia of every Fourier mode m = 0..m_max:

* **up** (κ > 0): the first critical point: the snap-through fold (m = 0), a loss of symmetry
  (bifurcation m ≥ 1) before it, or, for shallow caps that invert smoothly (no fold), the loss of
  symmetry of the inverted shell. The axisymmetric fold is followed to the end even when a
  bifurcation precedes it (the paper's snapping line comes from a 1D model): ``kappa_snap_R``.
* **down** (κ < 0): the loss of symmetry κ_b R of Eq. (4), with its m.
* **everted branch** (κ > 0, past the snap): its loss of symmetry is κ_e R = 2 - κ_b R *exactly*:
  reflecting a state in the plane of the rim keeps a and flips b (the normal is reversed), so with
  b° = -a°/R the energy at κ of the reflected state equals the energy at 2/R - κ of the original.
  The everted branch is the mirror of the fundamental branch, and the paper's mirrored Eq. (4) is
  a symmetry of the energy (checked numerically by ``everted_check``, which follows the branch
  through the snap and its second fold onto the everted branch).

Points run in parallel, one per MPI process (each on ``MPI.COMM_SELF``; the axisymmetric model is
serial), dynamically: a process claims the next task by creating a claim file, so ``mpirun -n 2``
computes two at once. Every result is appended (one line, flushed) to ``DIR/points.jsonl`` by the
process that computed it; a rerun reads that file and skips finished tasks (same numerics).
Then rank 0 fits the paper's laws with standard errors (``fit_all``), refines θ̄_s by bisection,
writes ``DIR/phase_diagram.json`` and the figure ``DIR/phase_diagram.{png,pdf}``.

``--model surface`` computes the same first critical points with the 2D surface model
(``shells.critical.follow``) for spot checks (much slower; no everted-branch check).
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import os
import time
import uuid
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from shells.errors import InputError
from shells.store import append_record, json_default, read_records
from shells.theory import PAPER, buckling_kappa_R, mirrored_buckling_kappa_R, plate_a, snap_kappa_R

__all__ = ["PhaseDiagramConfig", "Task", "compute_task", "everted_check",
           "fit_all", "make_figure", "merge_points", "run_phase_diagram", "tasks_of"]

log = logging.getLogger("shells")

#: Caps closer to a closed sphere than this (θ > THETA_MAX) are left out of a diagram.
THETA_MAX = 0.9 * math.pi
#: The snapping line is fitted over caps up to a hemisphere: the paper derives it for θ ≤ π/2
#: (the rim's tangent plane horizontal at the snap); deeper caps bend the fold curve upwards.
SNAP_FIT_THETA_MAX_DEG = 90.0


# ------------------------------------------------------------------------------------------------
# configuration
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PhaseDiagramConfig:
    """One phase diagram (validated on construction).

    Attributes:
        h_over_r: thicknesses h/R.
        thetabar_range: (A, B), the θ̄ interval; ``points`` values evenly spaced in it per h/R
            (values with θ = θ̄ √(h/R) > 0.9 π are left out and listed as skipped).
        points: number of θ̄ values per h/R (1: θ̄ = A only).
        nu: Poisson ratio.
        model: "axisym" (default) or "surface" (2D, for spot checks).
        m_max: Fourier modes 0..m_max are checked (axisym).
        rel_tol: location accuracy of folds and bifurcations, relative in κ.
        cells, layer_cells: axisymmetric mesh (bulk cells, cells per √(Rh) at the rim).
        ds_max: largest continuation step (axisym: the weighted arclength of
            ``shells.continuation``).
        refine: bisection steps in θ̄ for θ̄_s per h/R (0: the bracket only).
        size, layer_elements: surface-model mesh.
    """

    h_over_r: tuple[float, ...]
    thetabar_range: tuple[float, float]
    points: int
    nu: float = 0.5
    model: str = "axisym"
    m_max: int = 12
    rel_tol: float = 1.0e-3
    cells: int = 200
    layer_cells: float = 8.0
    ds_max: float = 0.2
    refine: int = 3
    size: float = 0.1
    layer_elements: float = 4.0

    def __post_init__(self) -> None:
        hs = tuple(self.h_over_r)
        if not hs:
            raise InputError("give at least one h/R")
        for h in hs:
            if not (isinstance(h, (int, float)) and math.isfinite(h) and 0 < h < 1):
                raise InputError(f"h/R must lie in (0, 1), got {h!r}")
        object.__setattr__(self, "h_over_r", tuple(float(h) for h in hs))
        rng = tuple(self.thetabar_range)
        if len(rng) != 2 or not all(isinstance(v, (int, float)) and math.isfinite(v)
                                    for v in rng):
            raise InputError(f"the theta-bar range must be two numbers, got {rng!r}")
        a, b = (float(v) for v in rng)
        if not (0 < a <= b):
            raise InputError(f"the theta-bar range must satisfy 0 < A <= B, got {a:g} {b:g}")
        object.__setattr__(self, "thetabar_range", (a, b))
        if not (isinstance(self.points, int) and 1 <= self.points <= 10000):
            raise InputError(f"points must be an integer in [1, 10000], got {self.points!r}")
        if a == b and self.points != 1:
            raise InputError("a single theta-bar value (A = B) needs --points 1")
        if not (isinstance(self.nu, (int, float)) and -1.0 < self.nu <= 0.5):
            raise InputError(f"nu must lie in (-1, 0.5], got {self.nu!r}")
        if self.model not in ("axisym", "surface"):
            raise InputError(f"model must be 'axisym' or 'surface', got {self.model!r}")
        if not (isinstance(self.m_max, int) and 1 <= self.m_max <= 200):
            raise InputError(f"m_max must be an integer in [1, 200], got {self.m_max!r}")
        if not (0 < self.rel_tol < 0.1):
            raise InputError(f"rel_tol must lie in (0, 0.1), got {self.rel_tol!r}")
        if not (isinstance(self.cells, int) and 20 <= self.cells <= 20000):
            raise InputError(f"cells must be an integer in [20, 20000], got {self.cells!r}")
        for name in ("layer_cells", "ds_max", "size", "layer_elements"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise InputError(f"{name} must be positive, got {v!r}")
        if not (isinstance(self.refine, int) and 0 <= self.refine <= 20):
            raise InputError(f"refine must be an integer in [0, 20], got {self.refine!r}")
        if any(t > THETA_MAX for h in self.h_over_r for t in [a * math.sqrt(h)]):
            raise InputError(f"theta-bar {a:g} gives an opening angle above 0.9 pi for some h/R: "
                             "lower A")

    def thetabars(self) -> list[float]:
        a, b = self.thetabar_range
        return [float(v) for v in np.linspace(a, b, self.points)]

    def numerics(self) -> dict[str, Any]:
        """What a computed task depends on besides (h/R, θ̄, direction): the rerun key."""
        if self.model == "axisym":
            return {"model": "axisym", "nu": self.nu, "m_max": self.m_max,
                    "rel_tol": self.rel_tol, "cells": self.cells,
                    "layer_cells": self.layer_cells, "ds_max": self.ds_max,
                    # the inertia is computed at every branch point (the key stays in the
                    # records: it was a setting, 2, of earlier runs)
                    "check_every": 1, "locator": "critical.follow"}
        return {"model": "surface", "nu": self.nu, "rel_tol": self.rel_tol, "size": self.size,
                "layer_elements": self.layer_elements}

    def signature(self) -> str:
        return hashlib.sha1(json.dumps(self.numerics(), sort_keys=True).encode()).hexdigest()[:12]

    def describe(self) -> dict[str, Any]:
        d = asdict(self)
        d["signature"] = self.signature()
        return d


@dataclass(frozen=True)
class Task:
    """One branch to follow: (h/R, θ̄, direction)."""

    h_over_r: float
    thetabar: float
    direction: str
    tag: str = "grid"

    def __post_init__(self) -> None:
        if self.direction not in ("up", "down"):
            raise InputError(f"direction must be 'up' or 'down', got {self.direction!r}")

    @property
    def theta(self) -> float:
        return self.thetabar * math.sqrt(self.h_over_r)

    def key(self, signature: str) -> str:
        return f"{signature}|h={self.h_over_r:.8g}|tb={self.thetabar:.8g}|{self.direction}"

    def cost(self) -> float:
        """A rough cost estimate (deep caps going up are the expensive ones)."""
        return (2.0 + self.thetabar) if self.direction == "up" else 1.0 + 0.2 * self.thetabar


def tasks_of(cfg: PhaseDiagramConfig) -> tuple[list[Task], list[dict[str, float]]]:
    """The grid's tasks (most expensive first) and the skipped (h/R, θ̄) (θ > 0.9 π)."""
    tasks, skipped = [], []
    for h in cfg.h_over_r:
        for tb in cfg.thetabars():
            if tb * math.sqrt(h) > THETA_MAX:
                skipped.append({"h_over_R": h, "thetabar": tb})
                continue
            tasks += [Task(h, tb, "up"), Task(h, tb, "down")]
    tasks.sort(key=lambda t: -t.cost())
    return tasks, skipped


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


class _Branch:
    """Model and Newton solver of one axisymmetric run, and the curvatures of its state."""

    def __init__(self, theta: float, h_over_r: float, nu: float, cfg: PhaseDiagramConfig
                 ) -> None:
        from shells.axisym import AxisymModel, AxisymParameters
        from shells.geometry import SphericalCap
        from shells.solvers import NewtonSolver

        self.shape = SphericalCap(1.0, theta)
        self.model = AxisymModel(self.shape, AxisymParameters(
            h=h_over_r, nu=nu, cells=cfg.cells, layer_cells=cfg.layer_cells))
        self.ns = NewtonSolver(self.model, options={"snes_rtol": 1e-9, "snes_atol": 1e-11,
                                                    "snes_stol": 1e-12, "snes_max_it": 30})
        self.modes = list(range(cfg.m_max + 1))
        self.model.modes = tuple(self.modes)
        self.curv = _Curvatures(self.model)
        self.settings = _settings(h_over_r, cfg, self.shape)

    def follow(self, kappa_end: float, crit: Any, **kw: Any) -> Iterator[tuple]:
        """``critical.follow`` from κ = 0 to ``kappa_end`` (R = 1: κ = κR), all m checked."""
        from shells.critical import follow

        return follow(self.model, self.settings, kappa_end, crit, solver=self.ns,
                      blocks=self.modes, **kw)

    def curvatures_at(self, cp: Any) -> dict[str, float]:
        """The curvatures of a critical point's state (the model's state is kept)."""
        from shells.problem import get_state, set_state

        keep = get_state(self.model)
        set_state(self.model, cp.state)
        try:
            return self.curv()
        finally:
            set_state(self.model, keep)

    def destroy(self) -> None:
        self.ns.destroy()


def _settings(h_over_r: float, cfg: PhaseDiagramConfig, shape: Any) -> Any:
    from shells.axisym import default_settings

    return default_settings(shape, h_over_r, ds_max=cfg.ds_max, max_steps=3000)


def _bifurcation_record(br: _Branch, cp: Any, step_modes: list[int]) -> dict[str, Any]:
    return {"kappa_R": cp.kappa, "bracket": [cp.kappa_lo, cp.kappa_hi], "mode_m": cp.mode_m,
            "modes": [cp.mode_m], "modes_at_step_end": step_modes, "accuracy": cp.accuracy,
            **br.curvatures_at(cp)}


def _trace_axisym(task: Task, cfg: PhaseDiagramConfig) -> dict[str, Any]:
    """Follow one branch; returns its first critical point, the fold and the first bifurcation.

    Going down the first bifurcation ends the run; going up the branch is followed past its
    first bifurcation (folds only) up to the snap fold, unless the cap is inverted (pole
    curvature b11 R > 0) there: a smoothly inverting cap has no fold to look for."""
    from shells.critical import CriticalSettings

    h = task.h_over_r
    tb = task.thetabar
    sign = 1.0 if task.direction == "up" else -1.0
    if task.direction == "up":
        bound = 1.6 * max(snap_kappa_R(tb), mirrored_buckling_kappa_R(tb, h), 1.0) + 0.5
    else:
        bound = 2.5 * max(-buckling_kappa_R(tb, h), 1.0) + 1.0
    br = _Branch(task.theta, h, cfg.nu, cfg)
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

    from shells.continuation import ContinuationSettings
    from shells.critical import CriticalSettings, follow
    from shells.geometry import SphericalCap
    from shells.mesh import MeshSpec, generate
    from shells.model import ModelParameters, ShellModel

    h, tb = task.h_over_r, task.thetabar
    shape = SphericalCap(1.0, task.theta)
    sm = generate(MeshSpec(shape, h=h, size=cfg.size, layer_elements=cfg.layer_elements),
                  MPI.COMM_SELF)
    model = ShellModel(sm, ModelParameters(h=h, nu=cfg.nu))
    if task.direction == "up":
        bound = 1.3 * max(snap_kappa_R(tb), mirrored_buckling_kappa_R(tb, h), 1.0) + 0.3
    else:
        bound = -(1.3 * min(buckling_kappa_R(tb, h), -1.0) - 0.3)
    sign = 1.0 if task.direction == "up" else -1.0
    st = ContinuationSettings(ds=bound / 16, ds_max=bound / 10, ds_min=1e-7 * bound,
                              ds_unit="kappa")
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
    """Follow one branch and return its JSON record (``status`` "ok" or "failed")."""
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
    """Follow the up-branch through the snap fold and its second fold onto the everted branch and
    locate the loss of symmetry there (first count change after the branch is stable again):
    checks κ_e R = 2 - κ_b R (mirror symmetry) directly. Costly for deep caps."""
    from shells.critical import CriticalSettings

    task = Task(h_over_r, thetabar, "up", tag="everted")
    bound = kappa_max or 2.0 - 1.5 * buckling_kappa_R(thetabar, h_over_r) + 1.0
    br = _Branch(task.theta, h_over_r, cfg.nu, cfg)
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


# ------------------------------------------------------------------------------------------------
# the points file, claims and the parallel driver
# ------------------------------------------------------------------------------------------------
def _record_key(rec: dict[str, Any], signature: str) -> str:
    return Task(rec["h_over_R"], rec["thetabar"], rec["direction"]).key(signature)


@dataclass
class RunStats:
    """What a run did (summed over ranks by ``run_phase_diagram``)."""

    computed: int = 0
    skipped_done: int = 0
    wall_time: float = 0.0
    per_rank: list[int] = field(default_factory=list)


def _run_tasks(tasks: list[Task], cfg: PhaseDiagramConfig, outdir: Path, comm: Any,
               limit: int | None, progress: Callable[[str], None]) -> int:
    """Compute the tasks not yet in the points file, claimed dynamically; returns how many this
    rank computed."""
    sig = cfg.signature()
    points = outdir / "points.jsonl"
    if comm.rank == 0:
        done = {_record_key(r, sig) for r in read_records(points)
                if r.get("status") == "ok" and r.get("signature", sig) == sig}
        run_id = uuid.uuid4().hex[:12]
        claims = outdir / ".claims" / run_id
        claims.mkdir(parents=True, exist_ok=True)
    else:
        done, run_id = None, None
    done, run_id = comm.bcast((done, run_id), root=0)
    claims = outdir / ".claims" / run_id
    todo = [t for t in tasks if t.key(sig) not in done]
    mine = 0
    seen = base = len(read_records(points)) if comm.rank == 0 else 0
    total = len(todo) + len(done)
    for i, t in enumerate(todo):
        if limit is not None and mine >= limit:
            break
        try:
            fd = os.open(claims / f"{i:06d}", os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            continue
        os.close(fd)
        rec = compute_task(t, cfg)
        rec["signature"] = sig
        rec["rank"] = comm.rank
        append_record(points, rec)
        mine += 1
        if comm.rank == 0:  # progress: everything in the file so far (all ranks)
            recs = read_records(points)
            for k, r in enumerate(recs[seen:], start=seen + 1):
                progress(_progress_line(r, len(done) + k - base, total))
            seen = len(recs)
    comm.Barrier()
    if comm.rank == 0:
        recs = read_records(points)
        for k, r in enumerate(recs[seen:], start=seen + 1):
            progress(_progress_line(r, len(done) + k - base, total))
        for f in claims.iterdir():
            f.unlink()
        claims.rmdir()
    return mine


def _progress_line(r: dict[str, Any], k: int, n: int) -> str:
    f = r.get("first") or {}
    what = (f"{f.get('kind')} at kappa R = {f['kappa_R']:+.4f} (m = {f.get('mode_m')})"
            if f.get("kappa_R") is not None else r.get("error", f.get("kind", "?")))
    return (f"[{k}/{n}] h/R = {r['h_over_R']:g}, thetabar = {r['thetabar']:.3f}, "
            f"{r['direction']:>4}: {what}  (rank {r.get('rank')}, {r['wall_time']:.1f} s)")


def run_phase_diagram(cfg: PhaseDiagramConfig, outdir: str | Path, comm: Any = None,
                      limit: int | None = None, figure: bool = True,
                      progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Compute (or complete) a phase diagram in ``outdir``; returns the result on every rank.

    ``limit``: each rank computes at most this many new tasks in the grid phase (an interrupted
    run, for tests); the result then covers what exists. ``result["stats"]`` says how many tasks
    this run computed (summed over ranks).
    """
    from mpi4py import MPI

    comm = comm or MPI.COMM_WORLD
    out = Path(outdir)
    if comm.rank == 0:
        out.mkdir(parents=True, exist_ok=True)
    comm.Barrier()
    say = progress or (lambda s: log.info(s))
    t0 = time.perf_counter()
    tasks, skipped = tasks_of(cfg)
    mine = _run_tasks(tasks, cfg, out, comm, limit, say if comm.rank == 0 else lambda s: None)
    # θ̄_s by bisection: one h/R per rank, sequential steps, each step a recorded task
    refined = 0
    if cfg.refine and limit is None:
        grid = [r for r in _current(out, cfg) if r.get("tag") == "grid"]
        brackets = comm.bcast(_snap_brackets(grid) if comm.rank == 0 else None, root=0)
        for j, (h, lo, hi) in enumerate(brackets):
            if j % comm.size != comm.rank:
                continue
            refined += _bisect_snap(h, lo, hi, cfg, out, comm.rank)
    comm.Barrier()
    computed = comm.allreduce(mine + refined, op=MPI.SUM)
    per_rank = comm.allgather(mine + refined)
    result = None
    if comm.rank == 0:
        recs = _current(out, cfg)
        points = merge_points(recs)
        fits = fit_all(points, cfg.nu)
        result = {"fits": fits["fits"], "fits_error": fits["fits_error"],
                  "fits_extra": fits["extra"], "points": points, "skipped": skipped,
                  "config": cfg.describe(), "points_file": str(out / "points.jsonl"),
                  "paper": {k: PAPER[k] for k in ("alpha", "beta", "b", "c", "thetabar_s",
                                                  "thetabar_c")},
                  "stats": asdict(RunStats(computed=computed, wall_time=time.perf_counter() - t0,
                                           per_rank=per_rank))}
        if figure:
            result["figures"] = make_figure(result, out / "phase_diagram")
        (out / "phase_diagram.json").write_text(json.dumps(result, indent=1,
                                                           default=json_default))
    return comm.bcast(result, root=0)


def _current(out: Path, cfg: PhaseDiagramConfig) -> list[dict[str, Any]]:
    """Records of this configuration (same numerics), last one per task."""
    sig = cfg.signature()
    hs = set(cfg.h_over_r)
    a, b = cfg.thetabar_range
    keep: dict[str, dict[str, Any]] = {}
    for r in read_records(out / "points.jsonl"):
        if r.get("signature") != sig or r.get("status") != "ok":
            continue
        if r["h_over_R"] not in hs or not (a - 1e-9 <= r["thetabar"] <= b + 1e-9):
            continue
        keep[_record_key(r, sig)] = r
    return list(keep.values())


def _snaps(rec: dict[str, Any]) -> bool:
    return rec.get("fold") is not None


def _snap_brackets(recs: list[dict[str, Any]]) -> list[tuple[float, float, float]]:
    """Per h/R: (h, θ̄ of the last no-snap point, θ̄ of the first snap point) if both exist."""
    out = []
    for h in sorted({r["h_over_R"] for r in recs}):
        ups = sorted((r for r in recs if r["h_over_R"] == h and r["direction"] == "up"),
                     key=lambda r: r["thetabar"])
        first = next((i for i, r in enumerate(ups) if _snaps(r)), None)
        if first is not None and first > 0:
            out.append((h, ups[first - 1]["thetabar"], ups[first]["thetabar"]))
    return out


def _bisect_snap(h: float, lo: float, hi: float, cfg: PhaseDiagramConfig, out: Path,
                 rank: int) -> int:
    sig = cfg.signature()
    done = {_record_key(r, sig): r for r in read_records(out / "points.jsonl")
            if r.get("signature") == sig and r.get("status") == "ok"}
    n = 0
    for _ in range(cfg.refine):
        mid = 0.5 * (lo + hi)
        t = Task(h, mid, "up", tag="refine")
        rec = done.get(t.key(sig))
        if rec is None:
            rec = compute_task(t, cfg)
            rec.update(signature=sig, rank=rank)
            append_record(out / "points.jsonl", rec)
            n += 1
        if rec.get("status") != "ok":
            break
        lo, hi = (lo, mid) if _snaps(rec) else (mid, hi)
    return n


# ------------------------------------------------------------------------------------------------
# merged points and fits
# ------------------------------------------------------------------------------------------------
def merge_points(recs: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One entry per (h/R, θ̄) with the up and down results and the derived phase data.

    ``up_kind``: "snap" (the fold first), "bifurcation" (loss of symmetry before the fold),
    "inversion" (no fold: smooth inversion, then loss of symmetry of the inverted shell) or
    "none"; ``kappa_everted_R`` = 2 - ``kappa_down_R`` (mirror symmetry), the loss of symmetry of
    the everted branch; ``everted_symmetric``: the snap lands on a stable symmetric everted
    shell (κ_s < κ_e).
    """
    by: dict[tuple[float, float], dict[str, Any]] = {}
    for r in recs:
        k = (r["h_over_R"], round(r["thetabar"], 9))
        by.setdefault(k, {})[r["direction"]] = r
    pts = []
    for (h, tb), d in sorted(by.items()):
        up, down = d.get("up"), d.get("down")
        p: dict[str, Any] = {"h_over_R": h, "thetabar": tb, "theta_deg": math.degrees(
            tb * math.sqrt(h)), "tag": (up or down or {}).get("tag", "grid")}
        if up is not None:
            fold, bif = up.get("fold"), up.get("bifurcation")
            if fold is None:
                kind = "inversion" if bif is not None else "none"
            else:
                kind = "bifurcation" if up["first"]["kind"] == "bifurcation" else "snap"
            p.update(up_kind=kind, kappa_up_R=up["first"]["kappa_R"],
                     mode_up=up["first"]["mode_m"],
                     kappa_snap_R=fold["kappa_R"] if fold else None,
                     kappa_bif_up_R=bif["kappa_R"] if bif else None,
                     mode_bif_up=bif["mode_m"] if bif else None,
                     b11_rim_snap_R=(fold or {}).get("b11_rim_R"),
                     b22_rim_snap_R=(fold or {}).get("b22_rim_R"),
                     b11_pole_snap_R=(fold or {}).get("b11_pole_R"))
        if down is not None:
            bif = down.get("bifurcation")
            p.update(kappa_down_R=bif["kappa_R"] if bif else None,
                     mode_down=bif["mode_m"] if bif else None)
            if bif:
                p.update(kappa_everted_R=2.0 - bif["kappa_R"], mode_everted=bif["mode_m"])
        ks, ke = p.get("kappa_snap_R"), p.get("kappa_everted_R")
        if ks is not None and ke is not None:
            p["everted_symmetric"] = ks < ke
        pts.append(p)
    return pts


def _lstsq(X: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Least squares with standard errors s² (XᵀX)⁻¹ (s² = RSS/(n-p)); also the RMS residual."""
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    r = y - X @ coef
    n, k = X.shape
    s2 = float(r @ r) / (n - k) if n > k else math.nan
    cov = s2 * np.linalg.inv(X.T @ X)
    return coef, cov, float(np.sqrt(np.mean(r**2)))


def _fit_snap(pts: list[dict[str, Any]]) -> dict[str, Any] | None:
    s = [(p["thetabar"], p["kappa_snap_R"]) for p in pts if p.get("kappa_snap_R") is not None]
    if len(s) < 3:
        return None
    tb, k = np.array(s).T
    coef, cov, rms = _lstsq(np.column_stack([tb, -np.ones_like(tb)]), k)
    return {"beta": coef[0], "alpha": coef[1], "beta_err": math.sqrt(cov[0, 0]),
            "alpha_err": math.sqrt(cov[1, 1]), "cov": cov.tolist(), "n": len(tb), "rms": rms,
            "thetabar_range": [float(tb.min()), float(tb.max())]}


def _fit_buckling(pts: list[dict[str, Any]], key: str = "kappa_down_R",
                  mirrored: bool = False) -> dict[str, Any] | None:
    """b, c of Eq. (4) (κ < 0 points; ``mirrored``: 2 - κ for the everted line)."""
    rows = [(p["thetabar"], p["h_over_R"], p[key]) for p in pts if p.get(key) is not None]
    if len(rows) < 3:
        return None
    tb, h, k = np.array(rows).T
    if mirrored:
        k = 2.0 - k
    y = k + plate_a() / tb**2 - 1.0
    X = np.column_stack([1.0 / (tb - math.pi / np.sqrt(h)), np.ones_like(tb)])
    coef, cov, rms = _lstsq(X, y)
    return {"b": coef[0], "c": coef[1], "b_err": math.sqrt(cov[0, 0]),
            "c_err": math.sqrt(cov[1, 1]), "cov": cov.tolist(), "n": len(tb), "rms": rms}


def _crossing(x: np.ndarray, d: np.ndarray) -> float | None:
    """First x where d changes sign from negative to non-negative (linear interpolation)."""
    for i in range(1, len(x)):
        if d[i - 1] < 0 <= d[i]:
            return float(x[i - 1] + (x[i] - x[i - 1]) * (-d[i - 1]) / (d[i] - d[i - 1]))
    return None


def _thetabar_c_from_lines(alpha: float, beta: float, b: float, c: float, h: float
                           ) -> float | None:
    """θ̄ where β θ̄ - α = 2 - κ_b(θ̄) (Eq. 4 with b, c), the paper's triple point."""
    from scipy.optimize import brentq

    f = lambda t: beta * t - alpha - mirrored_buckling_kappa_R(t, h, b, c)  # noqa: E731
    grid = np.linspace(1.0, min(30.0, 0.999 * math.pi / math.sqrt(h)), 400)
    vals = [f(t) for t in grid]
    for i in range(1, len(grid)):
        if vals[i - 1] < 0 <= vals[i]:
            return float(brentq(f, grid[i - 1], grid[i]))
    return None


def fit_all(points: list[dict[str, Any]], nu: float = 0.5) -> dict[str, Any]:
    """Fits of the paper's laws with standard errors.

    α, β: the snapping line over the folds of caps with θ ≤ 90° (the domain of the paper's
    argument; over all folds in ``extra["snap_fit_all_folds"]``); b, c: Eq. (4) over the κ < 0
    points; θ̄_s: per h/R the bracket between the last no-snap and the first snap θ̄, its midpoint
    (error: half its width), pooled: mean over h/R; θ̄_c: per h/R where the computed fold crosses
    the computed everted loss of symmetry 2 - κ_b, pooled: mean.
    """
    fits: dict[str, Any] = {k: None for k in ("alpha", "beta", "b", "c", "thetabar_s",
                                              "thetabar_c")}
    err: dict[str, Any] = dict(fits)
    extra: dict[str, Any] = {}
    snap = _fit_snap([p for p in points if math.degrees(p["thetabar"] * math.sqrt(
        p["h_over_R"])) <= SNAP_FIT_THETA_MAX_DEG])
    if snap:
        fits.update(alpha=snap["alpha"], beta=snap["beta"])
        err.update(alpha=snap["alpha_err"], beta=snap["beta_err"])
        extra["snap_fit"] = snap
    extra["snap_fit_all_folds"] = _fit_snap(points)
    buck = _fit_buckling(points)
    if buck:
        fits.update(b=buck["b"], c=buck["c"])
        err.update(b=buck["b_err"], c=buck["c_err"])
        extra["buckling_fit"] = buck
    hs = sorted({p["h_over_R"] for p in points})
    per_h: dict[str, Any] = {}
    s_vals, s_errs, c_vals = [], [], []
    for h in hs:
        ph = sorted((p for p in points if p["h_over_R"] == h and "up_kind" in p),
                    key=lambda p: p["thetabar"])
        e: dict[str, Any] = {}
        first = next((i for i, p in enumerate(ph) if p.get("kappa_snap_R") is not None), None)
        if first is not None and first > 0:
            lo, hi = ph[first - 1]["thetabar"], ph[first]["thetabar"]
            e["thetabar_s_bracket"] = [lo, hi]
            e["thetabar_s"] = 0.5 * (lo + hi)
            s_vals.append(0.5 * (lo + hi))
            s_errs.append(0.5 * (hi - lo))
        both = [p for p in ph if p.get("kappa_snap_R") is not None
                and p.get("kappa_everted_R") is not None]
        if len(both) >= 2:
            x = np.array([p["thetabar"] for p in both])
            d = np.array([p["kappa_snap_R"] - p["kappa_everted_R"] for p in both])
            tc = _crossing(x, d)
            e["thetabar_c"] = tc
            if tc is not None:
                c_vals.append(tc)
        pre = next((p["thetabar"] for p in ph if p.get("up_kind") == "bifurcation"), None)
        e["thetabar_bifurcation_precedes_fold"] = pre
        e["snap_fit"] = _fit_snap(ph)
        pd = [p for p in points if p["h_over_R"] == h]
        e["buckling_fit"] = _fit_buckling(pd)
        e["everted_buckling_fit"] = _fit_buckling(pd, "kappa_everted_R", mirrored=True)
        if snap and buck:
            e["thetabar_c_from_fits"] = _thetabar_c_from_lines(snap["alpha"], snap["beta"],
                                                               buck["b"], buck["c"], h)
        e["thetabar_c_paper_lines"] = _thetabar_c_from_lines(
            PAPER["alpha"], PAPER["beta"], PAPER["b"], PAPER["c"], h)
        per_h[f"{h:g}"] = e
    if s_vals:
        fits["thetabar_s"] = float(np.mean(s_vals))
        spread = float(np.std(s_vals, ddof=1)) / math.sqrt(len(s_vals)) if len(s_vals) > 1 \
            else 0.0
        err["thetabar_s"] = float(math.hypot(max(s_errs), spread))
    if c_vals:
        fits["thetabar_c"] = float(np.mean(c_vals))
        spacing = max((np.diff(sorted({p["thetabar"] for p in points})) if len(points) > 1
                       else [0.0]), default=0.0)
        spread = float(np.std(c_vals, ddof=1)) / math.sqrt(len(c_vals)) if len(c_vals) > 1 \
            else 0.0
        # linear interpolation over one grid step: its error is a fraction of the step
        err["thetabar_c"] = float(math.hypot(0.25 * float(spacing), spread))
    extra["per_h_over_R"] = per_h
    # the rim's meridional curvature at the snap against the paper's (1 + ν)(-1/R + κ_s): the
    # proportionality factor (least squares through 0) and the relative differences where
    # (1 + ν)(κ_s R - 1) > 0.5 (near θ̄_s the snap sits at κ_s R ≈ 1, where it vanishes)
    b11 = [(p["b11_rim_snap_R"], (1 + nu) * (-1.0 + p["kappa_snap_R"]), p["thetabar"])
           for p in points if p.get("b11_rim_snap_R") is not None]
    if b11:
        ours, law, _ = (np.array(v) for v in zip(*b11, strict=True))
        keep = law > 0.5
        rel = ours[keep] / law[keep] - 1
        extra["b11_rim_at_snap"] = {
            "n": int(len(ours)), "factor": float(ours @ law / (law @ law)),
            "n_compared": int(keep.sum()),
            "median_rel_diff": float(np.median(rel)) if rel.size else None,
            "max_abs_rel_diff": float(np.max(np.abs(rel))) if rel.size else None}
    return {"fits": fits, "fits_error": err, "extra": extra}


# ------------------------------------------------------------------------------------------------
# the figure
# ------------------------------------------------------------------------------------------------
def _shade_computed(ax: Any, pts: list[dict[str, Any]], ylo: float, yhi: float) -> None:
    """Shade the phases as computed: each computed θ̄ colours the band halfway to its neighbours.
    Blue (broken symmetry) below the κ < 0 loss of symmetry; white (symmetric, original
    orientation) up to the first instability going up (the snap, the loss of symmetry before
    the fold, or κR = 1 for a smooth inversion); then, where the shell is symmetric and everted
    (after a snap or an inversion), green up to its loss of symmetry (the everted branch's
    computed one, else the mirror 2 - κ_b of the κ < 0 one), and blue above. Points computed in
    one direction only (the θ̄_s bisection's) take no band: their neighbours' bands cover them."""
    blue, green = "#bcd3ee", "#c9e8c0"
    pts = sorted((p for p in pts if p.get("up_kind") is not None
                  and p.get("kappa_down_R") is not None), key=lambda p: p["thetabar"])
    tbs = [p["thetabar"] for p in pts]
    for i, p in enumerate(pts):
        lo = 0.5 * (tbs[i - 1] + tbs[i]) if i > 0 else max(0.0, tbs[0] - 0.5 * (
            tbs[1] - tbs[0]) if len(tbs) > 1 else tbs[0] - 0.5)
        hi = 0.5 * (tbs[i] + tbs[i + 1]) if i + 1 < len(tbs) else tbs[i] + 0.5 * (
            tbs[i] - tbs[i - 1] if i > 0 else 1.0)
        band = [lo, hi]

        def fill(y0: float | None, y1: float | None, color: str, band: list = band) -> None:
            if y0 is not None and y1 is not None and y1 > y0:
                ax.fill_between(band, y0, y1, color=color, lw=0)

        down = p.get("kappa_down_R")
        fill(ylo, down, blue)
        kind = p["up_kind"]
        top = {"snap": p.get("kappa_snap_R"), "bifurcation": p.get("kappa_bif_up_R"),
               "inversion": 1.0}.get(kind)
        if kind == "bifurcation":
            fill(top, yhi, blue)
            continue
        ev = p.get("kappa_everted_R") if kind == "snap" else p.get("kappa_up_R")
        if ev is None and down is not None:
            ev = 2.0 - down
        fill(top, ev, green)
        fill(ev if ev is not None else None, yhi, blue)


def make_figure(result: dict[str, Any], stem: Path) -> list[str]:
    """The phase diagram in the paper's style: θ̄ horizontal, κR vertical, phases shaded from
    the computed transitions (``_shade_computed``, the smallest h/R), computed points, the
    fitted lines solid and the paper's dashed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pts = result["points"]
    fits = result["fits"]
    hs = sorted({p["h_over_R"] for p in pts}) or [0.01]
    h0 = hs[0]
    tb_hi = max([p["thetabar"] for p in pts] + [5.0])
    x = np.linspace(0.5, tb_hi * 1.02, 600)
    x = x[x < 0.98 * math.pi / math.sqrt(h0)]
    al = fits.get("alpha") or PAPER["alpha"]
    be = fits.get("beta") or PAPER["beta"]
    b = fits.get("b") or PAPER["b"]
    c = fits.get("c") or PAPER["c"]
    ts = fits.get("thetabar_s") or PAPER["thetabar_s"]
    down = np.array([buckling_kappa_R(t, h0, b, c) for t in x])
    mirror = 2.0 - down
    ylo = min(-6.0, float(np.nanmin([p.get("kappa_down_R") or 0 for p in pts] + [0])) - 0.5)
    yhi = max(8.0, 1.1 * float(np.nanmax([p.get("kappa_snap_R") or 0 for p in pts] + [0])))
    fig, ax = plt.subplots(figsize=(7.5, 7.2))
    _shade_computed(ax, [p for p in pts if p["h_over_R"] == h0], ylo, yhi)
    ax.plot(x, down, "k-", lw=1.2, label="fits: Eq. (4), mirrored, snap line")
    ax.plot(x, mirror, "k-", lw=1.2)
    xs = x[x >= ts]
    ax.plot(xs, be * xs - al, "k-", lw=1.2)
    pd = np.array([buckling_kappa_R(t, h0) for t in x])
    ax.plot(x, pd, "--", color="0.4", lw=1.0, label="paper")
    ax.plot(x, 2.0 - pd, "--", color="0.4", lw=1.0)
    xs = x[x >= PAPER["thetabar_s"]]
    ax.plot(xs, snap_kappa_R(xs), "--", color="0.4", lw=1.0)
    xp = x[x > 1.2]
    ax.plot(xp, 1.0 + plate_a() / xp**2, ":", color="0.5", lw=1.0, label="plate limit")
    ax.plot(xp, 1.0 - plate_a() / xp**2, ":", color="0.5", lw=1.0)
    colors = plt.cm.viridis(np.linspace(0.0, 0.8, len(hs)))
    for h, col in zip(hs, colors, strict=True):
        ph = [p for p in pts if p["h_over_R"] == h]
        sel = lambda key, cond=lambda p: True: [(p["thetabar"], p[key]) for p in ph  # noqa
                                                 if p.get(key) is not None and cond(p)]
        for key, mk, cond, lab in (
                ("kappa_down_R", "v", lambda p: True, "loss of symmetry, kappa < 0"),
                ("kappa_snap_R", "o", lambda p: p.get("up_kind") == "snap", "snap (fold)"),
                ("kappa_snap_R", "s", lambda p: p.get("up_kind") == "bifurcation",
                 "fold preceded by loss of symmetry"),
                ("kappa_bif_up_R", "x", lambda p: p.get("up_kind") == "bifurcation",
                 "loss of symmetry before the fold"),
                ("kappa_up_R", "^", lambda p: p.get("up_kind") == "inversion",
                 "smooth inversion, then loss of symmetry"),
                ("kappa_everted_R", "D", lambda p: p.get("kappa_snap_R") is not None,
                 "everted loss of symmetry (2 - kappa_b)")):
            xy = sel(key, cond)
            if xy:
                xx, yy = zip(*xy, strict=True)
                ax.plot(xx, yy, mk, ms=4.5, mfc="none" if mk not in "x" else col, mec=col,
                        color=col, label=f"{lab}, h/R = {h:g}")
    ax.set_xlim(0, x[-1])
    ax.set_ylim(ylo, yhi)
    ax.axhline(0, color="0.6", lw=0.5)
    ax.set_xlabel(r"$\bar\theta = \theta/\sqrt{h/R}$")
    ax.set_ylabel(r"$\kappa R$")
    ax.set_title(f"Curvature-induced instabilities of open caps (shaded from the computed "
                 f"transitions, h/R = {h0:g}; lines: fits)", fontsize=9)
    ax.legend(fontsize=6.5, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2,
              frameon=False)
    fig.tight_layout()
    files = []
    for ext in ("png", "pdf"):
        f = f"{stem}.{ext}"
        fig.savefig(f, dpi=150)
        files.append(f)
    plt.close(fig)
    return files
