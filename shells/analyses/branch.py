"""Branch driver: follow a shell in κ, append each point to a branch file, resume after a crash.

Files in the output directory:

* ``branch.jsonl`` — line 1 is a header (``{"header": {...config...}}``), then one JSON object per
  converged point, appended and flushed as soon as it exists (a crash loses nothing computed).
* ``checkpoint/`` — the state at the last point: one ``.npz`` per MPI rank (owned DOF values with
  their node coordinates) and ``meta.json``. A rerun with the same configuration resumes from it
  on any rank count; with another configuration or mesh it restarts and says so.
* ``fields.bp`` — with ``fields`` other than "none": displacement ``displacement``, director
  ``director`` and curvature fields ``mean_curvature_change`` = ½ tr(b - b°) and
  ``natural_curvature_mismatch`` = ½ tr(b - b̄), as VTX (ADIOS2) for ParaView, one step per point.
"""

from __future__ import annotations

import logging
import math
import os
import time
from collections.abc import Iterator
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from shells.algorithms.continuation import Point, continuation, next_step
from shells.algorithms.settings import ContinuationSettings
from shells.analyses.store import load_state_checkpoint, resumable, save_state_checkpoint
from shells.errors import InputError
from shells.files import append_record, read_with_header, write_header
from shells.geometry.catalogue import shape_from_description
from shells.geometry.shapes import RunScales, Shape, kappa_length
from shells.geometry.stimulus import UNIFORM, CurvatureField
from shells.parameters import check_h_over_r, check_model, check_nu
from shells.progress import Progress
from shells.surface.fields import FieldWriter
from shells.surface.mesh import MeshSpec, ShellMesh, generate, load_mesh

__all__ = ["BranchConfig", "folds", "read_branch", "run", "run_axisym", "run_branch", "run_surface"]

log = logging.getLogger("shells")


@dataclass(frozen=True)
class BranchConfig(RunScales):
    """What a branch run computes (everything that decides its numbers).

    Attributes:
        shape: the analytic shape.
        h_over_r: thickness over the shape's length scale L (R; the disk's radius).
        nu: Poisson ratio.
        kappa_end: final natural curvature κ (absolute, 1/length); its sign is the direction.
        size, layer_elements: mesh parameters (see ``MeshSpec``; size None: the default of
            ``shells.surface.model.default_discretisation``).
        degree: polynomial degree of the surface model (None: ``default_discretisation``'s,
            P3 on closed spheres, deep caps and ellipsoids, where P2 locks).
        shear_penalty: Kirchhoff-Love penalty factor of the surface model.
        continuation: continuation settings.
        kappa_field: the natural-curvature stimulus (``shells.geometry.stimulus``; default:
            uniform).
        mesh_file: a user's mesh (``shells.surface.mesh.load_mesh``) of ``shape`` instead of
            meshing it (``size`` and ``layer_elements`` unused then).

    Raises:
        InputError: on construction, for a parameter out of range.
    """

    shape: Shape
    h_over_r: float
    nu: float = 0.5
    kappa_end: float = 1.0
    size: float | None = None
    layer_elements: float = 4.0
    shear_penalty: float = 1.0e3
    continuation: ContinuationSettings = field(default_factory=ContinuationSettings)
    degree: int | None = None
    kappa_field: CurvatureField = UNIFORM
    mesh_file: str | None = None

    def __post_init__(self) -> None:
        from shells.surface.model import default_discretisation

        if not isinstance(self.kappa_field, CurvatureField):
            raise InputError(f"kappa_field must be a CurvatureField, got {self.kappa_field!r}")
        self.kappa_field.check_on(self.shape)

        if self.degree is None or self.size is None:
            deg, size = default_discretisation(self.shape, self.h_over_r, self.degree, self.size,
                                               self.kappa_field)
            object.__setattr__(self, "degree", self.degree or deg)
            object.__setattr__(self, "size", self.size or size)
        check_h_over_r(self.h_over_r)
        check_nu(self.nu)
        if not (math.isfinite(self.kappa_end) and self.kappa_end != 0):
            raise InputError("the final kappa must be a nonzero number")

    def mesh_spec(self) -> MeshSpec:
        """The mesh this run generates (without a ``mesh_file``)."""
        return MeshSpec(self.shape, h=self.h, size=self.size, layer_elements=self.layer_elements)

    def describe(self) -> dict[str, Any]:
        """The configuration as the branch file's JSON header (what a resume compares)."""
        d = asdict(self)
        d["shape"] = self.shape.describe()
        d["continuation"] = self.continuation.describe()
        d["continuation"]["kappa_stops"] = list(self.continuation.kappa_stops)
        d["model"] = "surface"
        del d["kappa_field"]
        d.update(self.kappa_field.header_entry())
        if d["mesh_file"] is None:
            del d["mesh_file"]  # branches on shells' own meshes: headers of existing files match
        return d

    @classmethod
    def from_description(cls, d: dict[str, Any]) -> BranchConfig:
        """The configuration that ``describe`` gave ``d``."""
        c = dict(d["continuation"])
        c["kappa_stops"] = tuple(c.get("kappa_stops", ()))
        return cls(shape=shape_from_description(d["shape"]), h_over_r=d["h_over_r"], nu=d["nu"],
                   kappa_end=d["kappa_end"], size=d["size"], layer_elements=d["layer_elements"],
                   shear_penalty=d["shear_penalty"], continuation=ContinuationSettings(**c),
                   degree=d.get("degree", 2),
                   kappa_field=CurvatureField.from_description(d),
                   mesh_file=d.get("mesh_file"))


def point_record(p: Point, cfg: BranchConfig) -> dict[str, Any]:
    """The JSON record of a point: its fields and scalars, plus ``kappa_R`` and ``kappa_h``.

    Args:
        p: the point.
        cfg: the run (its R and h).

    Returns:
        The record (public keys: kappa_R, kappa_h, psi3_over_h, energy, ...).
    """
    d = p.as_dict()
    d["kappa_R"] = p.kappa * cfg.R
    d["kappa_h"] = p.kappa * cfg.h
    return d


def read_branch(path: str | os.PathLike) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """Read a branch file.

    Args:
        path: the ``branch.jsonl`` file.

    Returns:
        (header, points); a torn last line from a crash is ignored.
    """
    return read_with_header(path)


def _save_checkpoint(outdir: Path, model: Any, rec: dict[str, Any],
                     prev: tuple[np.ndarray, float] | None,
                     tangent: tuple[np.ndarray, float] | None = None) -> None:
    """State of this point (and of the previous one, whose secant orients a resumed run, and
    the unit tangent the next step follows, when given) in ``checkpoint/``:
    ``shells.analyses.store.save_state_checkpoint`` (each value with its node's coordinates, read
    back on any partition; a kill at any moment leaves a complete checkpoint, this point's or the
    previous one's)."""
    w = model.w.x.array
    w_prev, k_prev = (prev[0], prev[1]) if prev is not None else (w, float(model.kappa.value))
    states = {"w": w, "w_prev": w_prev}
    scalars = {"kappa": float(model.kappa.value), "kappa_prev": k_prev}
    if tangent is not None:
        states["tangent"] = tangent[0]
        scalars["tangent_kappa"] = tangent[1]
    save_state_checkpoint(outdir / "checkpoint", model, rec["index"], states, scalars)


def load_branch_checkpoint(outdir: Path, model: Any
                     ) -> tuple[float, int, np.ndarray, float, Any, np.ndarray, float] | None:
    """Read the branch checkpoint into ``model.w``.

    Nodes are matched by their coordinates (``shells.analyses.store.load_state_checkpoint``), so
    the checkpoint may come from another partition or rank count.

    Args:
        outdir: the run's folder (its ``checkpoint/``).
        model: the surface model, on the run's mesh.

    Returns:
        (κ, index, w - w_prev, κ - κ_prev, the tangent (owned values, λ part) or None,
        w_prev (owned values), κ_prev); None when the checkpoint is missing, incomplete or
        from another mesh.
    """
    got = load_state_checkpoint(outdir / "checkpoint", model, ("w", "w_prev"))
    if got is None:
        return None
    meta, states, scalars = got
    w, w_prev = states["w"], states["w_prev"]
    model.w.x.array[:w.size] = w
    model.w.x.scatter_forward()
    kappa, kappa_prev = float(scalars["kappa"]), float(scalars["kappa_prev"])
    dw = model.w.x.array.copy()
    dw[:w.size] = w - w_prev
    dw[w.size:] = 0.0
    tangent = (None if "tangent" not in states or "tangent_kappa" not in scalars
               else (states["tangent"], float(scalars["tangent_kappa"])))
    return kappa, int(meta["index"]), dw, kappa - kappa_prev, tangent, w_prev, kappa_prev


def run_branch(cfg: BranchConfig, outdir: str | os.PathLike, *, comm: Any = None,
               fields: str = "none", resume: bool = True, shell: ShellMesh | None = None,
               label: str = "branch") -> Iterator[dict[str, Any]]:
    """Compute the surface model's branch of ``cfg``, each point stored as it is computed.

    On resume, the records already in the branch file are yielded first (without recomputing),
    then the run continues from the checkpoint as the interrupted run would have.

    Args:
        cfg: the run.
        outdir: the run's folder (``branch.jsonl``, ``checkpoint/``, ``fields.bp``).
        comm: the communicator (default ``MPI.COMM_WORLD``).
        fields: the fields written for ParaView: "none", "last" or "all".
        resume: resume an unfinished run of the same configuration (False: start afresh).
        shell: the mesh, if already made (default: generated, or read from ``mesh_file``).
        label: the name in log messages.

    Yields:
        Each point's record, as it is written.

    Raises:
        InputError: for an unknown ``fields``, or a branch file that cannot be trusted.
    """
    from mpi4py import MPI

    if fields not in ("none", "last", "all"):
        raise InputError(f"fields must be none, last or all, got {fields!r}")
    comm = MPI.COMM_WORLD if comm is None else comm
    outdir = Path(outdir)
    if comm.rank == 0:
        outdir.mkdir(parents=True, exist_ok=True)
    comm.barrier()
    bfile = outdir / "branch.jsonl"
    header = cfg.describe()
    model = _branch_model(cfg, comm, shell, header, label)
    start, done = _branch_start(outdir, model, header, comm, resume, label)
    if comm.rank == 0:
        # the kept points are rewritten under the header into a temporary file, renamed over
        # the old one: a kill leaves the old file or the new one, never a torn one (a torn
        # last line of the old file is dropped here)
        write_header(bfile, header, done, sidecar=True)
    yield from done
    yield from _branch_points(cfg, outdir, model, comm, fields, label, start, done)


def _branch_model(cfg: BranchConfig, comm: Any, shell: ShellMesh | None,
                  header: dict[str, Any], label: str) -> Any:
    """The surface model of ``cfg`` on ``shell`` (default: generated, or read from
    ``mesh_file``); its DOFs go into ``header``."""
    from shells.surface.model import ModelParameters, ShellModel

    t0 = time.perf_counter()
    if shell is None:
        shell = load_mesh(cfg.mesh_file, comm) if cfg.mesh_file else generate(cfg.mesh_spec(),
                                                                              comm)
    model = ShellModel(shell, ModelParameters(h=cfg.h, nu=cfg.nu,
                                              shear_penalty=cfg.shear_penalty,
                                              degree=cfg.degree,
                                              quadrature_degree=2 * cfg.degree,
                                              kappa_field=cfg.kappa_field))
    header["dofs"] = model.num_dofs()
    log.info("%s: %s, %d DOFs on %d rank(s), set-up %.1f s", label, cfg.shape.describe(),
             header["dofs"], comm.size, time.perf_counter() - t0)
    return model


def _branch_start(outdir: Path, model: Any, header: dict[str, Any], comm: Any, resume: bool,
                  label: str) -> tuple[Any, list[dict[str, Any]]]:
    """Where a run resumes: the branch file's checkpoint, if the file is of this run and the
    checkpoint of one of its points.

    Returns:
        (``load_branch_checkpoint``'s tuple, the points kept up to it), or (None, []).

    Raises:
        InputError: a branch file that cannot be trusted (a corrupt line).
    """
    start = None
    # rank 0 reads the file (it alone rewrites it) and tells the others; a file it cannot
    # trust (a corrupt line) is an error on every rank
    why, done = resumable(outdir / "branch.jsonl", header, comm, resume=resume)
    if why is None:
        start = load_branch_checkpoint(outdir, model)
        if start is None or not any(d.get("index") == start[1] for d in done):
            # (a checkpoint past the file's last point: another run's, left when that one
            # started afresh)
            why, start = "its checkpoint is missing, incomplete or from another mesh", None
    if start is None:
        if why not in ("there is none", "--restart"):
            log.info("%s: not resuming from the existing branch file (%s); starting afresh",
                     label, why)
        return None, []
    # keep only the points up to the checkpoint
    done = [d for d in done if d["index"] <= start[1]]
    log.info("%s: resuming after point %d at kappa = %.6g", label, start[1], start[0])
    return start, done


def _resumed_continuation(cfg: BranchConfig, comm: Any, start: Any,
                          done: list[dict[str, Any]]) -> dict[str, Any]:
    """``continuation``'s keywords that resume after the checkpoint ``start`` (None: none):
    the secant of the last two points orients the run; it takes the step the interrupted run
    would have taken next (its points are then the uninterrupted run's; not for steps given
    in κ, converted at the start) and, for a quadratic predictor, the point before."""
    from mpi4py import MPI

    tangent = None
    moved = start is not None and comm.allreduce(bool(np.any(start[2])), op=MPI.LOR)
    if start is not None and (moved or start[3] != 0):
        tangent = (start[2], start[3] * cfg.L)
    st = cfg.continuation
    ds0 = previous = None
    last_rec = done[-1] if start is not None and done else {}
    if start is not None and last_rec.get("index") == start[1] > 0 \
            and last_rec.get("step", 0) > 0:
        if st.method == "natural" or st.ds_unit == "arclength":
            ds0 = next_step(st, last_rec["step"], last_rec["newton_its"])
        # the point before and the (arclength) step from it, for a quadratic predictor
        previous = (start[5], start[6], last_rec["step"])
    return dict(initial_tangent=tangent, initial_ds=ds0,
                tangent=None if start is None else start[4], previous=previous)


def _branch_points(cfg: BranchConfig, outdir: Path, model: Any, comm: Any, fields: str,
                   label: str, start: Any, done: list[dict[str, Any]]
                   ) -> Iterator[dict[str, Any]]:
    """The continuation from κ = 0 or after the checkpoint ``start``: each point's record
    appended (rank 0), checkpointed, its fields written, then yielded."""
    from shells.algorithms.newton import NewtonSolver

    writer = FieldWriter(model, outdir / "fields.bp") if fields != "none" else None
    ns = NewtonSolver(model)
    progress = Progress(label, cfg.kappa_end * cfg.R, comm)
    kappa0, index0 = (0.0, 0) if start is None else (start[0], start[1] + 1)
    if start is not None and abs(kappa0 - cfg.kappa_end) < 1e-14 * abs(cfg.kappa_end):
        return
    resumed = _resumed_continuation(cfg, comm, start, done)
    held: list[Any] = []  # the unit tangent the next step follows (arclength)

    def hold(tw: np.ndarray, tl: float) -> None:
        held[:] = [(tw, tl)]

    it = continuation(model, cfg.continuation, kappa_start=kappa0, kappa_end=cfg.kappa_end,
                      solver=ns, start_index=index0, skip_first=start is not None,
                      on_tangent=hold, **resumed)
    last = None
    # the previous point of the next checkpoint: on resume, the checkpoint's point
    prev = None if start is None else (model.w.x.array.copy(), kappa0)
    try:
        for p in it:
            rec = point_record(p, cfg)
            if comm.rank == 0:
                append_record(outdir / "branch.jsonl", rec)  # one whole line, fsync'ed
            _save_checkpoint(outdir, model, rec, prev, held[0] if held else None)
            prev = (model.w.x.array.copy(), float(model.kappa.value))
            if writer is not None and fields == "all":
                writer.write(float(rec["index"]))
            progress.update(rec["kappa_R"], psi3_over_h=rec["psi3_over_h"])
            last = rec
            yield rec
    finally:
        progress.close()
        if writer is not None:
            if fields == "last" and last is not None:
                writer.write(float(last["index"]))
            writer.close()
        ns.destroy()


def run(shape: Any, h_over_r: float, nu: float, kappa_end: float, *, model: str = "surface",
        outdir: str | os.PathLike = "results/branch", kappa_field: Any = None,
        fields: str = "none", resume: bool = True, **surface: Any) -> dict[str, Any]:
    """The equilibrium branch of a shell from κ = 0 to ``kappa_end``, with either model.

    Args:
        shape: the shell's reference shape (``shells.geometry``).
        h_over_r: thickness over the shape's length scale.
        nu: Poisson's ratio.
        kappa_end: the end of the range, an absolute natural curvature (its sign: the
            direction).
        model: ``"surface"`` (2D) or ``"axisym"`` (1D, shells of revolution).
        outdir: the run's folder: ``branch.jsonl``, every point appended as computed (the
            surface model: a rerun resumes from ``checkpoint/``).
        kappa_field: the natural-curvature stimulus (None: uniform).
        fields: the surface model's fields for ParaView: ``"none"``, ``"last"`` or ``"all"``.
        resume: the surface model resumes an unfinished run of the same configuration.
        **surface: the surface model's ``BranchConfig`` fields (``size``, ``degree``,
            ``layer_elements``, ``shear_penalty``, ``continuation``, ``mesh_file``).

    Returns:
        The branch: ``points`` (one record each), ``folds``, ``branch_file`` and, on the
        surface model, ``config`` and ``dofs``.

    Raises:
        InputError: a parameter out of range.
        RuntimeError: the surface model's continuation stopped before the end of the range.
    """
    check_model(model)
    if model == "axisym":
        return run_axisym(shape, h_over_r, nu, kappa_end * kappa_length(shape), outdir,
                          kappa_field=kappa_field)
    cfg = BranchConfig(shape=shape, h_over_r=h_over_r, nu=nu, kappa_end=kappa_end,
                       kappa_field=UNIFORM if kappa_field is None else kappa_field, **surface)
    return run_surface(cfg, outdir, fields=fields, resume=resume)


def folds(points: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The turning points in κ of a branch.

    Args:
        points: the branch's records, in order.

    Returns:
        {"kappa_R", "kappa_h", "index"} of each point after which dκ/ds changed sign.
    """
    return [{"kappa_R": p["kappa_R"], "kappa_h": p["kappa_h"], "index": p["index"]}
            for a, p in zip(points, points[1:], strict=False)
            if a["dkappa_ds"] * p["dkappa_ds"] < 0]


def run_surface(cfg: Any, outdir: str | os.PathLike, *, fields: str = "none",
                   resume: bool = True) -> dict[str, Any]:
    """The surface model's branch: ``run_branch`` on ``cfg``, after the mesh-size check.

    The mesh size is checked before the run creates its folder.

    Args:
        cfg: a ``BranchConfig``.
        outdir: the run's folder.
        fields: as for ``run_branch``.
        resume: as for ``run_branch``.

    Returns:
        The configuration, the DOFs, the branch file, the points and the folds.

    Raises:
        InputError: a mesh too large, or a bad ``fields``.
        RuntimeError: the continuation stopped before the end of the range (its points so
            far and its checkpoint are kept: the same call resumes after the last).
    """
    from shells.surface.mesh import check_mesh_size

    if cfg.mesh_file is None:
        check_mesh_size(cfg.mesh_spec())
    points = list(run_branch(cfg, outdir, fields=fields, resume=resume))
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
    header, _ = read_branch(f"{outdir}/branch.jsonl")
    return {"config": cfg.describe(), "dofs": header.get("dofs"),
            "branch_file": f"{outdir}/branch.jsonl", "points": points, "folds": folds(points)}


def run_axisym(shape: Any, h_over_r: float, nu: float, kappa_R_end: float,
                  outdir: str | os.PathLike, kappa_field: Any = None) -> dict[str, Any]:
    """The 1D (shell-of-revolution) model's branch, every point stored as computed.

    Args:
        shape: the shell of revolution.
        h_over_r: thickness over the shape's length scale.
        nu: Poisson's ratio.
        kappa_R_end: the end of the range in κR (its sign: the direction).
        outdir: the run's folder; ``branch.jsonl`` is written by rank 0.
        kappa_field: the natural-curvature stimulus (None: uniform).

    Returns:
        {"model", "branch_file", "points", "folds"}.
    """
    from shells.analyses import axisym_runs
    from shells.geometry.stimulus import UNIFORM

    kappa_field = UNIFORM if kappa_field is None else kappa_field

    outdir = Path(outdir)
    points = []
    # no checkpoint: a rerun computes the branch again (the 1D model takes seconds), the file
    # replaced atomically by its header, then each point appended whole and fsync'ed
    if _rank() == 0:
        outdir.mkdir(parents=True, exist_ok=True)
        write_header(outdir / "branch.jsonl", {
            "model": "axisym", "shape": shape.describe(), "h_over_r": h_over_r,
            "nu": nu, "kappa_R_end": kappa_R_end, **kappa_field.header_entry()}, sidecar=True)
    for i, p in enumerate(axisym_runs.branch(shape, h_over_r, nu,
                                             direction="up" if kappa_R_end > 0 else "down",
                                             kappa_max=abs(kappa_R_end), kappa_field=kappa_field)):
        rec = {"index": i, **p}
        points.append(rec)
        if _rank() == 0:
            append_record(outdir / "branch.jsonl", rec)
    return {"model": "axisym", "branch_file": str(outdir / "branch.jsonl"), "points": points,
            "folds": folds(points)}


def _rank() -> int:
    from mpi4py import MPI

    return MPI.COMM_WORLD.rank
