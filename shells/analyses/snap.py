"""Where a snap lands (analysis layer): ``run``.

A cap loaded past its snap fold has no nearby equilibrium: it jumps. ``run`` follows the
fundamental branch from κ = 0 to its first fold (``shells.algorithms.following.follow``),
takes the state at the fold to κ_start = (1 + ``past``) κ_fold (or a given κ beyond it),
perturbs it along the Hessian's unstable eigenvectors there (an exactly symmetric start would
stay symmetric) and minimises the energy at κ_start (``shells.algorithms.minimise``, TAO's
Newton with negative curvature). The minimum it reaches is the landing state: confirmed by the
Hessian's inertia (no negative eigenvalue beyond the symmetry orbit's), classified by the
azimuthal spectrum of its normal displacement (``symmetric`` when no m ≥ 1 carries more than
``SYMMETRY_TOL`` of the m = 0 amplitude; else ``mode_m``, the strongest), and compared with the
axisymmetric everted state at the same κ (Newton from the shell mirrored through its rim plane,
continued in κ from half the fold's κ).

Output folder (rank 0 writes): ``snap.json`` (the result), ``landing.png`` and ``landing.vtu``
(the landing shape coloured by the bending energy density), ``everted.png``, and
``checkpoint/`` (the fold's state, then the minimiser's iterate every ``SAVE_EVERY``
iterations): a rerun of the same configuration resumes from the latest.
"""

from __future__ import annotations

import json
import logging
import math
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from shells.errors import InputError
from shells.files import json_default, write_atomic
from shells.parameters import check_h_over_r, check_nu

__all__ = ["SAVE_EVERY", "SYMMETRY_TOL", "SnapConfig", "classify_landing", "run"]

log = logging.getLogger("shells")

#: a landing state is symmetric when no m ≥ 1 has more than this share of the m = 0 amplitude
SYMMETRY_TOL = 1.0e-2
#: the minimiser's iterate is checkpointed every this many iterations
SAVE_EVERY = 10


@dataclass(frozen=True)
class SnapConfig:
    """A snap computation on the surface model.

    Attributes:
        shape: an open shell of revolution (a cap, an ellipsoidal cap).
        h_over_r: thickness over the shape's length scale.
        nu: Poisson's ratio.
        method: "minimise" (TAO; the landing state at κ_start).
        past: κ_start = (1 + past) κ_fold, where ``kappa_R`` is None.
        kappa_R: κ_start R, past the fold (None: from ``past``).
        amplitude: the perturbation along each unstable eigenvector, RMS over the thickness.
        kappa_R_max: the fold is searched up to this κR (None: 2 θ̄ + 6, as ``critical``).
        size, degree: the mesh (None: ``default_discretisation``).
        layer_elements: elements across the rim's boundary layer.
        shear_penalty: the Kirchhoff-Love penalty factor.

    Raises:
        InputError: on construction, for a parameter out of range, a closed shape (which
            buckles, it does not snap) or a method other than those named.
    """

    # the shell
    shape: Any
    h_over_r: float
    nu: float = 0.5
    # the snap: where it lands and how
    method: str = "minimise"
    past: float = 0.01
    kappa_R: float | None = None  # noqa: N815
    amplitude: float = 0.1
    kappa_R_max: float | None = None  # noqa: N815
    size: float | None = None
    degree: int | None = None
    layer_elements: float = 4.0
    shear_penalty: float = 1.0e3

    def __post_init__(self) -> None:
        check_h_over_r(self.h_over_r)
        check_nu(self.nu)
        if getattr(self.shape, "closed", False):
            raise InputError("snap needs an open shell (a cap): a closed sphere buckles, it "
                             "does not snap through")
        if self.method != "minimise":
            raise InputError(f"method must be 'minimise', got {self.method!r}")
        if not (0 < self.past <= 1):
            raise InputError(f"past must lie in (0, 1], got {self.past!r}")
        if not (self.amplitude > 0 and math.isfinite(self.amplitude)):
            raise InputError(f"amplitude must be a positive number, got {self.amplitude!r}")

    def describe(self) -> dict[str, Any]:
        """Everything that decides the run's numbers, as plain data."""
        d = asdict(self)
        d["shape"] = self.shape.describe()
        return d


def classify_landing(model: Any) -> dict[str, Any]:
    """The landing state's stability, symmetry and shape (collective).

    Args:
        model: the surface model holding the state.

    Returns:
        ``energy``, ``negative_count`` (all negative eigenvalues), ``orbit_modes`` (those along
        the symmetry orbit, neutral in the continuum), ``stable`` (no negative eigenvalue but
        the orbit's), ``symmetric``, ``mode_m`` (0 when symmetric), ``spectrum`` (the amplitude
        of each m over that of m = 0), ``rim_rotation_deg``, ``psi3_pole_over_h``.
    """
    from shells.algorithms.stability import Stability

    stab = Stability(model)
    neg, orbit = stab.negative_count_modulo_orbit()
    stab.destroy()
    power = model.azimuthal_spectrum(model.state)
    amp = np.sqrt(power / max(power[0], 1e-300))
    symmetric = bool(np.max(amp[1:]) < SYMMETRY_TOL)
    s = model.scalars()
    return {"energy": s["energy"], "negative_count": int(neg), "orbit_modes": int(orbit),
            "stable": bool(neg - orbit == 0), "symmetric": symmetric,
            "mode_m": 0 if symmetric else int(1 + np.argmax(amp[1:])),
            "spectrum": [float(a) for a in amp], "rim_rotation_deg": s.get("rim_rotation_deg"),
            "psi3_pole_over_h": s.get("psi3_pole_over_h")}


def _model(cfg: SnapConfig, comm: Any) -> tuple[Any, Any, dict[str, Any]]:
    """The surface model of ``cfg`` (at κ = 0), its mesh, and the discretisation used."""
    from shells.surface.mesh import MeshSpec, generate
    from shells.surface.model import ModelParameters, ShellModel, default_discretisation

    degree, size = default_discretisation(cfg.shape, cfg.h_over_r, cfg.degree, cfg.size,
                                          None, cfg.nu)
    h = cfg.h_over_r * cfg.shape.characteristic_size()
    sm = generate(MeshSpec(cfg.shape, h=h, size=size, layer_elements=cfg.layer_elements), comm)
    params = ModelParameters(h=h, nu=cfg.nu, shear_penalty=cfg.shear_penalty, degree=degree,
                             quadrature_degree=2 * degree)
    return ShellModel(sm, params), params, {"size": size, "degree": degree,
                                            "layer_elements": cfg.layer_elements}


def _to_fold(model: Any, cfg: SnapConfig, R: float) -> tuple[float, np.ndarray, list[dict]]:
    """Follow the fundamental branch to its first fold: (κ_fold, the state there, the critical
    points on the way as records)."""
    from shells.algorithms.following import follow
    from shells.algorithms.settings import ContinuationSettings, CriticalSettings
    from shells.analyses.critical import REUSE_SURFACE
    from shells.progress import Progress

    L = cfg.shape.characteristic_size()
    tb = cfg.shape.theta / math.sqrt(cfg.h_over_r) if hasattr(cfg.shape, "theta") else 5.0
    kR_end = cfg.kappa_R_max if cfg.kappa_R_max is not None else 2.0 * tb + 6.0
    lam_end = kR_end / R * L
    st = ContinuationSettings(ds=lam_end / 16, ds_max=lam_end / 10, ds_min=1e-7 * lam_end,
                              factor_reuse=REUSE_SURFACE, ds_unit="kappa")
    progress = Progress("snap: to the fold", kR_end, model.comm)
    records: list[dict[str, Any]] = []
    fold = None
    for p, res, found in follow(model, st, kR_end / R, CriticalSettings(stop_at_fold=True)):
        progress.update(p.kappa * R, critical=len(records), negative=res.negative_count)
        for c in found:
            records.append({"kind": c.kind, "kappa_R": c.kappa * R, "mode_m": c.mode_m})
            log.info("  %s at kappa R = %.6f, m = %s", c.kind, c.kappa * R, c.mode_m)
            if c.kind == "fold" and fold is None:
                fold = c
    progress.close()
    if fold is None:
        raise InputError(f"no snap fold up to kappa R = {kR_end:g}: this shell does not snap "
                         f"there (a larger --kappa-R-max, or `shells critical` to see why)")
    return fold.kappa, np.asarray(fold.state), records


def _everted(sm_model: Any, params: Any, kappa: float, kappa_fold: float) -> dict[str, Any]:
    """The axisymmetric everted state at ``kappa``: Newton from the shell mirrored through its
    rim plane, continued in κ from where the mirror is (close to) an equilibrium: κ = 2/R on a
    spherical cap (there the mirror is one exactly), else half the fold's κ or less."""
    from shells.algorithms.continuation import continuation
    from shells.algorithms.settings import ContinuationSettings
    from shells.algorithms.stability import Stability
    from shells.geometry.shapes import SphericalCap
    from shells.surface.model import ShellModel

    ev = ShellModel(sm_model.shell, params)
    L = ev.length_scale()
    lam = abs(kappa_fold) * L
    nat = ContinuationSettings(method="natural", ds=0.1 * lam, ds_max=0.1 * lam,
                               ds_min=1e-4 * lam, max_newton_its=25)
    starts = [0.5 * kappa_fold, 0.35 * kappa_fold, 0.25 * kappa_fold]
    if isinstance(ev.shape, SphericalCap):
        starts.insert(0, 2.0 / ev.shape.R)
    for start in starts:
        ev.set_everted_guess()
        reached = False
        try:
            for q in continuation(ev, nat, kappa_start=start, kappa_end=kappa, scalars=False):
                reached = abs(q.kappa - kappa) <= 1e-9 * abs(kappa)
        except RuntimeError as e:
            log.info("snap: the everted state from kappa R = %.4g not reached (%s)",
                     start * L, e)
        if reached:
            stab = Stability(ev)
            neg = stab.inertia()[0]
            stab.destroy()
            s = ev.scalars()
            return {"energy": s["energy"], "negative_count": int(neg),
                    "rim_rotation_deg": s.get("rim_rotation_deg"), "model": ev}
    return {"energy": None, "negative_count": None, "model": None}


def run(cfg: SnapConfig, outdir: str | Path | None = None, *, render: bool = True,
        resume: bool = True) -> dict[str, Any]:
    """Where the shell of ``cfg`` lands when it snaps (the surface model; collective).

    Args:
        cfg: the shell and the run's settings.
        outdir: the output folder (None: nothing written or resumed).
        render: draw ``landing.png`` and ``everted.png`` (needs pyvista).
        resume: resume from ``outdir/checkpoint`` when it is of the same configuration.

    Returns:
        ``start`` ({"kappa_R", "kind": "fold", "kappa_fold_R", "unstable": [{eigenvalue,
        mode_m}]}), ``method``, ``landing`` (``classify_landing`` plus ``kappa_R``,
        ``iterations``, ``converged``), ``axisymmetric_everted`` ({"energy",
        "negative_count", "rim_rotation_deg"}), ``snap_time`` (None: minimisation has no
        time), ``critical_points``, ``dofs``, ``mesh``, ``wall_time``.

    Raises:
        InputError: no fold in the range, or κ_start not past the fold.
        RuntimeError: the minimiser stopped without converging.
    """
    from mpi4py import MPI

    from shells.algorithms.minimise import minimise_to_stable, perturb_unstable
    from shells.algorithms.settings import MinimiseSettings
    from shells.analyses.store import load_state_checkpoint, save_state_checkpoint
    from shells.geometry.shapes import kappa_length
    from shells.problem.interface import set_state

    comm = MPI.COMM_WORLD
    t0 = time.perf_counter()
    R = kappa_length(cfg.shape)
    model, params, mesh = _model(cfg, comm)
    out = Path(outdir) if outdir is not None else None
    ck = out / "checkpoint" if out is not None else None
    header = json.loads(json.dumps(cfg.describe(), default=json_default))
    got = (load_state_checkpoint(ck, model, ("w",)) if ck is not None and resume else None)
    if got is not None and got[0].get("header") != header:
        got = None
    if got is not None:
        # the checkpoint's own bookkeeping (its index, its ranks) is not carried forward
        meta = {k: v for k, v in got[0].items() if k not in ("index", "ranks")}
        states = got[1]
        kappa_fold, cps = meta["kappa_fold"], meta["critical_points"]
        log.info("snap: resuming from the checkpoint (%s)", meta["stage"])
    else:
        log.info("snap: %s, %d DOFs: following the fundamental branch to its snap fold",
                 cfg.shape.describe(), model.num_dofs())
        kappa_fold, w_fold, cps = _to_fold(model, cfg, R)
        meta = {"header": header, "kappa_fold": kappa_fold, "critical_points": cps,
                "stage": "fold"}
        states = {"w": w_fold}
        if ck is not None:
            save_state_checkpoint(ck, model, 0, states, meta=meta)
    kappa = cfg.kappa_R / R if cfg.kappa_R is not None else (1.0 + cfg.past) * kappa_fold
    if not kappa * np.sign(kappa_fold) > abs(kappa_fold):
        raise InputError(f"kappa R = {kappa * R:g} is not past the snap fold at kappa R = "
                         f"{kappa_fold * R:.6g}")
    set_state(model, states["w"])
    model.set_kappa(kappa)
    unstable = meta.get("unstable")
    if meta["stage"] == "fold":
        unstable = perturb_unstable(model, cfg.amplitude)
        log.info("snap: at kappa R = %.6f (%.3g past the fold), %d unstable direction(s): "
                 "m = %s", kappa * R, kappa / kappa_fold - 1, len(unstable),
                 [u["mode_m"] for u in unstable])

    def save(tao: Any) -> None:
        it = tao.getIterationNumber()
        if ck is not None and it % SAVE_EVERY == 0 and it > 0:
            save_state_checkpoint(ck, model, it, {"w": tao.getSolution().array_r.copy()},
                                  meta={**meta, "stage": f"minimise {it}",
                                        "unstable": unstable})
        if comm.rank == 0 and it % SAVE_EVERY == 0:
            _, f, gnorm, *_ = tao.getSolutionStatus()
            log.info("snap: minimise iteration %d, energy %.10g, |gradient| %.3g", it, f, gnorm)

    res = minimise_to_stable(model, MinimiseSettings(), amplitude=cfg.amplitude, monitor=save)
    if not res.converged:
        raise RuntimeError(f"the minimiser stopped without converging ({res.reason}, "
                           f"|gradient| {res.gradient_norm:.3g} after {res.iterations} "
                           "iterations): rerun to resume, or use a smaller --past")
    landing = {"kappa_R": kappa * R, **classify_landing(model), "iterations": res.iterations,
               "converged": res.converged, "gradient_norm": res.gradient_norm}
    log.info("snap: landed at energy %.10g: %s, %s, negative %d (orbit %d)", landing["energy"],
             "stable" if landing["stable"] else "UNSTABLE",
             "symmetric" if landing["symmetric"] else f"m = {landing['mode_m']}",
             landing["negative_count"], landing["orbit_modes"])
    if out is not None and render:
        from shells.analyses.render import render_state

        render_state(model, out / "landing.png", vtu=out / "landing.vtu",
                     title=f"landing state, kappa R = {kappa * R:.4f}"
                     + ("" if landing["symmetric"] else f", m = {landing['mode_m']}"))
    ev = _everted(model, params, kappa, kappa_fold)
    ev_model = ev.pop("model")
    if out is not None and render and ev_model is not None:
        from shells.analyses.render import render_state

        render_state(ev_model, out / "everted.png",
                     title=f"axisymmetric everted state, kappa R = {kappa * R:.4f}")
    result = {"start": {"kappa_R": kappa * R, "kind": "fold", "kappa_fold_R": kappa_fold * R,
                        "unstable": unstable},
              "method": cfg.method, "landing": landing, "axisymmetric_everted": ev,
              "snap_time": None, "critical_points": cps, "dofs": model.num_dofs(),
              "mesh": mesh, "config": header, "wall_time": time.perf_counter() - t0}
    if out is not None and comm.rank == 0:
        write_atomic(out / "snap.json", json.dumps(result, indent=1, default=json_default))
    return result
