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
    from shells.algorithms.following import follow
    from shells.analyses.store import resumable

    run = _SurfaceRun(shape, h_over_r, nu, kappa_end, first_only=first_only, size=size,
                      layer_elements=layer_elements, shear_penalty=shear_penalty,
                      degree=degree, ds=ds, ds_max=ds_max, outdir=outdir,
                      kappa_field=kappa_field, mesh_file=mesh_file)
    # the file a rerun resumes, read before any work (a corrupt line: an InputError)
    why, recs = (resumable(run.bfile, run.same_run, run.comm, resume=resume)
                 if run.out is not None else ("no output folder", []))
    run.build_model()
    start = run.resume_point(why, recs)
    tracked: list[Any] = []
    t0 = time.perf_counter()
    last_kappa = None if start is None else start.kappa
    progress = Progress("critical", kappa_end * run.R_or_L, run.comm)
    for p, res, found in follow(run.model, run.st, kappa_end, run.crit, resume=start,
                                track=None if run.out is None else tracked.append):
        last_kappa = p.kappa
        run.record_point(p, res, found, t0, progress)
        if run.out is not None:
            # after the point's records: a kill leaves this checkpoint or the one before
            run.checkpoint(tracked.pop())
    progress.close()
    run.check_end(last_kappa)
    return run.result(t0)


class _SurfaceRun:
    """One run of ``run_surface``: its settings, files, model, and the critical points so
    far (records, and the first one's state and mode). The arguments are
    ``run_surface``'s."""

    def __init__(self, shape: Any, h_over_r: float, nu: float, kappa_end: float, *,
                 first_only: bool, size: float | None, layer_elements: float,
                 shear_penalty: float, degree: int | None, ds: float | None,
                 ds_max: float | None, outdir: str | os.PathLike | None, kappa_field: Any,
                 mesh_file: str | None) -> None:
        from mpi4py import MPI

        from shells.geometry.stimulus import UNIFORM
        from shells.surface.model import default_discretisation

        self.shape, self.h_over_r, self.nu, self.kappa_end = shape, h_over_r, nu, kappa_end
        self.first_only, self.layer_elements = first_only, layer_elements
        self.shear_penalty, self.mesh_file = shear_penalty, mesh_file
        self.kappa_field = UNIFORM if kappa_field is None else kappa_field
        self.comm = MPI.COMM_WORLD
        self.L = shape.characteristic_size()
        self.h = h_over_r * self.L
        self.R_or_L = kappa_length(shape)
        self.defaults = degree is None and size is None and mesh_file is None
        self.degree, self.size = default_discretisation(shape, h_over_r, degree, size,
                                                        self.kappa_field, nu)
        self.lam_end = abs(kappa_end) * self.L
        self.st, self.crit = self.settings(ds, ds_max)
        self.same_run = self.describe()
        self.out = Path(outdir) if outdir else None
        self.bfile = self.out / "branch.jsonl" if self.out is not None else None
        self.cps: list[dict[str, Any]] = []
        # the first critical point's state and mode
        self.first_arrays: tuple[Any, Any] | None = None

    def settings(self, ds: float | None, ds_max: float | None) -> tuple[Any, Any]:
        """The continuation's and the locator's settings.

        Args:
            ds: the first step in κL (None: range/16).
            ds_max: the largest step in κL (None: range/10).

        Returns:
            (``ContinuationSettings``, ``CriticalSettings``).

        Raises:
            InputError: ``ds`` below 1e-7 of the range.
        """
        from shells.algorithms.settings import ContinuationSettings, CriticalSettings

        lam_end = self.lam_end
        ds = ds if ds is not None else lam_end / 16
        ds_max = ds_max if ds_max is not None else max(ds, lam_end / 10)
        if not ds >= 1e-7 * lam_end:
            raise InputError(f"--ds must be at least 1e-7 of the kappa range "
                             f"({1e-7 * lam_end:.3g} in kappa L here), got {ds:g}")
        st = ContinuationSettings(ds=ds, ds_max=max(ds, ds_max), ds_min=1e-7 * lam_end,
                                  factor_reuse=REUSE_SURFACE,
                                  ds_unit="kappa")
        return st, CriticalSettings(stop_at_first=self.first_only)

    def describe(self) -> dict[str, Any]:
        """Everything that decides the run's numbers (a rerun resumes only under the same)."""
        from dataclasses import asdict

        st = self.st
        return {
            "command": "critical", "model": "surface", "shape": self.shape.describe(),
            "h_over_r": self.h_over_r, "nu": self.nu, "kappa_end": self.kappa_end,
            "direction": "up" if self.kappa_end > 0 else "down", "first_only": self.first_only,
            "mesh": ({"size": self.size, "layer_elements": self.layer_elements}
                     if self.mesh_file is None else {"file": str(self.mesh_file)}),
            "degree": self.degree, "shear_penalty": self.shear_penalty,
            "continuation": {**st.describe(), "kappa_stops": list(st.kappa_stops)},
            "critical": asdict(self.crit), **self.kappa_field.describe()}

    def build_model(self) -> None:
        """The mesh (generated, or the user's) and the shell model on it."""
        from shells.surface.mesh import MeshSpec, generate, load_mesh
        from shells.surface.model import ModelParameters, ShellModel

        degree = self.degree
        self.sm = (load_mesh(self.mesh_file, self.comm) if self.mesh_file is not None else
                   generate(MeshSpec(self.shape, h=self.h, size=self.size,
                                     layer_elements=self.layer_elements), self.comm))
        self.model = ShellModel(self.sm, ModelParameters(
            h=self.h, nu=self.nu, shear_penalty=self.shear_penalty, degree=degree,
            quadrature_degree=2 * degree, kappa_field=self.kappa_field))
        log.info("critical: %s, %d DOFs, following kappa up to kappa R = %.4f",
                 self.shape.describe(), self.model.num_dofs(), self.kappa_end * self.R_or_L)

    def resume_point(self, why: str | None, recs: list[dict[str, Any]]) -> Any:
        """Where the run resumes, and the branch file rewritten with the records kept.

        Args:
            why: why the branch file cannot be resumed (None: it can).
            recs: its records.

        Returns:
            The ``FollowResume`` to continue from, or None (a fresh start).
        """
        if self.out is None:
            return None
        start, kept = None, []
        if why is None:
            why, start, kept = self.load_checkpoint(recs)
        if start is not None:
            log.info("critical: resuming after point %d at kappa R = %.6g (%d critical "
                     "point(s) so far)", start.index, start.kappa * self.R_or_L, len(self.cps))
        elif why not in ("there is none", "--restart"):
            log.info("critical: not resuming from the existing branch file (%s); starting "
                     "afresh", why)
        if self.comm.rank == 0:
            # the kept records under the header, atomically (a torn last line is dropped)
            write_header(self.bfile, {**self.same_run, "dofs": self.model.num_dofs()}, kept)
        return start

    def load_checkpoint(self, recs: list[dict[str, Any]]
                        ) -> tuple[str | None, Any, list[dict[str, Any]]]:
        """The checkpoint of a resumable branch file, checked against its records; sets the
        critical points so far and the first one's arrays.

        Returns:
            (None, the ``FollowResume``, the records kept), or (why not, None, []).
        """
        from shells.algorithms.records import FollowResume
        from shells.analyses.store import load_state_checkpoint

        got = load_state_checkpoint(self.out / CRITICAL_CHECKPOINT, self.model, ("w", "w_prev"))
        try:
            if got is None or got[0].get("header") != json.loads(
                    json.dumps(self.same_run, default=json_default)):
                raise KeyError("none of this run")
            meta, states, _ = got
            start = FollowResume.from_scalars(meta["follow"], states["w"], states["w_prev"],
                                              states.get("tangent"))
            kept = [r for r in recs
                    if r.get("index", math.inf) <= start.index
                    or r.get("critical_point", {}).get("after_point", math.inf) < start.index]
            self.cps = [r["critical_point"] for r in kept if "critical_point" in r]
            if (not any(r.get("index") == start.index for r in kept)
                    or len(self.cps) != start.found or (self.cps and "cp_state" not in states)):
                raise KeyError("not of this file")
            if self.cps:
                self.first_arrays = (states["cp_state"], states.get("cp_mode"))
        except (KeyError, TypeError, ValueError):
            self.cps = []
            return ("its checkpoint is missing, incomplete, unreadable or not of this file",
                    None, [])
        return None, start, kept

    def record_point(self, p: Any, res: Any, found: list[Any], t0: float,
                     progress: Progress) -> None:
        """Append the point's record and its critical points' to the branch file (rank 0)."""
        rec = {"index": p.index, "kappa_R": p.kappa * self.R_or_L, "kappa_h": p.kappa * self.h,
               "negative_count": res.negative_count, "dkappa_ds": p.dkappa_ds,
               "newton_its": p.newton_its, **p.scalars}
        if self.bfile is not None and self.comm.rank == 0:
            append_record(self.bfile, rec)  # one whole line, fsync'ed
        log.debug("  kappa R = %+.5f  kappa h = %+.5f  negative = %d  (%.0f s)",
                  rec["kappa_R"], rec["kappa_h"], res.negative_count, time.perf_counter() - t0)
        progress.update(rec["kappa_R"], critical=len(found), negative=res.negative_count)
        for c in found:
            self.record_critical(c)

    def record_critical(self, c: Any) -> None:
        """Keep a located critical point (the first one's state and mode too) and append
        its record (rank 0)."""
        R_or_L = self.R_or_L
        if self.first_arrays is None:
            self.first_arrays = (c.state, c.mode)
        d = c.as_dict()
        d.update(kappa_R=c.kappa * R_or_L, kappa_h=c.kappa * self.h,
                 kappa_R_bracket=[c.kappa_lo * R_or_L, c.kappa_hi * R_or_L],
                 locator_accuracy=d.get("accuracy"))
        if self.bfile is not None and self.comm.rank == 0:
            append_record(self.bfile, {"critical_point": d, "number": len(self.cps)})
        self.cps.append(d)
        log.info("  %s at kappa R = %.6f (kappa h = %.6f), m = %s, n = %s", c.kind,
                 d["kappa_R"], d["kappa_h"], c.mode_m, c.mode_n)

    def checkpoint(self, r: Any) -> None:
        """Save the point's ``FollowResume`` ``r`` (and the first critical state and mode)."""
        from shells.analyses.store import save_state_checkpoint

        arrays = {"w": r.state, "w_prev": r.state_prev}
        if r.tangent is not None:
            arrays["tangent"] = r.tangent
        if self.first_arrays is not None:
            arrays["cp_state"] = self.first_arrays[0]
            if self.first_arrays[1] is not None:
                arrays["cp_mode"] = self.first_arrays[1]
        save_state_checkpoint(self.out / CRITICAL_CHECKPOINT, self.model, r.index, arrays,
                              meta={"follow": r.scalars(), "header": self.same_run})

    def check_end(self, last_kappa: float | None) -> None:
        """Raise unless the run stopped where it should or reached the end of the range.

        Raises:
            RuntimeError: the continuation gave up short of the end ("none" beyond would be
                a false claim).
        """
        crit, cps, L, kappa_end = self.crit, self.cps, self.L, self.kappa_end
        stopped = bool(cps) and (crit.stop_at_first or (crit.stop_at_fold and any(
            c["kind"] == "fold" for c in cps)))
        if not stopped and (last_kappa is None
                            or abs(last_kappa * L - kappa_end * L) > 1e-9 * self.lam_end):
            raise RuntimeError(f"the continuation stopped at kappa R = "
                               f"{None if last_kappa is None else last_kappa * self.R_or_L} "
                               "before the end of the range, kappa R = "
                               f"{kappa_end * self.R_or_L:.6g}; critical points beyond it are "
                               "not known")

    def result(self, t0: float) -> dict[str, Any]:
        """The first critical mode written (``modes.bp``) and ``run_surface``'s result."""
        cps, out, first_arrays = self.cps, self.out, self.first_arrays
        first = cps[0] if cps else None
        if out is not None and first_arrays is not None and first_arrays[1] is not None:
            from shells.surface.fields import write_modes

            write_modes(self.model, first_arrays[0], [first_arrays[1]], out / "modes.bp")
            log.info("critical mode (ParaView, ADIOS2 VTX Reader): %s", out / "modes.bp")
        degree, mesh_file = self.degree, self.mesh_file
        return {"kind": first["kind"] if first else "none",
                "kappa_R": first["kappa_R"] if first else None,
                "kappa_h": first["kappa_h"] if first else None,
                "mode_m": first["mode_m"] if first else None,
                "mode_n": first["mode_n"] if first else None,
                "dofs": self.model.num_dofs(), "critical_points": cps,
                "discretisation_error": discretisation_error_of(self.shape, self.defaults,
                                                                self.kappa_field.uniform),
                "discretisation_note": discretisation_note_of(self.shape, self.defaults,
                                                              self.kappa_field.uniform),
                "mesh": ({"size": self.size, "layer_elements": self.layer_elements,
                          "degree": degree}
                         if mesh_file is None else {"size": None, "layer_elements": None,
                                                    "degree": degree, "user_mesh": True,
                                                    "file": str(mesh_file),
                                                    "cells": self.sm.num_cells()}),
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
