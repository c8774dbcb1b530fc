"""Imperfection sensitivity of the closed sphere's curvature buckling (driver layer).

The stress-free reference surface carries an axisymmetric imperfection of amplitude δ
(``shells.geometry.imperfections.ImperfectSphere``: a pole dimple or the buckling mode's shape), or
on the surface model a spherical harmonic P_n^m(cos θ) cos(mφ) (``HarmonicImperfectSphere``,
imperfection "harmonic": not axisymmetric for m > 0); κ is imposed on it as on a perfect
sphere. With rotational symmetry enforced (the 1D model's axisymmetric
problem, as in the paper and in the pressure-buckling literature) the perfect sphere's
bifurcation becomes a limit point: the imperfect branch is followed from κ = 0 with the
common algorithm layer (``shells.algorithms.following.follow``, folds only) up to its fold κ_max,
and the knock-down is κ_max/κ_b, κ_b the perfect sphere's first axisymmetric bifurcation (same mesh,
same code path, δ = 0). Points are appended to a JSON-lines file as computed; a rerun with the
same configuration skips the amplitudes already there.

Asymptotics: at the perfect sphere's bifurcation Koiter's reduced equation is computed
(``shells.algorithms.asymptotics``; ∂R/∂δ from two imperfect models at ±δ on the same mesh): its
kind (asymmetric for an even buckling degree n, symmetric at that order for an odd one) and, where
it gives one, the small-δ law 1 - κ_max/κ_b = C √δ, reported beside every computed point. The
law also sets the steps near the fold: at small δ the fold lies within C √δ κ_b of κ_b and
turns sharply, so the branch is taken there by natural steps and followed from 4 C √δ below
κ_b with steps of a quarter of that distance.
"""

from __future__ import annotations

import json
import logging
import math
from collections.abc import Iterator
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

from shells.errors import InputError
from shells.files import append_record, json_default, read_with_header, write_header
from shells.parameters import check_h_over_r, check_model, check_nu

log = logging.getLogger("shells")

__all__ = ["KnockdownConfig", "fold_kappa", "knockdown", "run"]

#: how a point is computed; part of a points file's key, so that a rerun never reads back
#: points of another method. Changed with every change of the search (what each version
#: changed: docs/design-notes.md, "Knock-down search")
METHOD = "first-critical-point/5"
#: ∂R/∂δ by central differences at δ/h = ±this (R is linear in δ to well below the
#: difference's own error there: docs/design-notes.md, "Knock-down search")
DELTA_FD = 1.0e-3
#: after a crossing, at most this many points are followed while looking for the fold within
#: the location tolerance (a safety limit: the window in κ ends the search first)
MAX_POINTS_AFTER_CROSSING = 50


@dataclass(frozen=True)
class KnockdownConfig:
    """One knock-down curve (validated).

    Attributes:
        h_over_r: thickness over the sphere's radius.
        amplitudes: imperfection amplitudes δ/h (≥ 0; 0 is the perfect sphere).
        nu: Poisson ratio.
        imperfection: "dimple" (w0 = -δ h exp(-(β/β0)²)), "mode" (w0 = -δ h P_n(cos β)) or
            "harmonic" (w0 = -δ h P_n^m(cos θ) cos(mφ) / max|P_n^m|, the surface model only:
            ``shells.geometry.imperfections.HarmonicImperfectSphere``; m = 0 is "mode").
        load: "curvature" (the natural curvature κ) or "pressure" (a dead external pressure,
            continued in its equivalent curvature κ_p of the paper's Eq. (5); κ_b is then the
            buckling pressure's, classically 12 (1-ν)/√(3(1-ν²)) in κ_p h): the same code
            path, one load parameter of the 1D model (``AxisymParameters.load``).
        width: the dimple's β0 in units of sqrt(h/R).
        degree: the mode's (the harmonic's) degree n (None: the perfect sphere's critical
            degree, located; the surface model: the thin-shell theory's, rounded).
        order: the harmonic's order m (0 <= m <= n; "harmonic" only).
        model: "axisym" (1D, rotational symmetry enforced) or "surface" (2D: every mode can
            appear, κ_max is the first critical point of any kind; no reduced equation).
        size, element_degree: the surface model's bulk element size and degree (P3: P2 locks
            on spheres); a dimple is meshed with β0 / 4 at the pole (``shells.surface.mesh``).
        cells, penalty: the 1D mesh's bulk cells (None: the default) and C1 penalty. The
            penalty ties the slopes to the displacement to O(1/penalty), which on a closed
            sphere acts as a pole-localised imperfection of its own, large enough at the 1D
            model's default to spoil the small-δ end of a curve; 1e6 (default) puts it out of
            reach (docs/imperfections.md, "Method").

    Raises:
        InputError: on construction, for a value out of its range or an inconsistent
            combination (a harmonic imperfection on the 1D model, pressure on the surface
            model, an order m > 0 without "harmonic" or above the degree).
    """

    h_over_r: float
    amplitudes: tuple[float, ...]
    nu: float = 0.5
    imperfection: str = "dimple"
    width: float = 1.0
    load: str = "curvature"
    degree: int | None = None
    cells: int | None = None
    penalty: float = 1.0e6
    model: str = "axisym"
    size: float = 0.21
    element_degree: int = 3
    order: int = 0

    def __post_init__(self) -> None:
        check_h_over_r(self.h_over_r)
        amps = tuple(float(a) for a in self.amplitudes)
        if not amps or not all(math.isfinite(a) and 0 <= a <= 10 for a in amps):
            raise InputError("give imperfection amplitudes delta/h in [0, 10]")
        object.__setattr__(self, "amplitudes", amps)
        check_nu(self.nu)
        check_model(self.model)
        if self.model == "surface" and self.load != "curvature":
            raise InputError("the surface model's knock-down is for natural curvature only "
                             "(--load pressure: use --model axisym)")
        if not (math.isfinite(self.size) and 0.02 <= self.size <= 1.0):
            raise InputError(f"the surface mesh size must lie in [0.02, 1], got {self.size!r}")
        if self.element_degree not in (2, 3):
            raise InputError(f"element degree must be 2 or 3, got {self.element_degree!r}")
        if self.load not in ("curvature", "pressure"):
            raise InputError(f"load must be 'curvature' or 'pressure', got {self.load!r}")
        if self.imperfection not in ("dimple", "mode", "harmonic"):
            raise InputError(f"imperfection must be 'dimple', 'mode' or 'harmonic', got "
                             f"{self.imperfection!r}")
        from shells.geometry.imperfections import HARMONIC_DEGREE_MAX

        if self.imperfection == "harmonic" and self.model != "surface":
            raise InputError("the harmonic imperfection is not axisymmetric: it needs the "
                             "surface model (--model surface; for m = 0 use --imperfection mode)")
        top = HARMONIC_DEGREE_MAX if self.imperfection == "harmonic" else 1000
        if self.degree is not None and not (isinstance(self.degree, int)
                                            and not isinstance(self.degree, bool)
                                            and 0 <= self.degree <= top):
            raise InputError(f"the mode degree n must be an integer in [0, {top}], got "
                             f"{self.degree!r}")
        if not (isinstance(self.order, int) and not isinstance(self.order, bool)
                and 0 <= self.order <= HARMONIC_DEGREE_MAX):
            raise InputError(f"the harmonic's order m must be an integer in [0, "
                             f"{HARMONIC_DEGREE_MAX}], got {self.order!r}")
        if self.order and self.imperfection != "harmonic":
            raise InputError("an order m > 0 is the harmonic imperfection's (--imperfection "
                             "harmonic)")
        if self.degree is not None and self.order > self.degree:
            raise InputError(f"the harmonic's order m must not exceed its degree n, got n = "
                             f"{self.degree}, m = {self.order}")
        if not (math.isfinite(self.width) and 0 < self.width <= 50):
            raise InputError(f"the dimple width must lie in (0, 50] (units of sqrt(h/R)), got "
                             f"{self.width!r}")

    def describe(self) -> dict[str, Any]:
        """The fields; ``order`` only for the harmonic imperfection, so that the keys stored
        in the other curves' points files, which have no ``order``, still match."""
        d = asdict(self)
        if self.imperfection != "harmonic":
            del d["order"]
        return d


def imperfect_model(cfg: KnockdownConfig, amplitude: float, degree: int) -> Any:
    """The 1D model of the imperfect sphere, axisymmetric blocks only.

    Args:
        cfg: the curve.
        amplitude: δ/h (0: the perfect sphere).
        degree: the mode's degree n (the "mode" and "harmonic" imperfections).

    Returns:
        (the ``AxisymModel``, its ``RunConfig``).
    """
    from shells.analyses.axisym_runs import RunConfig
    from shells.axisym import AxisymModel
    from shells.geometry.shapes import Sphere

    shape = Sphere(1.0) if amplitude == 0 else imperfect_shape(cfg, amplitude, degree)
    run = RunConfig(shape=shape, h_over_r=cfg.h_over_r, nu=cfg.nu, cells=cfg.cells,
                    penalty=cfg.penalty, m_max=0)
    model = AxisymModel(shape, replace(run.params(), load=cfg.load))
    model.modes = (0,)
    return model, run


def imperfect_shape(cfg: KnockdownConfig, amplitude: float, degree: int) -> Any:
    """The unit sphere with the imperfection of ``cfg`` at ``amplitude`` (δ/h) of ``degree``."""
    from shells.geometry.imperfections import HarmonicImperfectSphere, ImperfectSphere

    if cfg.imperfection == "harmonic":
        return HarmonicImperfectSphere(1.0, amplitude * cfg.h_over_r, degree, cfg.order)
    return ImperfectSphere(1.0, math.pi, amplitude * cfg.h_over_r, cfg.imperfection,
                           cfg.width * math.sqrt(cfg.h_over_r), degree)


def kappa_scale(cfg: KnockdownConfig) -> float:
    """The thin-shell κ_b h of the load (sets the followed range)."""
    from shells.theory import sphere_kappa_b_h, sphere_pressure_kappa_h

    return (sphere_pressure_kappa_h if cfg.load == "pressure" else sphere_kappa_b_h)(cfg.nu)


def _imperfection_derivative(cfg: KnockdownConfig, degree: int, model: Any) -> Any:
    """A callable giving ∂R/∂(δ/h) at ``model``'s current state and κ (central differences of
    two imperfect models on the same mesh)."""
    plus, _ = imperfect_model(cfg, DELTA_FD, degree)
    minus, _ = imperfect_model(cfg, -DELTA_FD, degree)

    def derivative() -> Any:
        out = model.create_vector()
        tmp = model.create_vector()
        for m, sign in ((plus, 1.0), (minus, -1.0)):
            model.state.copy(m.state)
            m.sync()
            m.set_kappa(model.get_kappa())
            m.assemble_residual(tmp)
            out.axpy(sign / (2 * DELTA_FD), tmp)
        tmp.destroy()
        return out

    return derivative


def balanced_weight(model: Any, ns: Any) -> float:
    """The arclength norm's state weight ξ that balances the tangent's state and load parts.

    At the model's current (converged) state: J z = -∂R/∂λ, ξ² cw₁ |z|² = 1 (cw₁:
    ``Arclength``'s weight at ξ = 1, the RMS over all DOFs in thicknesses).

    Args:
        model: the problem, at a converged state.
        ns: its Newton solver.

    Returns:
        ξ (1 where the state part vanishes).

    Raises:
        RuntimeError: if the Jacobian cannot be factored.
    """
    from shells.algorithms.bordered import Arclength

    ar = Arclength(ns, model.length_scale(), 1.0)
    try:
        if not ar.tangent(None, 1.0, attempts=2):
            raise RuntimeError("the Jacobian at the start of the branch could not be factored")
        ratio = 1.0 / ar.tl**2 - 1.0  # cw₁ |z|², the state part over the load part
    finally:
        ar.destroy()
    return 1.0 / math.sqrt(ratio) if ratio > 0 else 1.0


def first_critical(model: Any, ns: Any, cfg: KnockdownConfig, end: float,
                    ds_h: float | None, kappa_start: float = 0.0, balanced: bool = False,
                    window: bool = True) -> tuple[list[Any], int]:
    """The axisymmetric critical points of one attempt, up to the first fold.

    Args:
        model: the problem; its state is the branch's at ``kappa_start``.
        ns: its Newton solver.
        cfg: the curve.
        end: the κ the branch is followed to at most.
        ds_h: the steps in κh (None: the defaults), in the arclength norm of state weight 1.
        kappa_start: the start's κ.
        balanced: steps of ``ds_h`` in κ in the norm balanced at the start
            (``balanced_weight``) instead.
        window: when a crossing comes first, follow the branch on until it lies a location
            tolerance beyond it in κ (a fold within it is the first critical point,
            ``first_of``); False: stop at the first critical point.

    Returns:
        (the located points in branch order, the number of branch points followed).

    Raises:
        RuntimeError: if Newton fails at the start or on the way.
    """
    from shells.algorithms.following import follow
    from shells.algorithms.settings import CriticalSettings
    from shells.analyses.axisym_runs import default_settings
    from shells.geometry.shapes import Sphere

    steps: dict[str, Any] = {}
    if ds_h is not None:
        steps = {"ds": ds_h / cfg.h_over_r, "ds_max": ds_h / cfg.h_over_r}
    if ds_h is not None and balanced:
        # An imperfect sphere's fold mode is localised (a dimple's: within sqrt(Rh) of the
        # pole) and weakly loaded, so with the state weight 1 (the state's RMS over the whole
        # sphere, in thicknesses, against λ = κR) dκ/ds stays near 1 until the fold mode's
        # eigenvalue is at the Jacobian's round-off (docs/imperfections.md, "Method");
        # there the corrector stalls, the eigenvalue's sign flips with round-off (a pair of
        # "bifurcations" with dκ/ds > 0) and the steps fall below ds_min short of the fold. A
        # balanced norm turns the tangent where the eigenvalue is still well resolved.
        steps["ds_unit"] = "kappa"
        model.set_kappa(kappa_start)
        ok, _ = ns.solve()
        if not ok:
            raise RuntimeError(f"Newton did not converge at the start kappa = {kappa_start}")
        steps["state_weight"] = balanced_weight(model, ns)
    st = default_settings(Sphere(1.0), cfg.h_over_r, **steps)
    # every crossing is located, and the branch is followed on after the first one until it
    # lies a location tolerance beyond it in κ: a fold within that window is the first
    # critical point (``first_of``)
    crit = CriticalSettings(stop_at_fold=True, max_critical=None if window else 1)
    found: list[Any] = []
    n = after = 0
    for p, _, cps in follow(model, st, end, crit, solver=ns, kappa_start=kappa_start):
        n += 1
        found += cps
        if any(c.kind == "fold" for c in found) or (found and not window):
            break
        if found:
            # a later fold lies at or above the branch's κ here (κ > 0 on these branches)
            after += 1
            if (p.kappa - found[0].kappa > crit.rel_tol * abs(found[0].kappa)
                    or after > MAX_POINTS_AFTER_CROSSING):
                break
    return found, n


def first_of(found: list[Any], rel_tol: float) -> tuple[Any, list[Any]]:
    """The first critical point of one attempt, and the crossings located before it.

    A crossing followed by a fold within ``rel_tol`` in κ is that fold, seen early through
    its own eigenvalue: next to an imperfect sphere's fold its mode's eigenvalue reaches the
    round-off level at which it is resolved while dκ/ds is still positive, so the inertia may
    count it negative first, a "bifurcation" of the fold's own mode (pole-localised, carrying
    the load) just below the fold. The two are one critical point at the location tolerance
    (docs/imperfections.md, "Crossings just before the fold").

    Args:
        found: one attempt's critical points, in branch order.
        rel_tol: the location tolerance, relative in κ.

    Returns:
        (the first critical point or None, the crossings before it when it is such a fold).
    """
    if not found or found[0].kind == "fold":
        return (found[0] if found else None), []
    fold = next((c for c in found if c.kind == "fold"), None)
    if fold is not None and abs(fold.kappa - found[0].kappa) <= rel_tol * abs(fold.kappa):
        return fold, [c for c in found if c.kind != "fold"]
    return found[0], []


def _approach(model: Any, ns: Any, kappa: float) -> None:
    """Natural continuation from κ = 0 to ``kappa`` (far from any critical point)."""
    from shells.algorithms.continuation import continuation
    from shells.algorithms.settings import ContinuationSettings

    lam = kappa * model.length_scale()
    st = ContinuationSettings(method="natural", ds=0.1 * lam, ds_max=0.1 * lam,
                              kappa_stops=(lam,))
    for _ in continuation(model, st, kappa_start=0.0, kappa_end=kappa, solver=ns):
        pass
    # natural steps end short of ``kappa`` (below their ds_min) where a fold comes first
    if abs(model.get_kappa() - kappa) > 1e-12 * abs(kappa):
        raise RuntimeError(f"the branch was followed to kappa = {model.get_kappa():.8g} only, "
                           f"short of {kappa:.8g}: a fold before it")


def fold_kappa(cfg: KnockdownConfig, amplitude: float, degree: int,
               predicted: float | None = None, kappa_b: float | None = None
               ) -> dict[str, Any]:
    """The first axisymmetric critical point of the imperfect sphere.

    Args:
        cfg: the curve.
        amplitude: δ/h: for δ > 0 the point is its fold (limit point), for δ = 0 its
            bifurcation.
        degree: the mode's degree n.
        predicted: the asymptotic law's κ_max/κ_b, which with ``kappa_b`` sets the steps
            near a fold close to κ_b.
        kappa_b: the perfect sphere's κ_b (absolute).

    Returns:
        {"kind", "kappa_h", "mode_n", "accuracy", "branch_points"} and, where crossings of
        the fold's own eigenvalue came first, "crossings_before".

    Raises:
        RuntimeError: if no limit point is found in any attempt.
    """
    from shells.algorithms.newton import NewtonSolver
    from shells.axisym import SNES_OPTIONS

    model, run = imperfect_model(cfg, amplitude, degree)
    ns = NewtonSolver(model, options=SNES_OPTIONS)
    try:
        c, n, before = _locate_first(cfg, amplitude, model, ns, run.h, predicted, kappa_b)
    finally:
        ns.destroy()
    return _point_record(c, run.h, n, before)


def _point_record(c: Any, h: float, n: int, before: list[Any] | None = None
                  ) -> dict[str, Any]:
    r = {"kind": c.kind, "kappa_h": c.kappa * h, "mode_n": c.mode_n,
         "accuracy": c.accuracy, "branch_points": n}
    if before:  # crossings of the fold's own eigenvalue located just before it (``first_of``)
        r["crossings_before"] = [{"kappa_h": b.kappa * h, "mode_n": b.mode_n,
                                  "eigenvalue": b.eigenvalue} for b in before]
    return r


def _locate_first(cfg: KnockdownConfig, amplitude: float, model: Any, ns: Any, h: float,
                  predicted: float | None = None, kappa_b: float | None = None
                  ) -> tuple[Any, int, list[Any]]:
    """``fold_kappa``'s search on ``model`` (solver ``ns``): the located critical point
    (carrying its state and mode), the number of branch points followed and the crossings of
    the fold's own eigenvalue located just before the fold (``first_of``)."""
    from shells.algorithms.settings import CriticalSettings

    end = 1.25 * kappa_scale(cfg) / h
    perfect = amplitude == 0
    # Every critical point of the axisymmetric problem is located, and the first one decides.
    # For δ > 0 it must be the fold: the imperfect branch is stable up to its limit point. A
    # crossing first means a step went past the fold, which turns ever more sharply as δ → 0,
    # onto the neighbouring branch of the broken bifurcation (docs/design-notes.md,
    # "Knock-down search"): the run is repeated with steps 4 and 16 times shorter. A
    # crossing followed by a fold within the location tolerance is that fold (``first_of``:
    # the fold mode's eigenvalue counted negative just before the fold, where it is no
    # longer resolved; docs/imperfections.md, "Crossings just before the fold"). Where the
    # asymptotic law puts the fold within 0.08 in κh of κ_b, the steps are a quarter of that
    # distance (and 4 times shorter on a retry), from 4 times that distance below κ_b. The perfect
    # sphere's branch is the uniform shrink.
    # (start κ, step in κh) of each attempt
    ladder: list[tuple[float, float | None]] = (
        [(0.0, None)] if perfect else [(0.0, 0.02), (0.0, 0.005), (0.0, 0.00125)])
    # each step of an imperfect sphere's ladder is tried in the norm of state weight 1, then,
    # if that finds no fold, in the balanced norm (``first_critical``): a pole-localised fold
    # mode (a dimple's under pressure at h/R = 0.002) is turned only in the latter, the
    # state weight 1 keeps the folds it finds as they were
    if not perfect and predicted is not None and kappa_b is not None:
        gap_h = (1.0 - predicted) * kappa_b * h
        if 0 < gap_h < 0.08:
            start = kappa_b * (1.0 - 4.0 * (1.0 - predicted))
            ladder = [(start, gap_h / 4), (start, gap_h / 16), *ladder]
    first, before = None, []
    n = 0
    attempts = [(start, ds_h, False) for start, ds_h in ladder] if perfect else [
        (start, ds_h, b) for start, ds_h in ladder for b in (False, True)]
    for start, ds_h, balanced in attempts:
        model.w.x.array[:] = 0.0
        model.set_kappa(0.0)
        try:
            if start > 0:
                _approach(model, ns, start)
            found, n = first_critical(model, ns, cfg, end, ds_h, start, balanced,
                                       window=not perfect)
        except RuntimeError as e:  # a failed Newton: the next attempt
            log.info("knockdown: delta/h = %g: %s; next attempt", amplitude, e)
            first, before = None, []
            continue
        first, before = first_of(found, CriticalSettings().rel_tol)
        if perfect or (first is not None and first.kind == "fold"):
            break
        log.info("knockdown: delta/h = %g: %s first with steps of %s in kappa h%s; next "
                 "attempt", amplitude, _describe(first, h), ds_h,
                 " (balanced norm)" if balanced else "")
    if first is None or (not perfect and first.kind != "fold"):
        raise RuntimeError(f"no limit point of the imperfect sphere found up to kappa h = "
                           f"{end * h:.4g} at delta/h = {amplitude:g}")
    return first, n, before


def _describe(c: Any, h: float) -> str:
    """A located critical point in a few words (log messages)."""
    if c is None:
        return "no critical point"
    return (f"{c.kind} at kappa h = {c.kappa * h:.7f} (mode n = {c.mode_n}, eigenvalue "
            f"{c.eigenvalue:.2e}, no fold within the location tolerance after it)")


def surface_first(cfg: KnockdownConfig, amplitude: float, degree: int) -> dict[str, Any]:
    """The surface model's first critical point (fold or bifurcation, any m).

    From ``shells.analyses.critical.run_surface``, collective on COMM_WORLD.

    Args:
        cfg: the curve.
        amplitude: δ/h (0: the perfect sphere on the same pole-refined mesh).
        degree: the harmonic's or mode's degree n.

    Returns:
        {"kind", "kappa_h", "mode_n" (None), "mode_m", "accuracy" (None), "dofs",
        "asymptotics" (None)}.

    Raises:
        RuntimeError: if no critical point is found in the range.
    """
    from shells.analyses.critical import run_surface

    # δ = 0 as an imperfect sphere too: the same pole-refined mesh as the imperfect ones
    r = run_surface(imperfect_shape(cfg, amplitude, degree), cfg.h_over_r, cfg.nu,
                         1.25 * kappa_scale(cfg) / cfg.h_over_r, first_only=True,
                         size=cfg.size, degree=cfg.element_degree)
    if r["kappa_h"] is None:
        raise RuntimeError(f"no critical point of the surface model found up to kappa h = "
                           f"{1.25 * kappa_scale(cfg):.4g} at delta/h = {amplitude:g}")
    return {"kind": r["kind"], "kappa_h": r["kappa_h"], "mode_n": None,
            "mode_m": r["mode_m"], "accuracy": None, "dofs": r.get("dofs"),
            "asymptotics": None}


def perfect_sphere(cfg: KnockdownConfig, degree: int) -> dict[str, Any]:
    """The perfect sphere's first axisymmetric bifurcation and Koiter's reduced equation there.

    Args:
        cfg: the curve (its imperfection gives c3, ``shells.algorithms.asymptotics``).
        degree: the imperfection profile's degree (the located mode's where ``cfg.degree`` is
            None).

    Returns:
        {"kind", "kappa_h" (the refined κ_c h), "kappa_h_located", "mode_n", "accuracy",
        "branch_points", "asymptotics"}.

    Raises:
        RuntimeError: if the bifurcation is not found.
    """
    from shells.algorithms.asymptotics import reduced_equation
    from shells.algorithms.newton import NewtonSolver
    from shells.axisym import SNES_OPTIONS

    model, run = imperfect_model(cfg, 0.0, degree)
    ns = NewtonSolver(model, options=SNES_OPTIONS)
    try:
        point, count, _ = _locate_first(cfg, 0.0, model, ns, run.h)
        n = point.mode_n if cfg.degree is None and point.mode_n else degree
        red = reduced_equation(model, point, ns, _imperfection_derivative(cfg, n, model))
    finally:
        ns.destroy()
    r = _point_record(point, run.h, count)
    r["asymptotics"] = red.as_dict()
    # κ_b: the refined κ_c (the eigenvalue's zero on the fundamental branch, to ~1e-10; the
    # located bracket is 1e-4 wide), the reference of the knock-downs and of the law
    r["kappa_h_located"] = r["kappa_h"]
    r["kappa_h"] = r["asymptotics"]["kappa_c_h"] = red.kappa_c * cfg.h_over_r
    return r


def knockdown(cfg: KnockdownConfig, outdir: str | Path | None = None
              ) -> Iterator[dict[str, Any]]:
    """The knock-down curve of ``cfg``, point by point.

    Args:
        cfg: the curve.
        outdir: the folder of ``points.jsonl``, to which the records are appended as
            computed; those already there (same configuration and method; the amplitudes may
            differ) are read back instead of recomputed. None: nothing stored.

    Yields:
        First {"perfect": {...}, "degree"}, then one record per amplitude {"delta_over_h",
        "kappa_max_h", "knockdown", "kind", "accuracy", "degree", "knockdown_asymptotic",
        ...}; an amplitude whose search fails gets "kind" "none" and its "error".

    Raises:
        InputError: if ``points.jsonl`` holds another configuration, or the harmonic's order
            exceeds the critical degree.
    """
    from shells.theory import sphere_mode_n

    out = None if outdir is None else Path(outdir) / "points.jsonl"
    done, perfect = _stored_points(cfg, out)
    degree = cfg.degree if cfg.degree is not None else int(round(sphere_mode_n(cfg.h_over_r,
                                                                               cfg.nu)))
    if cfg.order > degree:
        raise InputError(f"the harmonic's order m = {cfg.order} exceeds its degree n = {degree} "
                         "(the critical degree): give --mode-n")
    if perfect is None:
        first = surface_first(cfg, 0.0, degree) if cfg.model == "surface" else perfect_sphere(
            cfg, degree)
        perfect = json.loads(json.dumps(first, default=json_default))
        if out is not None:
            append_record(out, {"perfect": perfect})
    if cfg.degree is None and perfect.get("mode_n"):
        degree = int(perfect["mode_n"])
    yield {"perfect": perfect, "degree": degree}
    from shells.algorithms.asymptotics import ReducedEquation

    law = None if perfect["asymptotics"] is None else ReducedEquation(
        **{k: v for k, v in perfect["asymptotics"].items()
           if k not in ("coefficient", "kappa_c_h")})
    for a in cfg.amplitudes:
        if a in done:
            yield done[a]
            continue
        rec = _amplitude_record(cfg, a, degree, perfect, law)
        if out is not None:
            append_record(out, rec)
        yield rec


def _stored_points(cfg: KnockdownConfig, out: Path | None
                   ) -> tuple[dict[float, dict[str, Any]], dict[str, Any] | None]:
    """The records of ``out`` (``points.jsonl``; written with its header if new) that a
    rerun reuses; on the surface model, rank 0's, on every rank.

    Returns:
        ({amplitude: its record}, the perfect sphere's record or None).

    Raises:
        InputError: if the file holds another configuration.
    """
    done: dict[float, dict[str, Any]] = {}
    # the curve's key: everything but the amplitudes (a rerun may add amplitudes), as stored
    key = {k: v for k, v in cfg.describe().items() if k != "amplitudes"}
    key["method"] = METHOD
    header = json.loads(json.dumps({"config": key}, default=json_default))
    perfect = None
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        if not out.exists():
            write_header(out, header)
        else:
            head, recs = read_with_header(out)
            if head != header:
                raise InputError(f"{out} holds another configuration: choose another "
                                 "directory or remove it")
            done = {r["delta_over_h"]: r for r in recs if "delta_over_h" in r}
            perfect = next((r["perfect"] for r in recs if "perfect" in r), None)
    if cfg.model == "surface":
        # collective runs: every rank skips the same stored points (rank 0 holds the file)
        from mpi4py import MPI

        done, perfect = MPI.COMM_WORLD.bcast((done, perfect) if MPI.COMM_WORLD.rank == 0
                                             else None, root=0)
    return done, perfect


def _amplitude_record(cfg: KnockdownConfig, a: float, degree: int, perfect: dict[str, Any],
                      law: Any) -> dict[str, Any]:
    """The record of amplitude δ/h = ``a`` (a failed search: "kind" "none" and its "error").

    Args:
        cfg: the curve.
        a: the amplitude.
        degree: the imperfection's degree.
        perfect: the perfect sphere's record (κ_b h: its "kappa_h").
        law: the perfect sphere's ``ReducedEquation``, or None.
    """
    kb = perfect["kappa_h"]
    pred = None if law is None else law.knockdown(a)
    try:
        if a == 0:
            r = {k: perfect[k] for k in ("kind", "kappa_h", "accuracy")}
        elif cfg.model == "surface":
            r = surface_first(cfg, a, degree)
        else:
            r = fold_kappa(cfg, a, degree, pred, law.kappa_c)
    except RuntimeError as e:  # reported with the curve, which goes on
        log.warning("knockdown: delta/h = %g: %s", a, e)
        r = {"kind": "none", "kappa_h": None, "accuracy": None, "error": str(e)}
    rec = {"delta_over_h": a, "kappa_max_h": r["kappa_h"],
           "knockdown": None if r["kappa_h"] is None else r["kappa_h"] / kb,
           "kind": r["kind"], "accuracy": r["accuracy"], "degree": degree,
           # the law's κ_max/κ_b (None where it predicts no fold at this order)
           "knockdown_asymptotic": pred}
    if "error" in r:
        rec["error"] = r["error"]
    if r.get("mode_m") is not None:
        rec["mode_m"] = r["mode_m"]
    if r.get("crossings_before"):
        rec["crossings_before"] = r["crossings_before"]
    if rec["knockdown"] is not None:
        log.info("knockdown: delta/h = %g: kappa_max h = %.6f, knock-down %.4f (%s)", a,
                 rec["kappa_max_h"], rec["knockdown"], r["kind"])
    return rec


def run(cfg: KnockdownConfig, outdir: str | Path | None, figure: bool = True
                  ) -> dict[str, Any]:
    """The knock-down analysis: the whole curve (``knockdown``) as one result.

    Args:
        cfg: the curve.
        outdir: the output folder (None: nothing written).
        figure: with ``outdir``, also write ``outdir``/knockdown.png (log δ axis).

    Returns:
        {"kappa_b", "kappa_b_h", "load", "p_b_over_E", "p_c_over_E_classical", "degree",
        "asymptotics", "points" (by δ), "config", "figures", "points_file"}.

    Raises:
        InputError: as ``knockdown``.
    """
    recs = list(knockdown(cfg, outdir))
    head, pts = recs[0], sorted(recs[1:], key=lambda r: r["delta_over_h"])
    h = cfg.h_over_r  # R = 1
    kbh = head["perfect"]["kappa_h"]
    out: dict[str, Any] = {"kappa_b": head["perfect"]["kappa_h"] / h, "load": cfg.load,
                           # the load at κ_b as a pressure (Eq. (5)), and the classical p_c
                           "p_b_over_E": kbh * h**2 / (6 * (1 - cfg.nu)),
                           "p_c_over_E_classical": 2 / math.sqrt(3 * (1 - cfg.nu**2)) * h**2,
                           "kappa_b_h": head["perfect"]["kappa_h"], "degree": head["degree"],
                           "asymptotics": head["perfect"]["asymptotics"],
                           "points": pts, "config": cfg.describe(), "figures": []}
    if outdir is not None:
        out["points_file"] = str(Path(outdir) / "points.jsonl")
        if figure:
            out["figures"] = [write_figure(out, Path(outdir) / "knockdown.png")]
    return out


def write_figure(res: dict[str, Any], path: Path) -> str:
    """Plot the knock-down curve (computed and asymptotic, log δ axis).

    Args:
        res: a result of ``run``.
        path: the image file.

    Returns:
        The path written.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pts = [p for p in res["points"] if p["delta_over_h"] > 0 and p["knockdown"] is not None]
    fig, ax = plt.subplots(figsize=(5, 3.5))
    ax.semilogx([p["delta_over_h"] for p in pts], [p["knockdown"] for p in pts], "o-",
                label="computed")
    law = (res.get("asymptotics") or {}).get("coefficient")  # None on the surface model
    if law and pts:
        import numpy as np

        d = np.geomspace(min(p["delta_over_h"] for p in pts),
                         max(p["delta_over_h"] for p in pts), 50)
        ax.semilogx(d, 1 - law * np.sqrt(d), "k--", lw=1,
                    label=f"Koiter: 1 - {law:.3g} √(δ/h)")
        ax.legend(fontsize=8)
    c = res["config"]
    what = c["imperfection"] + (f" n = {res['degree']}, m = {c['order']}"
                                if c["imperfection"] == "harmonic" else "")
    ax.set_title(f"closed sphere, h/R = {c['h_over_r']:g}, ν = {c['nu']:g}, {what}", fontsize=9)
    ax.set_xlabel("imperfection amplitude δ/h")
    ax.set_ylabel("κ_max / κ_b")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=150)
    plt.close(fig)
    return str(path)
