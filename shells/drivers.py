"""The runs behind ``shells branch``, ``shells critical`` and ``shells postbuckle`` (driver layer):
which problem to build, the files a run writes, the result dict its subcommand prints.

Every function takes plain typed arguments (a shape, numbers, a folder, a library config), never
an argparse namespace, and returns the JSON-serialisable result of the subcommand:

* ``branch_surface(cfg, outdir, ...)``, ``branch_axisym(shape, ...)``: the branch in κ from 0
  (``DIR/branch.jsonl``); ``folds(points)``: its turning points;
* ``critical_run(shape, ...)``: the critical points of the fundamental branch, either model
  (``DIR/critical.json``); ``critical_surface(shape, ...)`` the surface model's
  (``DIR/branch.jsonl``, a rerun resuming from ``DIR/checkpoint/``, the first critical mode in
  ``DIR/modes.bp``; the 1D model's runs in seconds and computes again);
* ``postbuckle_run(cfg, outdir, fields)``: ``shells.postbuckle.run_postbuckle`` with the
  bifurcated states written for ParaView (``ShapeWriter``).

The command line (``shells.cli``) only parses, calls these and prints.
"""

from __future__ import annotations

import json
import logging
import math
import os
import time
from pathlib import Path
from typing import Any

from shells.errors import InputError
from shells.store import append_record, json_default, write_atomic, write_header

__all__ = ["ShapeWriter", "branch_axisym", "branch_surface", "critical_run", "critical_surface",
           "folds", "postbuckle_run"]

log = logging.getLogger("shells")


def _rank() -> int:
    from mpi4py import MPI

    return MPI.COMM_WORLD.rank


def _R_or_L(shape: Any) -> float:
    """The length of κR (``shells.geometry.kappa_length``)."""
    from shells.geometry import kappa_length

    return kappa_length(shape)


# --------------------------------------------------------------------------------------------
# branches
# --------------------------------------------------------------------------------------------
def folds(points: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The turning points in κ of a branch (dκ/ds changes sign): kappa_R, kappa_h, index."""
    return [{"kappa_R": p["kappa_R"], "kappa_h": p["kappa_h"], "index": p["index"]}
            for a, p in zip(points, points[1:], strict=False)
            if a["dkappa_ds"] * p["dkappa_ds"] < 0]


def branch_surface(cfg: Any, outdir: str | os.PathLike, *, fields: str = "none",
                   resume: bool = True) -> dict[str, Any]:
    """The surface model's branch (``shells.branch.run_branch`` on ``cfg``, a ``BranchConfig``),
    after the mesh-size check (before the run creates its folder)."""
    from shells import branch
    from shells.mesh import check_mesh_size

    if cfg.mesh_file is None:
        check_mesh_size(cfg.mesh_spec())
    points = list(branch.run_branch(cfg, outdir, fields=fields, resume=resume))
    end = cfg.kappa_end * cfg.R
    if points and abs(points[-1]["kappa_R"] - end) > 1e-12 * abs(end) \
            and len(points) <= cfg.continuation.max_steps:
        # the continuation gave up (the corrector failed down to the smallest step): the
        # branch beyond is not known; its points so far and the checkpoint are kept
        raise RuntimeError(f"the continuation stopped at kappa R = {points[-1]['kappa_R']:.6g} "
                           f"before the end of the range, kappa R = {end:.6g}: the corrector "
                           f"did not converge with steps down to {cfg.continuation.ds_min:g}; "
                           f"{len(points)} points are in {outdir}/branch.jsonl and the same "
                           "command resumes after the last")
    header, _ = branch.read_branch(f"{outdir}/branch.jsonl")
    return {"config": cfg.describe(), "dofs": header.get("dofs"),
            "branch_file": f"{outdir}/branch.jsonl", "points": points, "folds": folds(points)}


def branch_axisym(shape: Any, h_over_r: float, nu: float, kappa_R_end: float,
                  outdir: str | os.PathLike, kappa_field: Any = None) -> dict[str, Any]:
    """The shell-of-revolution model's branch up to κR = ``kappa_R_end`` (its sign: the
    direction) under the stimulus ``kappa_field`` (None: uniform), every point appended to
    ``outdir/branch.jsonl`` (rank 0) as computed."""
    from shells import axisym
    from shells.stimulus import UNIFORM

    kappa_field = UNIFORM if kappa_field is None else kappa_field

    outdir = Path(outdir)
    points = []
    # no checkpoint: a rerun computes the branch again (the 1D model takes seconds), the file
    # replaced atomically by its header, then each point appended whole and fsync'ed
    if _rank() == 0:
        outdir.mkdir(parents=True, exist_ok=True)
        write_header(outdir / "branch.jsonl", {
            "model": "axisym", "shape": shape.describe(), "h_over_r": h_over_r,
            "nu": nu, "kappa_R_end": kappa_R_end, **kappa_field.header_entry()})
    for i, p in enumerate(axisym.branch(shape, h_over_r, nu,
                                        direction="up" if kappa_R_end > 0 else "down",
                                        kappa_max=abs(kappa_R_end), kappa_field=kappa_field)):
        rec = {"index": i, **p}
        points.append(rec)
        if _rank() == 0:
            append_record(outdir / "branch.jsonl", rec)
    return {"model": "axisym", "branch_file": str(outdir / "branch.jsonl"), "points": points,
            "folds": folds(points)}


# --------------------------------------------------------------------------------------------
# critical points
# --------------------------------------------------------------------------------------------
def critical_run(shape: Any, h_over_r: float, nu: float, *, direction: str = "up",
                 model: str = "surface", kappa_end: float | None = None,
                 outdir: str | os.PathLike | None = None, kappa_field: Any = None,
                 **surface: Any) -> dict[str, Any]:
    """The critical points of the fundamental branch from κ = 0 towards ``kappa_end`` (None:
    ``shells.theory.default_kappa_range``; the 1D model then uses its own), with either model,
    under the stimulus ``kappa_field`` (a ``shells.stimulus.CurvatureField``; None: uniform);
    ``surface``: the keyword arguments of ``critical_surface``. Writes ``outdir/critical.json``
    (rank 0)."""
    from shells.stimulus import UNIFORM

    kappa_field = UNIFORM if kappa_field is None else kappa_field
    L = shape.characteristic_size()
    h = h_over_r * L
    R_or_L = _R_or_L(shape)
    user_range = kappa_end is not None
    if kappa_end is None:
        from shells.theory import default_kappa_range

        kappa_end = default_kappa_range(shape, h_over_r, nu, direction)
    theta_deg = math.degrees(shape.theta) if hasattr(shape, "theta") and not shape.closed \
        else None
    base = {"h_over_R": h_over_r, "nu": nu, "theta_deg": theta_deg,
            "model": model, "shape": shape.describe(), "direction": direction,
            "kappa_R_end": kappa_end * R_or_L, "kappa_h_end": kappa_end * h,
            **kappa_field.describe()}
    if model == "axisym":
        try:
            from shells import axisym
        except ImportError as e:
            raise InputError("--model axisym is not available in this installation") from e
        result = {**base, **axisym.critical(
            shape, h_over_r, nu, direction=direction,
            kappa_max=abs(kappa_end) * R_or_L if user_range else None,
            kappa_field=kappa_field)}
    elif model == "surface":
        result = {**base, **critical_surface(shape, h_over_r, nu, kappa_end, outdir=outdir,
                                             kappa_field=kappa_field, **surface)}
    else:
        raise InputError(f"--model must be surface or axisym, got {model!r}")
    if outdir and _rank() == 0:
        Path(outdir).mkdir(parents=True, exist_ok=True)
        write_atomic(Path(outdir) / "critical.json",
                     json.dumps(result, indent=1, default=json_default))
    return result


#: the folder of ``shells critical``'s checkpoint (surface model), beside its ``branch.jsonl``
CRITICAL_CHECKPOINT = "checkpoint"


#: ``ContinuationSettings.factor_reuse`` of the surface model's critical points: 3 LU
#: factorisations per arclength step instead of 5, the located points unchanged to 3e-11 (the
#: 30° cap's fold, the θ̄ = 5 cap's bifurcation; benchmarks/lu_per_step.py)
REUSE_SURFACE = 1.0e-5


def critical_surface(shape: Any, h_over_r: float, nu: float, kappa_end: float, *,
                     first_only: bool = False, size: float | None = None,
                     layer_elements: float = 4.0, shear_penalty: float = 1.0e3,
                     degree: int | None = None, ds: float | None = None,
                     ds_max: float | None = None,
                     outdir: str | os.PathLike | None = None,
                     kappa_field: Any = None, mesh_file: str | None = None,
                     resume: bool = True) -> dict[str, Any]:
    """The surface model's critical points up to ``kappa_end`` (``shells.critical.follow``):
    meshes ``shape`` (``size``, ``degree`` None: ``shells.model.default_discretisation``), or
    runs on the mesh in ``mesh_file`` (a user's, of ``shape``; ``size`` then unused),
    follows the branch in steps ``ds`` .. ``ds_max`` in κL (None: range/16, range/10), writes
    ``outdir/branch.jsonl`` (rank 0): a header (the run's configuration), every point as it is
    computed and every critical point as it is located ({"critical_point": {...}, "number":
    i}), and after each point a checkpoint (``outdir/checkpoint/``: the state there and at the
    point before, the next step, the negative count, and the first critical point's state and
    mode once located; ``shells.store.save_state_checkpoint``), and at the end the first
    critical mode to ``outdir/modes.bp``; returns the first critical point's kind, κ and mode,
    every critical point, the DOFs, the mesh and the wall time.

    A rerun with the same configuration (``resume``) resumes after the last checkpointed point
    (on any rank count): its points and critical points so far are kept as written, the next
    ones are the uninterrupted run's (``follow``'s ``resume``), and so is the result (timings
    aside). Another configuration, no points or a checkpoint that is missing, incomplete,
    unreadable or not of this file: the run starts afresh, with one log line; a corrupt line
    in the file is an ``InputError``."""
    from dataclasses import asdict

    from mpi4py import MPI

    from shells.continuation import ContinuationSettings
    from shells.critical import CriticalSettings, FollowResume, follow
    from shells.mesh import MeshSpec, generate, load_mesh
    from shells.model import ModelParameters, ShellModel, default_discretisation
    from shells.stimulus import UNIFORM
    from shells.store import load_state_checkpoint, resumable, save_state_checkpoint

    kappa_field = UNIFORM if kappa_field is None else kappa_field
    comm = MPI.COMM_WORLD
    L = shape.characteristic_size()
    h = h_over_r * L
    R_or_L = _R_or_L(shape)
    defaults = degree is None and size is None and mesh_file is None
    degree, size = default_discretisation(shape, h_over_r, degree, size, kappa_field, nu)
    lam_end = abs(kappa_end) * L
    ds = ds if ds is not None else lam_end / 16
    ds_max = ds_max if ds_max is not None else max(ds, lam_end / 10)
    if not ds >= 1e-7 * lam_end:
        raise InputError(f"--ds must be at least 1e-7 of the kappa range ({1e-7 * lam_end:.3g} "
                         f"in kappa L here), got {ds:g}")
    st = ContinuationSettings(ds=ds, ds_max=max(ds, ds_max), ds_min=1e-7 * lam_end,
                              factor_reuse=REUSE_SURFACE,
                              ds_unit="kappa")
    crit = CriticalSettings(stop_at_first=first_only)
    # everything that decides the run's numbers (a rerun resumes only under the same)
    same_run: dict[str, Any] = {
        "command": "critical", "model": "surface", "shape": shape.describe(),
        "h_over_r": h_over_r, "nu": nu, "kappa_end": kappa_end,
        "direction": "up" if kappa_end > 0 else "down", "first_only": first_only,
        "mesh": ({"size": size, "layer_elements": layer_elements} if mesh_file is None
                 else {"file": str(mesh_file)}),
        "degree": degree, "shear_penalty": shear_penalty,
        "continuation": {**st.describe(), "kappa_stops": list(st.kappa_stops)},
        "critical": asdict(crit), **kappa_field.describe()}
    out = Path(outdir) if outdir else None
    bfile = out / "branch.jsonl" if out is not None else None
    # the file a rerun resumes, read before any work (a corrupt line: an InputError)
    why, recs = (resumable(bfile, same_run, comm, resume=resume) if out is not None
                 else ("no output folder", []))
    sm = (load_mesh(mesh_file, comm) if mesh_file is not None else
          generate(MeshSpec(shape, h=h, size=size, layer_elements=layer_elements), comm))
    model = ShellModel(sm, ModelParameters(h=h, nu=nu, shear_penalty=shear_penalty,
                                           degree=degree, quadrature_degree=2 * degree,
                                           kappa_field=kappa_field))
    log.info("critical: %s, %d DOFs, following kappa up to kappa R = %.4f", shape.describe(),
             model.num_dofs(), kappa_end * R_or_L)
    header = {**same_run, "dofs": model.num_dofs()}
    cps: list[dict[str, Any]] = []
    start: FollowResume | None = None
    first_arrays: tuple[Any, Any] | None = None  # the first critical point's state and mode
    kept: list[dict[str, Any]] = []
    if out is not None:
        if why is None:
            got = load_state_checkpoint(out / CRITICAL_CHECKPOINT, model, ("w", "w_prev"))
            try:
                if got is None or got[0].get("header") != json.loads(
                        json.dumps(same_run, default=json_default)):
                    raise KeyError("none of this run")
                meta, states, _ = got
                start = FollowResume.from_scalars(meta["follow"], states["w"], states["w_prev"],
                                                  states.get("tangent"))
                kept = [r for r in recs
                        if r.get("index", math.inf) <= start.index
                        or r.get("critical_point", {}).get("after_point", math.inf) < start.index]
                cps = [r["critical_point"] for r in kept if "critical_point" in r]
                if (not any(r.get("index") == start.index for r in kept)
                        or len(cps) != start.found or (cps and "cp_state" not in states)):
                    raise KeyError("not of this file")
                if cps:
                    first_arrays = (states["cp_state"], states.get("cp_mode"))
            except (KeyError, TypeError, ValueError):
                why, start, kept, cps = ("its checkpoint is missing, incomplete, unreadable or "
                                         "not of this file"), None, [], []
        if start is not None:
            log.info("critical: resuming after point %d at kappa R = %.6g (%d critical "
                     "point(s) so far)", start.index, start.kappa * R_or_L, len(cps))
        elif why not in ("there is none", "--restart"):
            log.info("critical: not resuming from the existing branch file (%s); starting "
                     "afresh", why)
        if comm.rank == 0:
            # the kept records under the header, atomically (a torn last line is dropped)
            write_header(bfile, header, kept)
    tracked: list[FollowResume] = []
    t0 = time.perf_counter()
    last_kappa = None if start is None else start.kappa
    for p, res, found in follow(model, st, kappa_end, crit, resume=start,
                                track=None if out is None else tracked.append):
        last_kappa = p.kappa
        rec = {"index": p.index, "kappa_R": p.kappa * R_or_L, "kappa_h": p.kappa * h,
               "negative_count": res.negative_count, "dkappa_ds": p.dkappa_ds,
               "newton_its": p.newton_its, **p.scalars}
        if bfile is not None and comm.rank == 0:
            append_record(bfile, rec)  # one whole line, fsync'ed
        log.info("  kappa R = %+.5f  kappa h = %+.5f  negative = %d  (%.0f s)", rec["kappa_R"],
                 rec["kappa_h"], res.negative_count, time.perf_counter() - t0)
        for c in found:
            if first_arrays is None:
                first_arrays = (c.state, c.mode)
            d = c.as_dict()
            d.update(kappa_R=c.kappa * R_or_L, kappa_h=c.kappa * h,
                     kappa_R_bracket=[c.kappa_lo * R_or_L, c.kappa_hi * R_or_L],
                     locator_accuracy=d.get("accuracy"))
            if bfile is not None and comm.rank == 0:
                append_record(bfile, {"critical_point": d, "number": len(cps)})
            cps.append(d)
            log.info("  %s at kappa R = %.6f (kappa h = %.6f), m = %s, n = %s", c.kind,
                     d["kappa_R"], d["kappa_h"], c.mode_m, c.mode_n)
        if out is not None:
            # after the point's records: a kill leaves this checkpoint or the one before
            r = tracked.pop()
            arrays = {"w": r.state, "w_prev": r.state_prev}
            if r.tangent is not None:
                arrays["tangent"] = r.tangent
            if first_arrays is not None:
                arrays["cp_state"] = first_arrays[0]
                if first_arrays[1] is not None:
                    arrays["cp_mode"] = first_arrays[1]
            save_state_checkpoint(out / CRITICAL_CHECKPOINT, model, r.index, arrays,
                                  meta={"follow": r.scalars(), "header": same_run})
    stopped = bool(cps) and (crit.stop_at_first or (crit.stop_at_fold and any(
        c["kind"] == "fold" for c in cps)))
    if not stopped and (last_kappa is None
                        or abs(last_kappa * L - kappa_end * L) > 1e-9 * lam_end):
        # the continuation gave up short of the end: "none" beyond would be a false claim
        raise RuntimeError(f"the continuation stopped at kappa R = "
                           f"{None if last_kappa is None else last_kappa * R_or_L} before the "
                           f"end of the range, kappa R = {kappa_end * R_or_L:.6g}; critical "
                           "points beyond it are not known")
    first = cps[0] if cps else None
    if out is not None and first_arrays is not None and first_arrays[1] is not None:
        from shells.fields import write_modes

        write_modes(model, first_arrays[0], [first_arrays[1]], out / "modes.bp")
        log.info("critical mode (ParaView, ADIOS2 VTX Reader): %s", out / "modes.bp")
    return {"kind": first["kind"] if first else "none",
            "kappa_R": first["kappa_R"] if first else None,
            "kappa_h": first["kappa_h"] if first else None,
            "mode_m": first["mode_m"] if first else None,
            "mode_n": first["mode_n"] if first else None,
            "dofs": model.num_dofs(), "critical_points": cps,
            "discretisation_error": _discretisation_error(shape, defaults),
            "discretisation_note": _discretisation_note(shape, defaults),
            "mesh": ({"size": size, "layer_elements": layer_elements, "degree": degree}
                     if mesh_file is None else {"size": None, "layer_elements": None,
                                                "degree": degree, "user_mesh": True,
                                                "file": str(mesh_file),
                                                "cells": sm.num_cells()}),
            "wall_time": time.perf_counter() - t0}


def _discretisation_error(shape: Any, defaults: bool) -> float | None:
    """The relative error of κ that the surface model's discretisation is known to stay within:
    a closed sphere on its default mesh (``shells.model.SPHERE_DEFAULT_ERROR``); else None."""
    from shells.model import SPHERE_DEFAULT_ERROR

    sphere = shape.closed and shape.kind in ("sphere", "meridian")
    return SPHERE_DEFAULT_ERROR if sphere and defaults else None


def _discretisation_note(shape: Any, defaults: bool) -> str:
    """What a critical point's ``accuracy`` (``locator_accuracy``) covers, and what not."""
    known = _discretisation_error(shape, defaults)
    return ("accuracy / locator_accuracy: the locator's bracket on this mesh only, not the "
            "discretisation error; " + (
                f"the default sphere mesh keeps kappa within about {known:.1%} of the converged "
                "value (4.25 elements per wavelength of the critical degree)" if known else
                "that is not estimated here: refine --size, or compare with --model axisym"
                " on a shell of revolution"))


# --------------------------------------------------------------------------------------------
# post-buckling
# --------------------------------------------------------------------------------------------
class ShapeWriter:
    """Writes the requested bifurcated states while the model holds them (``all``), or the
    last one of each side at the end (``last``): 1D, a revolved surface (.vts) and the meridian
    (.csv); 2D, VTX fields (one .bp per side)."""

    def __init__(self, out: Path | None, fields: str, model_kind: str, h: float) -> None:
        self.out, self.fields, self.kind, self.h = out, fields, model_kind, h
        self.files: list[str] = []
        self.last: dict[int, tuple[Any, Any, dict[str, Any]]] = {}
        self.writers: dict[int, Any] = {}

    def __call__(self, model: Any, rec: dict[str, Any]) -> None:
        if self.out is None or self.fields == "none" or rec["branch"] != "bifurcated":
            return
        if self.fields == "all":
            self._write(model, rec)
        else:
            from shells.problem import get_state

            self.last[rec["side"]] = (model, get_state(model), dict(rec))

    def _write(self, model: Any, rec: dict[str, Any]) -> None:
        from mpi4py import MPI

        side = rec["side"]
        if self.kind == "axisym":
            if MPI.COMM_WORLD.rank != 0:
                return
            from shells.revolve import revolve, write_profile_csv, write_vts

            prof = model.meridian_profile()
            d = self.out / "shapes"
            d.mkdir(parents=True, exist_ok=True)
            stem = d / f"side{side:+d}_{rec['index']:03d}"
            self.files.append(write_vts(revolve(prof), str(stem) + ".vts"))
            write_profile_csv(prof, str(stem) + ".csv", self.h)
            self.files.append(str(stem) + ".csv")
            return
        from shells.fields import FieldWriter

        if side not in self.writers:
            path = self.out / f"fields_side{side:+d}.bp"
            self.writers[side] = FieldWriter(model, path)
            self.files.append(str(path))
        self.writers[side].write(float(rec["index"]))

    def close(self) -> None:
        from shells.problem import set_state

        for model, state, rec in self.last.values():
            set_state(model, state)
            self._write(model, rec)
        for w in self.writers.values():
            w.close()


def postbuckle_run(cfg: Any, outdir: str | os.PathLike | None = None,
                   fields: str = "none") -> dict[str, Any]:
    """``shells.postbuckle.run_postbuckle`` on ``cfg`` (a ``PostbuckleConfig``), the bifurcated
    states written for ParaView (``fields``: none, last, all; needs ``outdir``); returns the
    critical point, the points, the sides' summaries, the DOFs and the files written."""
    from shells.postbuckle import run_postbuckle

    out = Path(outdir) if outdir else None
    shapes = ShapeWriter(out, fields, cfg.model, cfg.h_over_r * cfg.shape.characteristic_size())
    try:
        recs = run_postbuckle(cfg, out, on_point=shapes)
    finally:
        shapes.close()
    cp = next(r["critical_point"] for r in recs if "critical_point" in r)
    points = [r for r in recs if "branch" in r]
    summary = recs[-1].get("summary", {})
    return {"config": cfg.describe(), "critical_point": cp, "points": points,
            "sides": summary.get("sides"), "dofs": summary.get("dofs"),
            "branch_file": str(out / "postbuckle.jsonl") if out else None,
            "files": shapes.files}
