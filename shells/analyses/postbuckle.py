"""Post-buckling branches: follow the fundamental branch to a bifurcation, switch, follow the
bifurcated branch on both sides (driver layer, on the algorithm layer's ``follow`` and
``switch_branch``; both models).

``postbuckle(cfg)`` yields one record per computed point:

1. the fundamental branch from κ = 0 with the stability at every point, up to its
   ``cfg.at``-th bifurcation, located to 1e-4 in κ (``branch`` = "fundamental");
2. the critical mode there: on the 1D model the axisymmetric (m = 0) mode of the Jacobian
   (the only branches the 1D model represents), on the surface model the critical
   eigenvector of the Hessian (a split (cos mφ, sin mφ) pair's partner pinned);
3. the bifurcated branch on each of ``cfg.sides`` (``branch`` = "bifurcated"), until κ leaves
   [``kappa_min_ratio`` κ_c, κ_max], after ``max_points`` points, or when it returns to the
   fundamental branch. On a closed shell with a pole (the sphere; either model, not on a
   user's mesh) the branch is the dimple at the top pole, its depth Ψ3(pole)/h the branch's
   parameter (the summary's ``parameter``: "psi3_pole_over_h", else "arclength"; side -1
   pushes the pole in; docs/model.md, "The 1D model's closed sphere").

Each bifurcated point carries ``side`` (the sign of the first amplitude), ``start`` ("down" or
"up": where κ goes from κ_c on that side) and ``subcritical`` (it goes back towards smaller
|κ|). Stability is the negative count of the full Hessian (``negative_count``; on the 1D model
Σ_m N_m over the Fourier blocks, each m ≥ 1 counted for its cos and sin members, per block in
``negative_counts``); ``orientation_modes`` of them lie along the state's symmetry orbit (a
pattern's rotation about the axis, a dimple's sliding over a sphere), neutral for the shell,
and ``stable`` means no other negative eigenvalue.

Files (``run_postbuckle``): the records in ``DIR/postbuckle.jsonl`` (header first, each side
ended by a {"side_end": ...} record), the critical point in ``DIR/critical_point/`` and the
side being followed in ``DIR/side_checkpoint/`` (``shells.analyses.store``). A rerun with the
same configuration reuses a complete file; otherwise it resumes from the critical point: the
sides that ended are kept, an interrupted side continues after its last checkpointed point as
the uninterrupted run would, and a side whose checkpoint is unusable restarts from the
bifurcation (a log line says why); without the critical point the run starts from κ = 0. (A
1D side's first 3 points are held back until no retry at another amplitude can drop them.)
"""

from __future__ import annotations

import json
import logging
import math
import os
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from shells.analyses.axisym_runs import CLOSED_PENALTY
from shells.analyses.store import load_checkpoint, save_checkpoint
from shells.errors import InputError
from shells.files import append_record, json_default, read_with_header, write_header
from shells.geometry.shapes import RunScales, Shape
from shells.geometry.stimulus import UNIFORM, CurvatureField
from shells.parameters import check_h_over_r, check_model

__all__ = ["PostbuckleConfig", "postbuckle", "read_postbuckle", "run_postbuckle"]

log = logging.getLogger("shells")


@dataclass(frozen=True)
class PostbuckleConfig(RunScales):
    """One post-buckling run.

    Attributes:
        shape: the shell (``shells.geometry.shapes``).
        h_over_r: thickness over the shape's length scale L.
        nu: Poisson ratio.
        model: "axisym" (1D; axisymmetric branches only) or "surface" (2D).
        direction: "up" (κ > 0) or "down" (κ < 0).
        at: follow the branch from the ``at``-th bifurcation of the fundamental branch.
        kappa_end: end of the range (signed κ, absolute); None:
            ``shells.analyses.setup.default_kappa_range``.
        kappa_min_ratio: bifurcated branches end where κ/κ_c falls below this.
        max_points: at most this many points per side of the bifurcated branch.
        sides: the sides of the critical mode followed, +1 and/or -1 (a pitchfork's two are
            mirror images: one may do).
        amplitude: first mode amplitude (RMS in thicknesses) of the bifurcated branch; on
            closed shells with a pole the first point's change of the pole's depth Ψ3(pole)/h,
            and the depth's first step (up to 4 times this).
        cells, size, layer_elements, degree: discretisation of the 1D / surface model (None:
            the model's defaults; the surface model: 3 layer elements, size and degree of
            ``shells.surface.model.default_discretisation``, P3 where P2 locks).
        penalty: the 1D model's C1 penalty (None: 1e5 on closed shells, else its default).
        kappa_field: the natural-curvature stimulus (``shells.geometry.stimulus``; default:
            uniform).
        mesh_file: the surface model on a user's mesh (``shells.surface.mesh.load_mesh``) of
            ``shape`` instead of meshing it.
    """

    shape: Shape
    h_over_r: float
    nu: float = 0.5
    model: str = "axisym"
    direction: str = "up"
    at: int = 1
    kappa_end: float | None = None
    kappa_min_ratio: float = 0.5
    max_points: int = 60
    amplitude: float = 0.25
    cells: int | None = None
    penalty: float | None = None
    size: float | None = None
    layer_elements: float = 3.0
    degree: int | None = None
    sides: tuple[int, ...] = (1, -1)
    kappa_field: CurvatureField = UNIFORM
    mesh_file: str | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.kappa_field, CurvatureField):
            raise InputError(f"kappa_field must be a CurvatureField, got {self.kappa_field!r}")
        self.kappa_field.check_on(self.shape, axisymmetric=self.model == "axisym")
        if not (isinstance(self.sides, tuple) and self.sides
                and all(s in (1, -1) for s in self.sides) and len(set(self.sides)) == len(
                    self.sides)):
            raise InputError(f"sides must be (1,), (-1,) or (1, -1), got {self.sides!r}")
        check_model(self.model)
        if self.direction not in ("up", "down"):
            raise InputError(f"direction must be up or down, got {self.direction!r}")
        if not (isinstance(self.at, int) and 1 <= self.at <= 50):
            raise InputError(f"--at must be an integer in [1, 50], got {self.at!r}")
        check_h_over_r(self.h_over_r)
        if not (0 <= self.kappa_min_ratio < 1):
            raise InputError(f"kappa_min_ratio must lie in [0, 1), got {self.kappa_min_ratio}")
        if not (isinstance(self.max_points, int) and 1 <= self.max_points <= 100000):
            raise InputError(f"max_points must be a positive integer, got {self.max_points!r}")
        if not (math.isfinite(self.amplitude) and self.amplitude > 0):
            raise InputError(f"amplitude must be positive, got {self.amplitude!r}")
        sign = 1.0 if self.direction == "up" else -1.0
        if self.kappa_end is not None and not (math.isfinite(self.kappa_end)
                                               and self.kappa_end * sign > 0):
            raise InputError("the end of the kappa range must be a nonzero number of the sign "
                             "of --direction")
        if self.model == "surface" and (self.degree is None or self.size is None):
            from shells.surface.model import default_discretisation

            # size 0.2 with 3 layer elements: close to the 1D model's bifurcations on caps and
            # ellipsoids (docs/design-notes.md, "Post-buckling runs")
            deg, size = default_discretisation(self.shape, self.h_over_r, self.degree,
                                               0.2 if self.size is None else self.size,
                                               self.kappa_field)
            object.__setattr__(self, "degree", deg)
            object.__setattr__(self, "size", size)

    @property
    def kappa_stop(self) -> float:
        """The end of the κ range: ``kappa_end``, or the shape's default range."""
        from shells.analyses.setup import default_kappa_range

        if self.kappa_end is not None:
            return self.kappa_end
        return default_kappa_range(self.shape, self.h_over_r, self.nu, self.direction)

    def describe(self) -> dict[str, Any]:
        """The configuration as the JSON header of its file (what a resume compares)."""
        d = asdict(self)
        d["shape"] = self.shape.describe()
        d["sides"] = list(self.sides)  # as JSON reads it back (a resumed file's header)
        del d["kappa_field"]
        d.update(self.kappa_field.header_entry())
        if d["mesh_file"] is None:
            del d["mesh_file"]  # runs on shells' own meshes: headers of existing files match
        return d


#: the 1D model's branch switching: near-null modes deflated from its first corrector's steps
#: (the neighbouring degrees of a sphere's buckling mode), and the round-off factor of the
#: residual bound, above the floor of the stiff penalised Jacobian (docs/design-notes.md,
#: "Post-buckling runs")
DEFLATE = 4
ROUNDOFF = 10.0
#: the closed sphere's dimple branch: switched onto along the projection of the pole's depth
#: on this many eigenvectors nearest 0 at κ_b, or on the located multiplet if larger (the 1D
#: model: the neighbouring degrees; the surface model: the multiplet of the critical degrees;
#: docs/model.md, "The 1D model's closed sphere"), and followed with the depth Ψ3(pole)/h as the
#: parameter (``switch_branch``'s ``control``)
CLUSTER = 6


class _Run:
    """The model, its solvers and the record maker of a run."""

    def __init__(self, cfg: PostbuckleConfig) -> None:
        from mpi4py import MPI

        from shells.algorithms.newton import NewtonSolver
        from shells.algorithms.stability import Stability

        self.cfg = cfg
        if cfg.model == "axisym":
            from shells.analyses.axisym_runs import RunConfig
            from shells.axisym import SNES_OPTIONS, AxisymModel

            # the C1 penalty ties the slopes to the displacement only to O(1/penalty): on a
            # closed sphere that is a mirror-symmetric imperfection, ∝ 1/penalty, which the
            # near-critical even degrees amplify into a fold just before κ_b; 1e5 makes it 10x
            # smaller than the default. Not 1e6: then Newton does not converge on the dimple
            # branch of thin spheres (docs/model.md, "The 1D model's closed sphere")
            penalty = cfg.penalty if cfg.penalty is not None else (
                CLOSED_PENALTY if cfg.shape.closed else 1.0e4)
            rc = RunConfig(shape=cfg.shape, h_over_r=cfg.h_over_r, nu=cfg.nu,
                           direction=cfg.direction, cells=cfg.cells, penalty=penalty,
                           kappa_field=cfg.kappa_field)
            self.model: Any = AxisymModel(cfg.shape, rc.params())
            self.model.modes = tuple(rc.modes)
            self.ns = NewtonSolver(self.model, options=SNES_OPTIONS)
        else:
            from shells.surface.mesh import MeshSpec, generate, load_mesh
            from shells.surface.model import ModelParameters, ShellModel

            sm = (load_mesh(cfg.mesh_file, MPI.COMM_WORLD) if cfg.mesh_file else
                  generate(MeshSpec(cfg.shape, h=cfg.h, size=cfg.size,
                                    layer_elements=cfg.layer_elements), MPI.COMM_WORLD))
            self.model = ShellModel(sm, ModelParameters(h=cfg.h, nu=cfg.nu, degree=cfg.degree,
                                                        quadrature_degree=2 * cfg.degree,
                                                        kappa_field=cfg.kappa_field))
            self.ns = NewtonSolver(self.model)
        self.stab = Stability(self.model)

    def stability(self, orbit: bool = True) -> dict[str, Any]:
        """The point's stability record.

        Args:
            orbit: count orientation modes apart; False on the fundamental branch: a state
                with the shell's symmetry has no orbit, and the tangent of its mesh-sized
                asymmetry (the P_n of a closed sphere's penalty imperfection, rotated) is a
                member of the unstable multiplet past κ_b, which must not be discounted
                (docs/design-notes.md, "Post-buckling runs").

        Returns:
            ``stable``, ``negative_count``, ``orientation_modes`` and, on the 1D model,
            ``negative_counts`` per block and ``negative_count_axisymmetric``.
        """
        if self.cfg.model == "surface":
            # a rotation of the buckling pattern about the axis is neutral for the shell; on
            # the mesh (exactly C_k-symmetric) its eigenvalue is tiny and of either sign, and
            # it does not decide stability: counted apart
            if not orbit:
                n = self.stab.negative_count(None)
                return {"stable": n == 0, "negative_count": n, "orientation_modes": 0}
            n, slid = self.stab.negative_count_modulo_orbit(None)
            return {"stable": n - slid == 0, "negative_count": n, "orientation_modes": slid}
        counts = self.stab.negative_counts()
        total = sum(c if m == 0 else 2 * c for m, c in counts.items())
        slide = 0
        if orbit and self.cfg.shape.closed and counts.get(1, 0) > 0:
            # on a closed sphere a rotation about its centre slides a dimple at the pole over
            # it: neutral, an m = 1 pair of either sign on the meridian's mesh, far below the
            # block's next mode (docs/model.md, "The 1D model's closed sphere")
            slide = 2 * self.stab.negative_count_modulo_orbit(1, count=counts[1])[1]
        return {"stable": total - slide == 0, "negative_count": total,
                "negative_counts": [counts[m] for m in sorted(counts)],
                "negative_count_axisymmetric": self.stab.negative_count(None),
                "orientation_modes": slide}

    def record(self, p: Any, branch: str, **extra: Any) -> dict[str, Any]:
        """The record of point ``p`` on ``branch``: its scalars, κR, κh, stability, ``extra``."""
        d = p.as_dict()
        d.update(branch=branch, kappa_R=p.kappa * self.cfg.R, kappa_h=p.kappa * self.cfg.h,
                 **self.stability(orbit=branch != "fundamental"))
        d.setdefault("mode_amplitude", 0.0)
        d.update(extra)
        return d

    def destroy(self) -> None:
        """Free the stability and Newton solvers."""
        self.stab.destroy()
        self.ns.destroy()


class SecondaryLocator:
    """The critical points of a bifurcated branch of the 1D model, located between two of its
    points (``shells.algorithms.locate.locate_between``: the generic locator, on the step re-taken
    by pseudo-arclength) where the negative count of a Fourier block rises from one point to the
    next (a secondary bifurcation: the closed sphere's deep dimple turning polygonal), or
    dκ/ds changes sign (a fold of the branch), from the side's third point on (next to the
    bifurcation the neighbouring degrees of a sphere's cluster cross as the dimple forms, and
    the branch turns sharply: the tangent at its first point need not point to the second).
    Block m = 1 of a closed shell is left out: its lowest mode there is the dimple sliding over
    the sphere, neutral and of either sign. A count that falls is not located. The surface
    model's one block mixes such orbit modes into its count: nothing is located there. The
    model is back at the later point's state afterwards."""

    def __init__(self, run: _Run, settings: Any, closed: bool) -> None:
        self.run, self.settings = run, settings
        self.on = run.cfg.model == "axisym"
        self.skip = {1} if closed else set()
        self.prev: tuple[Any, np.ndarray, dict[int, int]] | None = None
        self.points = 0  # the side's points so far
        self.found: list[dict[str, Any]] = []

    def _counts(self, rec: dict[str, Any]) -> dict[int, int]:
        return {m: c for m, c in enumerate(rec.get("negative_counts") or [])
                if m not in self.skip}

    def resume(self, rec: dict[str, Any], state: np.ndarray) -> None:
        """Start from a resumed side's last point (its record and state)."""
        from shells.algorithms.continuation import Point

        if self.on:
            p = Point(index=rec["index"], kappa=rec["kappa"], kappa_L=rec["kappa_L"],
                      newton_its=rec["newton_its"], step=rec["step"],
                      dkappa_ds=rec["dkappa_ds"], wall_time=rec["wall_time"])
            self.prev = (p, np.asarray(state).copy(), self._counts(rec))
            self.points = int(rec["index"]) + 1

    def step(self, p: Any, state: np.ndarray, rec: dict[str, Any], kappa_c: float
             ) -> list[dict[str, Any]]:
        """The critical points between the last point and ``p`` (records), if any."""
        from shells.algorithms.locate import locate_between

        if not self.on:
            return []
        counts = self._counts(rec)
        prev, self.prev = self.prev, (p, state.copy(), counts)
        self.points += 1
        if prev is None or self.points < 3:
            return []
        p0, w0, c0 = prev
        rises = any(counts.get(m, 0) > c for m, c in c0.items())
        fold = (p0.dkappa_ds >= 0) != (p.dkappa_ds >= 0)
        if not (rises or fold):
            return []
        # blocks whose count fell are left as they were at the later point: not searched
        base = {m: (c if counts.get(m, 0) > c else counts.get(m, 0)) for m, c in c0.items()}
        cfg = self.run.cfg
        try:
            found = locate_between(self.run.model, self.settings, p0, w0, base, p, state,
                                   counts, stab=self.run.stab)
        except RuntimeError as e:
            log.warning("postbuckle: the critical point between kappa R = %.6g and %.6g was "
                        "not located: %s", p0.kappa * cfg.R, p.kappa * cfg.R, e)
            return []
        out = [{"kind": c.kind, "kappa": c.kappa, "kappa_R": c.kappa * cfg.R,
                "kappa_h": c.kappa * cfg.h, "kappa_over_kappa_c": c.kappa / kappa_c,
                "mode_m": c.mode_m, "block": c.block, "accuracy": float(c.accuracy),
                "kappa_R_bracket": [float(c.kappa_lo * cfg.R), float(c.kappa_hi * cfg.R)],
                "negative_before": c.negative_before, "negative_after": c.negative_after}
               for c in found]
        for c in out:
            log.info("postbuckle: %s of the bifurcated branch at kappa R = %.6f (%.4f kappa_c),"
                     " m = %s", c["kind"], c["kappa_R"], c["kappa_over_kappa_c"], c["mode_m"])
        self.found.extend(out)
        return out


@dataclass
class SideResume:
    """A side interrupted after some points: its ``side``, the ``records`` of its points
    (indices 0 to k, as written) and the ``switch`` state after point k (a
    ``shells.algorithms.records.SwitchResume``) that ``switch_branch`` resumes from."""

    side: int
    records: list[dict[str, Any]]
    switch: Any


def _settings(cfg: PostbuckleConfig, kappa_stop: float) -> tuple[Any, Any]:
    from shells.algorithms.settings import ContinuationSettings, CriticalSettings

    lam = abs(kappa_stop) * cfg.L
    closed = cfg.shape.closed
    # a closed sphere's axisymmetric modes of neighbouring degrees bifurcate within 1e-4 in κ:
    # short steps, and the locator's corrector deflates the near-null modes (else it lands on
    # the branches bifurcating close by: docs/model.md, "The 1D model's closed sphere")
    # (the surface model: 1/20, its steps cost a factorisation of 10⁴-10⁵ DOFs each, and the
    # locator brackets a bifurcation to 1e-4 within a step of any length)
    frac = 1.0 / 80 if closed else 1.0 / 40 if cfg.model == "axisym" else 1.0 / 20
    st = ContinuationSettings(ds=frac * lam, ds_max=frac * lam, ds_min=1e-8 * lam,
                              ds_unit="kappa", newton_tol=1e-8)
    crit = CriticalSettings(stop_at_fold=True, deflate=4 if cfg.model == "axisym" else 0)
    return st, crit


def postbuckle(cfg: PostbuckleConfig, on_point: Callable[[Any, dict[str, Any]], None] | None = None,
               *, on_critical: Callable[[Any, Any], None] | None = None,
               on_side_point: Callable[[Any, int, Any], None] | None = None,
               resume: tuple[Any, dict[int, dict[str, Any]]]
               | tuple[Any, dict[int, dict[str, Any]], SideResume | None] | None = None
               ) -> Iterator[dict[str, Any]]:
    """Compute the run of ``cfg`` (see the module docstring).

    Args:
        cfg: the run.
        on_point: called as ``on_point(model, record)`` at every point while the model holds
            its state (for fields and shapes).
        on_critical: called as ``on_critical(model, cp)`` once the bifurcation is located,
            with the ``CriticalPoint`` and its state and mode (a checkpoint).
        on_side_point: called as ``on_side_point(model, side, r)`` after a bifurcated point's
            record has been yielded (and stored by the consumer), with the ``SwitchResume`` r
            that resumes the side after it (a checkpoint).
        resume: (that ``CriticalPoint``, {side: its "side_end" record} of the sides that
            ended[, a ``SideResume``]): the fundamental branch and those sides are not
            computed again (nor yielded), the ``SideResume``'s side continues after its last
            point, the other sides are followed from the critical point.

    Yields:
        The records in order: fundamental points, {"critical_point": {...}} once, each
        side's bifurcated points and its {"side_end": {...}} record, {"summary": {...}} last.

    Raises:
        InputError: bad configuration, or a first critical point the model cannot switch at
            (a fold before the bifurcation; a non-axisymmetric bifurcation on the 1D model).
        RuntimeError: the continuation stopped short of the range, or switching failed.
    """
    pb = _Postbuckle(cfg, on_point, on_critical, on_side_point)
    try:
        yield from pb.records(resume)
    finally:
        pb.destroy()


@dataclass
class _Attempt:
    """One attempt at a side (one first amplitude): its points so far, how it ended, the
    records held back, and its locator of secondary critical points."""

    secondary: SecondaryLocator
    held: list[dict[str, Any]] = field(default_factory=list)
    n: int = 0
    first: float | None = None
    last: float | None = None
    ended: str = "stalled (step below ds_min)"
    ended_before: str | None = None


class _Postbuckle:
    """One run of ``postbuckle``: the model, the fundamental branch's settings and, once the
    bifurcation is known, the bifurcated branches' (control, pins, steps, range). The
    arguments are ``postbuckle``'s."""

    def __init__(self, cfg: PostbuckleConfig,
                 on_point: Callable[[Any, dict[str, Any]], None] | None,
                 on_critical: Callable[[Any, Any], None] | None,
                 on_side_point: Callable[[Any, int, Any], None] | None) -> None:
        self.cfg, self.on_point = cfg, on_point
        self.on_critical, self.on_side_point = on_critical, on_side_point
        self.run = _Run(cfg)
        self.kappa_stop = cfg.kappa_stop
        self.st, self.crit = _settings(cfg, self.kappa_stop)
        self.control = None
        self.phase: list[Any] = []
        self.tracked: list[Any] = [None]  # the last point's SwitchResume
        self.fundamental_points: Iterator[Any] | None = None

    def destroy(self) -> None:
        """Free the control and phase functionals and the model."""
        for v in [self.control, *self.phase]:
            if v is not None:
                v.destroy()
        self.run.destroy()

    def records(self, resume: tuple[Any, ...] | None) -> Iterator[dict[str, Any]]:
        """The run's records (``postbuckle``'s), from κ = 0 or from ``resume``."""
        cfg = self.cfg
        cp = None if resume is None else resume[0]
        done_sides = {} if resume is None else dict(resume[1])
        inside = resume[2] if resume is not None and len(resume) > 2 else None
        if cp is None:
            cp = yield from self.fundamental()
        cpd = {"kind": cp.kind, "kappa": cp.kappa, "kappa_R": cp.kappa * cfg.R,
               "kappa_h": cp.kappa * cfg.h, "mode_m": cp.mode_m, "mode_n": cp.mode_n,
               "multiplicity": cp.multiplicity, "accuracy": cp.accuracy,
               "kappa_R_bracket": [cp.kappa_lo * cfg.R, cp.kappa_hi * cfg.R]}
        log.info("postbuckle: bifurcation at kappa R = %.6f (kappa h = %.6f), m = %s, n = %s",
                 cpd["kappa_R"], cpd["kappa_h"], cp.mode_m, cp.mode_n)
        if resume is None:
            if self.on_critical is not None:
                self.on_critical(self.run.model, cp)
            yield {"critical_point": cpd}
        else:
            log.info("postbuckle: resumed at the critical point; side(s) %s already done",
                     sorted(done_sides) or "none")
        self.side_settings(cp)
        sides = {}
        for side in (float(s) for s in cfg.sides):
            if int(side) in done_sides:
                sides[int(side)] = {k: v for k, v in done_sides[int(side)].items()
                                    if k != "side"}
                continue
            cont = inside if inside is not None and inside.side == int(side) else None
            sides[int(side)] = yield from self.side(cp, side, cont)
        yield {"summary": {"sides": sides, "dofs": self.run.model.num_dofs()}}

    def fundamental(self) -> Iterator[dict[str, Any]]:
        """The fundamental branch's records up to its ``cfg.at``-th bifurcation.

        Returns:
            That bifurcation's ``CriticalPoint``.

        Raises:
            InputError: a fold first, or (1D model) a loss of stability to m > 0 modes.
            RuntimeError: no such bifurcation in the range.
        """
        from shells.algorithms.following import follow

        cfg, run = self.cfg, self.run
        bifs = []
        # held by the run object: closed (its locator freed) when the run is released
        self.fundamental_points = follow(run.model, self.st, self.kappa_stop, self.crit,
                                         solver=run.ns)
        for p, _, found in self.fundamental_points:
            rec = run.record(p, "fundamental")
            for c in found:
                if c.kind == "fold":
                    raise InputError(f"the fundamental branch reaches a fold at kappa R = "
                                     f"{c.kappa * cfg.R:.6g} before bifurcation {cfg.at}: "
                                     "nothing to switch to (shells critical shows the fold)")
                bifs.append(c)
            if cfg.model == "axisym" and any(rec["negative_counts"][1:]) and not bifs:
                ms = [m for m, c in enumerate(rec["negative_counts"]) if c and m > 0]
                raise InputError(
                    f"the fundamental branch loses stability to the non-axisymmetric mode(s) "
                    f"m = {ms} by kappa R = {rec['kappa_R']:.5g}: the 1D model follows "
                    "axisymmetric branches only; use --model surface")
            if self.on_point is not None:
                self.on_point(run.model, rec)
            yield rec
            if len(bifs) >= cfg.at:
                return bifs[cfg.at - 1]
        raise RuntimeError(f"no bifurcation {cfg.at} on the fundamental branch up to "
                           f"kappa R = {self.kappa_stop * cfg.R:.6g}")

    def side_settings(self, cp: Any) -> None:
        """The bifurcated branches' settings at the bifurcation ``cp``: the control (a
        closed shell's pole dimple), the phase functionals, the steps, the range, pins,
        deflation and first amplitudes."""
        from shells.algorithms.settings import ContinuationSettings

        cfg, run = self.cfg, self.run
        lam_c = abs(cp.kappa_L)
        # a closed shell with a pole (the sphere): the dimple at the pole, its depth the
        # branch's parameter (steps in thicknesses of depth; on the 1D model arclength steps
        # slide onto other branches of the cluster, their path depending on the first
        # amplitude and on round-off; the surface model's multiplet has no preferred member)
        self.dimple = dimple = (cfg.shape.closed and getattr(cfg.shape, "of_revolution", True)
                                and getattr(cfg.shape, "has_pole", True)
                                and cfg.mesh_file is None)
        self.control = run.model.pole_functional() if dimple else None
        # the surface model's dimple could slide over the sphere (neutral; a near-null pair of
        # either sign on the mesh): its centre held at the pole, since at a fixed depth the
        # corrector is singular where that pair's eigenvalue crosses 0 (docs/model.md, "The 1D
        # model's closed sphere")
        self.phase = (run.model.pole_moments() if dimple and cfg.model == "surface" else [])
        self.sst = ContinuationSettings(
            ds=cfg.amplitude, ds_max=(4 * cfg.amplitude if dimple else
                                      max(4 * cfg.amplitude, 0.01 * lam_c)),
            ds_min=1e-6 * cfg.amplitude, target_newton_its=5, max_steps=cfg.max_points,
            residual_roundoff=ROUNDOFF if cfg.model == "axisym" else 0.1)
        self.k_lo, self.k_hi = sorted((cfg.kappa_min_ratio * cp.kappa, self.kappa_stop))
        # the 1D model follows its one axisymmetric mode without pins: the modes of the
        # neighbouring degrees that cross next to it are other branches, not an orbit of
        # symmetry, and a localised dimple holds every degree (pinning them fails at large
        # amplitude). The surface model pins the partner of a split pair (the pattern's
        # orientation), see switch_branch
        self.pinned = 1 if cfg.model == "axisym" else None
        self.deflate = DEFLATE if cfg.model == "axisym" else 0
        # the 1D model's first corrector next to a cluster of bifurcations is sensitive to the
        # amplitude (docs/design-notes.md, "Post-buckling runs"): a side that returns within
        # its first 3 points is retried with other amplitudes (its points are kept back until
        # then: from the third on, they stream); the surface model takes one amplitude and
        # streams its points
        self.factors = (1.0, 1.4, 2.0, 0.6) if cfg.model == "axisym" else (1.0,)

    def stop(self, kappa: float, n: int) -> str | None:
        """How the side ends after its ``n``-th point, at ``kappa`` (None: it goes on)."""
        if not (self.k_lo <= kappa <= self.k_hi):
            return "range"
        return "max_points" if n >= self.cfg.max_points else None

    def landed(self, kappa: float) -> bool:
        """Whether ``kappa`` is the end of the range."""
        return abs(kappa - self.kappa_stop) <= 1e-12 * abs(self.kappa_stop)

    def side(self, cp: Any, side: float, cont: SideResume | None
             ) -> Iterator[dict[str, Any]]:
        """One side's records: its attempts (retried at other amplitudes while one returns
        or fails within 3 points), then its {"side_end"} record.

        Args:
            cp: the bifurcation.
            side: +1 or -1.
            cont: the side's ``SideResume`` (None: from the bifurcation).

        Returns:
            The side's summary (the "side_end" record without ``side``).
        """
        cfg = self.cfg
        amps = ([cont.records[0]["first_amplitude"]] if cont is not None
                else [f * cfg.amplitude for f in self.factors])
        for i, amp in enumerate(amps):
            a = yield from self.attempt(cp, side, amp, cont, i == len(amps) - 1)
            if not a.ended.startswith(("returned", "switching failed")) or a.n >= 3 \
                    or i == len(amps) - 1:
                break
            log.info("postbuckle: side %+d %s after %d points at amplitude %.3g: "
                     "retried", side, "failed" if a.n == 0 else "returned", a.n, amp)
        yield from a.held
        located = [c for r in (cont.records if cont is not None else [])
                   for c in r.get("critical", [])] + a.secondary.found
        summary = {"points": a.n, "ended": a.ended, "first_amplitude": amp,
                   "critical": located,
                   "parameter": "psi3_pole_over_h" if self.dimple else "arclength",
                   "start": None if a.first is None else (
                       "down" if abs(a.first) < abs(cp.kappa) else "up")}
        (log.warning if a.ended.startswith("switching failed") else log.info)(
            "postbuckle: side %+d: %d points, %s", side, a.n, a.ended)
        yield {"side_end": {"side": int(side), **summary}}
        return summary

    def attempt(self, cp: Any, side: float, amp: float, cont: SideResume | None,
                final: bool) -> Iterator[dict[str, Any]]:
        """One attempt at a side from first amplitude ``amp`` (or resumed from ``cont``):
        its points streamed from the third on, or all at once if it is the ``final`` one.

        Returns:
            The ``_Attempt`` (records still held back in ``held``).

        Raises:
            RuntimeError: switching failed other than by a return to the fundamental branch
                or (before any point) no first point.
        """
        cfg, run = self.cfg, self.run
        # the last point's (point, state, counts of the blocks searched) for locating
        # the critical points of the bifurcated branch (``SecondaryLocator``)
        a = _Attempt(secondary=SecondaryLocator(run, self.sst, closed=cfg.shape.closed))
        if cont is not None:
            a.secondary.resume(cont.records[-1], cont.switch.state)
            a.n, a.first, a.last = (len(cont.records), cont.records[0]["kappa"],
                                    cont.records[-1]["kappa"])
            a.ended_before = self.stop(a.last, a.n) or ("range" if self.landed(a.last) else None)
            log.info("postbuckle: side %+d resumed after its point %d (kappa R = %.6g)",
                     side, cont.switch.index, a.last * cfg.R)
        try:
            for p in self.switched_points(cp, side, amp, cont, a):
                rec = self.side_record(p, a, cp, side, amp)
                a.held.append(rec)
                if a.n >= 3 or final:  # no retry can drop them now
                    yield from a.held
                    a.held = []
                    if self.on_side_point is not None:
                        self.on_side_point(run.model, int(side), self.tracked[0])
                ended_now = self.stop(p.kappa, a.n)
                if ended_now is not None:
                    a.ended = ended_now
                    break
            else:
                if a.ended_before is not None:
                    a.ended = a.ended_before
                elif a.n and self.landed(a.last):
                    a.ended = "range"
        except RuntimeError as e:
            if "back on the fundamental branch" in str(e):
                a.ended = "returned to the fundamental branch"
            elif a.n == 0 and "did not converge off the fundamental branch" in str(e):
                # no first point at any of switch_branch's amplitudes: the next factor, and
                # past the last the side is reported as failed, not the run (a first
                # corrector next to a cluster of bifurcations can diverge: docs/model.md,
                # "The 1D model's closed sphere")
                a.ended = f"switching failed: {e}"
            else:
                raise
        return a

    def switched_points(self, cp: Any, side: float, amp: float, cont: SideResume | None,
                        a: _Attempt) -> Iterator[Any]:
        """The bifurcated branch's points (``switch_branch``; none if the resumed side had
        ended). Landing target: the end of the range (a supercritical branch lands on it);
        a subcritical one turns back and ends below ``kappa_min_ratio`` κ_c."""
        from shells.algorithms.switching import switch_branch

        if a.ended_before is not None:
            return iter(())
        track = (None if self.on_side_point is None
                 else (lambda r: self.tracked.__setitem__(0, r)))
        return switch_branch(
            self.run.model, cp, self.sst, self.kappa_stop, ds=amp, solver=self.run.ns,
            sign=side, pinned=self.pinned, min_amplitude=0.1, deflate=self.deflate,
            resume=None if cont is None else cont.switch, track=track, control=self.control,
            cluster=max(CLUSTER, cp.multiplicity or 1) if self.dimple else 1,
            response=self.dimple and self.cfg.model == "surface", phase=self.phase)

    def side_record(self, p: Any, a: _Attempt, cp: Any, side: float, amp: float
                    ) -> dict[str, Any]:
        """The record of the bifurcated point ``p`` (its secondary critical points
        located), counted in ``a`` and handed to ``on_point``."""
        from shells.problem.interface import get_state

        run = self.run
        if a.first is None:
            a.first = p.kappa
        a.last = p.kappa
        start = "down" if abs(a.first) < abs(cp.kappa) else "up"
        rec = run.record(p, "bifurcated", side=int(side), start=start,
                         subcritical=start == "down", first_amplitude=amp)
        found = a.secondary.step(p, get_state(run.model), rec, cp.kappa)
        if found:
            rec["critical"] = found
        a.n += 1
        if self.on_point is not None:
            self.on_point(run.model, rec)
        return rec


def read_postbuckle(path: str | os.PathLike) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """Read a post-buckling file.

    Args:
        path: the ``postbuckle.jsonl`` file.

    Returns:
        (header, records); a torn last line is ignored.
    """
    return read_with_header(path)


def run_postbuckle(cfg: PostbuckleConfig, outdir: str | os.PathLike | None = None,
                   comm: Any = None,
                   on_point: Callable[[Any, dict[str, Any]], None] | None = None
                   ) -> list[dict[str, Any]]:
    """``postbuckle`` with its records stored as they are computed, and resumed on a rerun.

    Args:
        cfg: the run.
        outdir: the folder of ``postbuckle.jsonl`` (written by rank 0), ``critical_point/``
            and ``side_checkpoint/``; None: nothing is written or resumed.
        comm: the communicator (default ``MPI.COMM_WORLD``).
        on_point: as for ``postbuckle``.

    Returns:
        All records of the run, the kept ones of a resumed file first. A rerun of the same
        configuration reuses a complete file and resumes an incomplete one from its critical
        point (see the module docstring).
    """
    from mpi4py import MPI

    comm = MPI.COMM_WORLD if comm is None else comm
    header = cfg.describe()
    path = Path(outdir) / "postbuckle.jsonl" if outdir is not None else None
    kept: list[dict[str, Any]] = []
    resume = None
    if path is not None:
        old = None
        if comm.rank == 0 and path.exists():
            old = read_postbuckle(path)
        old = comm.bcast(old, root=0)
        if old is not None and old[0] == header and old[1] and "summary" in old[1][-1]:
            log.info("postbuckle: reusing the complete run in %s", path)
            return old[1]
        if old is not None and old[0] == header:
            kept, done = _resumable(old[1])
            cp = _load_critical(Path(outdir), comm, header) if kept else None
            if cp is not None:
                inside = _load_side(Path(outdir), comm, header, cp, old[1], done)
                kept += [] if inside is None else inside.records
                resume = (cp, done, inside)
            else:
                kept = []
        if comm.rank == 0:
            write_header(path, header, kept)
        comm.barrier()

    def save(model: Any, cp: Any) -> None:
        if path is not None:
            _save_critical(Path(outdir), model, cp, comm, header)
            if comm.rank == 0:  # an earlier run's side: not of this critical point
                (Path(outdir) / SIDE_CHECKPOINT / "meta.json").unlink(missing_ok=True)

    def save_side(model: Any, side: int, r: Any) -> None:
        save_checkpoint(Path(outdir) / SIDE_CHECKPOINT, comm, r.index,
                        {"state": r.state, "state_prev": r.state_prev},
                        {"side": side, "header": header, "switch": r.scalars()})

    from shells.progress import Progress

    recs = list(kept)
    # the share is not known beforehand (a side's length is its branch's): points, κ, side
    progress = Progress("postbuckle", None, comm)
    for rec in postbuckle(cfg, on_point, on_critical=save,
                          on_side_point=None if path is None else save_side, resume=resume):
        recs.append(rec)
        if path is not None and comm.rank == 0:
            append_record(path, rec)
        if "kappa_R" in rec and "branch" in rec:
            progress.update(rec["kappa_R"], critical=int("critical_point" in rec),
                            **({"side": rec["side"]} if "side" in rec else {}))
    progress.close()
    return recs


def _resumable(recs: list[dict[str, Any]]) -> tuple[list[dict[str, Any]], dict[int, Any]]:
    """The records a resumed run keeps (the fundamental branch, the critical point, the sides
    that ended, each with its points) and {side: its "side_end" record}; nothing without a
    critical point."""
    at = next((i for i, r in enumerate(recs) if "critical_point" in r), None)
    if at is None:
        return [], {}
    done = {int(r["side_end"]["side"]): r["side_end"] for r in recs[at + 1:] if "side_end" in r}
    kept = recs[:at + 1] + [r for r in recs[at + 1:]
                            if ("side_end" in r and int(r["side_end"]["side"]) in done)
                            or (r.get("branch") == "bifurcated" and int(r["side"]) in done)]
    return kept, done


#: the folder of the checkpoint of the side being followed
#: (``shells.analyses.store.save_checkpoint``)
SIDE_CHECKPOINT = "side_checkpoint"


def _unfinished_side(recs: list[dict[str, Any]], done: dict[int, Any]
                     ) -> tuple[int, list[dict[str, Any]]] | None:
    """The side that was being followed when the run stopped (it has points and no
    "side_end" record) and its points, or None."""
    at = next(i for i, r in enumerate(recs) if "critical_point" in r)
    pts = [r for r in recs[at + 1:] if r.get("branch") == "bifurcated"
           and int(r["side"]) not in done]
    return None if not pts else (int(pts[0]["side"]), pts)


def _load_side(outdir: Path, comm: Any, header: dict[str, Any], cp: Any,
               recs: list[dict[str, Any]], done: dict[int, Any]) -> SideResume | None:
    """The side that ``recs`` (a run's records, with its critical point) left unfinished, to
    resume after its last point that the side checkpoint holds (its later points dropped), or
    None (no such side; or its checkpoint is missing, unreadable, another run's, another
    partition's or not of these points: then the side restarts whole, as a log line says)."""
    from shells.algorithms.records import SwitchResume

    side = _unfinished_side(recs, done)
    if side is None:
        return None
    side, pts = side
    n = None if cp.state is None else np.asarray(cp.state).shape
    got = load_checkpoint(outdir / SIDE_CHECKPOINT, comm, every_rank=False,
                          check=lambda z: z["state"].shape == z["state_prev"].shape == n)
    why = "missing, incomplete, unreadable or of another rank count"
    if got is not None:
        meta, parts = got
        # (meta is rank 0's, broadcast: every rank decides alike)
        try:
            k = meta["index"]
            kept = [r for r in pts if r["index"] <= k]
            sr = SwitchResume(**meta["switch"], state=parts[0]["state"],
                              state_prev=parts[0]["state_prev"])
            if not _same_header(meta, header):
                why = "another configuration's"
            elif meta.get("side") != side or sr.index != k:
                why = "another side's"
            elif ([r["index"] for r in kept] != list(range(k + 1)) or not math.isclose(
                    kept[-1]["kappa_L"], sr.lam, rel_tol=1e-12, abs_tol=0.0)):
                why = "not of the points in the file"
            else:
                return SideResume(side, kept, sr)
        except (TypeError, KeyError, ValueError, IndexError):
            why = "corrupt"
    log.info("postbuckle: side %+d: its checkpoint is %s; the side restarts from the "
             "critical point", side, why)
    return None


def _same_header(meta: dict[str, Any], header: dict[str, Any]) -> bool:
    """Whether a checkpoint's meta (its "header") is of the run with ``header``."""
    return json.loads(json.dumps(header, default=json_default)) == meta.get("header")


def _save_critical(outdir: Path, model: Any, cp: Any, comm: Any,
                   header: dict[str, Any]) -> None:
    """The critical point's scalars, state and mode (owned values on this rank) in
    ``outdir/critical_point`` (``store.save_checkpoint``, the run's header in its meta)."""
    save_checkpoint(outdir / "critical_point", comm, 0,
                    {"state": np.asarray(cp.state), "mode": np.asarray(cp.mode),
                     "scalars": json.dumps(cp.as_dict(), default=json_default)},
                    meta={"header": header})


def _load_critical(outdir: Path, comm: Any, header: dict[str, Any]) -> Any:
    """The ``CriticalPoint`` saved by ``_save_critical`` for this configuration and rank count,
    or None on every rank (missing, incomplete, another run's or another partition's)."""
    from shells.algorithms.records import CriticalPoint

    got = load_checkpoint(outdir / "critical_point", comm, every_rank=False)
    if got is None or not _same_header(got[0], header):  # meta: the same on every rank
        log.info("postbuckle: no usable critical-point checkpoint: starting from kappa = 0")
        return None
    z = got[1][0]
    return CriticalPoint(**json.loads(str(z["scalars"])), state=z["state"].copy(),
                         mode=z["mode"].copy())


def run(cfg: Any, outdir: str | os.PathLike | None = None,
                   fields: str = "none") -> dict[str, Any]:
    """The post-buckling analysis of ``cfg``: ``run_postbuckle`` plus ParaView output.

    Args:
        cfg: a ``PostbuckleConfig``.
        outdir: the output folder (None: nothing written).
        fields: which bifurcated states to write for ParaView: "none", "last" or "all"
            (needs ``outdir``).

    Returns:
        {"config", "critical_point", "points", "sides" (the sides' summaries), "dofs",
        "branch_file", "files"}.
    """
    from shells.analyses.writers import ShapeWriter

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
