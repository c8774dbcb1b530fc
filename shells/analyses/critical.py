"""The critical points of a shell's fundamental branch (analyses layer): ``run`` for either
model (``DIR/critical.json``), ``run_surface`` the surface model's run (``DIR/branch.jsonl``,
a rerun resuming from ``DIR/checkpoint/``, the first critical mode in ``DIR/modes.bp``); the 1D
model's is ``shells.analyses.axisym_runs.critical`` (it computes again in seconds).
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
from shells.files import append_record, json_default, write_atomic, write_header
from shells.geometry.shapes import kappa_length
from shells.parameters import check_model
from shells.progress import Progress

__all__ = ["CRITICAL_CHECKPOINT", "REUSE_SURFACE", "discretisation_error_of",
           "discretisation_note_of", "run", "run_surface"]

log = logging.getLogger("shells")


def run(shape: Any, h_over_r: float, nu: float, *, direction: str = "up",
                 model: str = "surface", kappa_end: float | None = None,
                 outdir: str | os.PathLike | None = None, kappa_field: Any = None,
                 first_only: bool = False, **surface: Any) -> dict[str, Any]:
    """The critical points of a shell's fundamental branch from κ = 0, with either model.

    Args:
        shape: the shell's reference shape.
        h_over_r: thickness over the shape's length scale.
        nu: Poisson's ratio.
        direction: "up" (κ > 0) or "down" (κ < 0).
        model: "surface" (2D) or "axisym" (1D).
        kappa_end: the end of the range, an absolute κ (None:
            ``shells.analyses.setup.default_kappa_range``; the 1D model then uses its own).
        outdir: the output folder: ``critical.json`` (rank 0) and, on the surface model,
            ``run_surface``'s files. None: nothing written.
        kappa_field: the stimulus, a ``shells.geometry.stimulus.CurvatureField`` (None:
            uniform).
        first_only: stop at the first critical point (either model).
        **surface: the keyword arguments of ``run_surface``.

    Returns:
        The run's parameters and the result of ``run_surface`` or
        ``shells.analyses.axisym_runs.critical``.

    Raises:
        InputError: a parameter out of range.
        RuntimeError: the continuation stopped before the end of the range.
    """
    from shells.geometry.stimulus import UNIFORM

    check_model(model)
    kappa_field = UNIFORM if kappa_field is None else kappa_field
    L = shape.characteristic_size()
    h = h_over_r * L
    R_or_L = kappa_length(shape)
    user_range = kappa_end is not None
    if kappa_end is None:
        from shells.analyses.setup import default_kappa_range

        kappa_end = default_kappa_range(shape, h_over_r, nu, direction)
    theta_deg = math.degrees(shape.theta) if hasattr(shape, "theta") and not shape.closed \
        else None
    base = {"h_over_R": h_over_r, "nu": nu, "theta_deg": theta_deg,
            "model": model, "shape": shape.describe(), "direction": direction,
            "kappa_R_end": kappa_end * R_or_L, "kappa_h_end": kappa_end * h,
            **kappa_field.describe()}
    if model == "axisym":
        from shells.analyses import axisym_runs

        result = {**base, **axisym_runs.critical(
            shape, h_over_r, nu, direction=direction,
            kappa_max=abs(kappa_end) * R_or_L if user_range else None,
            kappa_field=kappa_field, **({"max_critical": 1} if first_only else {}))}
    else:
        result = {**base, **run_surface(shape, h_over_r, nu, kappa_end, outdir=outdir,
                                        kappa_field=kappa_field, first_only=first_only,
                                        **surface)}
    if outdir and _rank() == 0:
        Path(outdir).mkdir(parents=True, exist_ok=True)
        write_atomic(Path(outdir) / "critical.json",
                     json.dumps(result, indent=1, default=json_default))
    return result


#: the folder of ``shells critical``'s checkpoint (surface model), beside its ``branch.jsonl``
CRITICAL_CHECKPOINT = "checkpoint"


#: ``ContinuationSettings.factor_reuse`` of the surface model's critical points: fewer LU
#: factorisations per arclength step, the located points unchanged (docs/design-notes.md,
#: "Chord steps"; benchmarks/lu_per_step.py)
REUSE_SURFACE = 1.0e-5


def run_surface(shape: Any, h_over_r: float, nu: float, kappa_end: float, *,
                     first_only: bool = False, size: float | None = None,
                     layer_elements: float = 4.0, shear_penalty: float = 1.0e3,
                     degree: int | None = None, ds: float | None = None,
                     ds_max: float | None = None,
                     outdir: str | os.PathLike | None = None,
                     kappa_field: Any = None, mesh_file: str | None = None,
                     resume: bool = True) -> dict[str, Any]:
    """The surface model's critical points up to ``kappa_end`` (``follow``), resumable.

    Writes ``outdir/branch.jsonl`` (rank 0): a header (the run's configuration), every point
    as it is computed and every critical point as it is located ({"critical_point": {...},
    "number": i}); after each point a checkpoint (``outdir/checkpoint/``: the state there and
    at the point before, the next step, the negative counts, and the first critical point's
    state and mode once located); at the end the first critical mode to ``outdir/modes.bp``.
    A rerun with the same configuration (``resume``) resumes after the last checkpointed point
    (on any rank count): the points and critical points so far are kept as written, the next
    ones and the result are the uninterrupted run's (``follow``'s ``resume``). Another
    configuration, no points, or an unusable checkpoint: the run starts afresh, with one log
    line.

    Args:
        shape: the shell's reference shape.
        h_over_r: thickness over the shape's length scale.
        nu: Poisson's ratio.
        kappa_end: the end of the range, an absolute κ (its sign: the direction).
        first_only: stop at the first critical point.
        size: the mesh's bulk element size (None: ``default_discretisation``).
        layer_elements: elements across the rim's boundary layer.
        shear_penalty: the Kirchhoff-Love penalty factor.
        degree: the element degree (None: ``default_discretisation``).
        ds: the first step in κL (None: range/16).
        ds_max: the largest step in κL (None: range/10).
        outdir: the output folder (None: nothing written or resumed).
        kappa_field: the stimulus (None: uniform).
        mesh_file: a user's mesh of ``shape`` instead of meshing it (``size`` then unused).
        resume: resume an unfinished run of the same configuration.

    Returns:
        The first critical point's ``kind`` ("none" if there is none), ``kappa_R``,
        ``kappa_h``, ``mode_m``, ``mode_n``; ``critical_points`` (all), ``dofs``, ``mesh`` and
        ``wall_time``.

    Raises:
        InputError: ``ds`` below 1e-7 of the range, or a corrupt line in the branch file.
        RuntimeError: the continuation stopped before the end of the range.
    """
    from dataclasses import asdict

    from mpi4py import MPI

    from shells.algorithms.following import follow
    from shells.algorithms.records import FollowResume
    from shells.algorithms.settings import ContinuationSettings, CriticalSettings
    from shells.analyses.store import load_state_checkpoint, resumable, save_state_checkpoint
    from shells.geometry.stimulus import UNIFORM
    from shells.surface.mesh import MeshSpec, generate, load_mesh
    from shells.surface.model import ModelParameters, ShellModel, default_discretisation

    kappa_field = UNIFORM if kappa_field is None else kappa_field
    comm = MPI.COMM_WORLD
    L = shape.characteristic_size()
    h = h_over_r * L
    R_or_L = kappa_length(shape)
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
    progress = Progress("critical", kappa_end * R_or_L, comm)
    for p, res, found in follow(model, st, kappa_end, crit, resume=start,
                                track=None if out is None else tracked.append):
        last_kappa = p.kappa
        rec = {"index": p.index, "kappa_R": p.kappa * R_or_L, "kappa_h": p.kappa * h,
               "negative_count": res.negative_count, "dkappa_ds": p.dkappa_ds,
               "newton_its": p.newton_its, **p.scalars}
        if bfile is not None and comm.rank == 0:
            append_record(bfile, rec)  # one whole line, fsync'ed
        log.debug("  kappa R = %+.5f  kappa h = %+.5f  negative = %d  (%.0f s)",
                  rec["kappa_R"], rec["kappa_h"], res.negative_count, time.perf_counter() - t0)
        progress.update(rec["kappa_R"], critical=len(found), negative=res.negative_count)
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
    progress.close()
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
        from shells.surface.fields import write_modes

        write_modes(model, first_arrays[0], [first_arrays[1]], out / "modes.bp")
        log.info("critical mode (ParaView, ADIOS2 VTX Reader): %s", out / "modes.bp")
    return {"kind": first["kind"] if first else "none",
            "kappa_R": first["kappa_R"] if first else None,
            "kappa_h": first["kappa_h"] if first else None,
            "mode_m": first["mode_m"] if first else None,
            "mode_n": first["mode_n"] if first else None,
            "dofs": model.num_dofs(), "critical_points": cps,
            "discretisation_error": discretisation_error_of(shape, defaults, kappa_field.uniform),
            "discretisation_note": discretisation_note_of(shape, defaults, kappa_field.uniform),
            "mesh": ({"size": size, "layer_elements": layer_elements, "degree": degree}
                     if mesh_file is None else {"size": None, "layer_elements": None,
                                                "degree": degree, "user_mesh": True,
                                                "file": str(mesh_file),
                                                "cells": sm.num_cells()}),
            "wall_time": time.perf_counter() - t0}


def _rank() -> int:
    from mpi4py import MPI

    return MPI.COMM_WORLD.rank


def discretisation_error_of(shape: Any, defaults: bool, uniform: bool = True) -> float | None:
    """The relative error of κ that the surface model's discretisation is known to stay within
    (a run's ``discretisation_error``).

    Args:
        shape: the shell.
        defaults: the mesh and degree are ``default_discretisation``'s (no size, degree or
            mesh file given).
        uniform: the stimulus is the uniform one.

    Returns:
        Under the uniform stimulus on the default mesh, a closed sphere's
        ``shells.surface.model.SPHERE_DEFAULT_ERROR`` or a spherical cap's
        ``CAP_DEFAULT_ERROR``; else None.
    """
    from shells.geometry.shapes import SphericalCap
    from shells.surface.model import CAP_DEFAULT_ERROR, SPHERE_DEFAULT_ERROR

    if not (defaults and uniform):
        return None
    if shape.closed and shape.kind in ("sphere", "meridian"):
        return SPHERE_DEFAULT_ERROR
    if isinstance(shape, SphericalCap) and not shape.closed:
        return CAP_DEFAULT_ERROR
    return None


def discretisation_note_of(shape: Any, defaults: bool, uniform: bool = True) -> str:
    """What a critical point's ``accuracy`` (``locator_accuracy``) covers, and what not (a run's
    ``discretisation_note``; arguments as ``discretisation_error_of``'s)."""
    known = discretisation_error_of(shape, defaults, uniform)
    sphere = shape.closed and shape.kind in ("sphere", "meridian")
    why = ("4.25 elements per wavelength of the critical degree" if sphere else
           "the rim layer at sqrt(R h)/4, the bulk size scaled with sqrt(R h); measured on caps "
           "of theta/sqrt(h/R) 2 to 8 at h/R 0.04 and 0.01, docs/design-notes.md")
    return ("accuracy / locator_accuracy: the locator's bracket on this mesh only, not the "
            "discretisation error; " + (
                f"the default {'sphere' if sphere else 'cap'} mesh keeps kappa within about "
                f"{known:.1%} of the converged value ({why})" if known else
                "that is not estimated here: refine --size, or compare with --model axisym"
                " on a shell of revolution"))
