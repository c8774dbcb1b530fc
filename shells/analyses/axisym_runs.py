"""Drivers of the axisymmetric model (driver layer): one run's configuration and its numerics
defaults, ``branch`` (the branch with per-m stability) and ``critical`` (its critical points),
both on ``shells.algorithms.following.follow``."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from shells.analyses.setup import open_shell_kappa_R_max
from shells.axisym.kinematics import is_sphere
from shells.axisym.mesh import check_supported
from shells.axisym.model import SNES_OPTIONS, AxisymModel, AxisymParameters
from shells.errors import InputError
from shells.geometry.shapes import RunScales, Shape
from shells.geometry.stimulus import UNIFORM, CurvatureField
from shells.parameters import check_h_over_r, check_nu
from shells.theory import sphere_kappa_b_h, sphere_mode_n

__all__ = ["RunConfig", "branch", "critical", "default_cells",
           "default_settings"]


# ------------------------------------------------------------------------------------------------
# numerics of a run
# ------------------------------------------------------------------------------------------------


#: ``ContinuationSettings.factor_reuse`` of ``critical`` with its default settings: the
#: corrector's chord steps and the tangent from its factorisation. With the quadratic
#: predictor the corrector's first update is small enough that at this bound its second
#: iterate keeps the first's factorisation too, the located points unchanged
#: (docs/design-notes.md, "Chord steps")
REUSE_CRITICAL = 1.0e-4

#: the C1 penalty of a run that sets none (``RunConfig.penalty`` None): the weight of
#: benchmarks/axisym_convergence.py, kept wherever its round-off allows (``resolve_penalty``)
PENALTY = 1.0e4
#: the same on a closed shell: the penalty ties the slopes to the displacement to O(1/penalty),
#: which on a closed sphere is an imperfection at its poles that lowers κ_b by ∝ 1/penalty; a
#: tenfold stiffer tie puts that below the location's tolerance, so ``critical``, ``postbuckle``
#: and ``knockdown`` report one κ_b for the same sphere (docs/design-notes.md, "The C1
#: penalty on closed shells")
CLOSED_PENALTY = 1.0e5
#: the lowest penalty ``resolve_penalty`` goes to, over h/R: the penalty's consistency error, a
#: relative C (h/R)/penalty independent of the mesh, then stays within the location's
#: tolerance for the constants C measured (docs/model.md, "The thin end")
PENALTY_FLOOR = 1.0e4
#: ``resolve_penalty`` lowers the penalty until the round-off of every Fourier block's
#: eigenvalue nearest 0 at κ = 0 is at most this fraction of it
ROUNDOFF_TARGET = 1.0e-2
#: ... and refuses a discretisation whose round-off stays above this fraction: its counts would
#: be decided by round-off well away from any crossing (the cases accepted:
#: benchmarks/thin_end.py)
ROUNDOFF_LIMIT = 5.0e-2


def default_cells(shape: Shape, h_over_r: float) -> int:
    """The default number of bulk cells of the 1D mesh.

    Args:
        shape: the shell.
        h_over_r: thickness over the shape's length scale.

    Returns:
        200, and on a sphere at least 5 per degree of its critical mode.
    """
    if is_sphere(shape):
        return max(200, int(math.ceil(5 * sphere_mode_n(h_over_r, 0.0))))
    return 200


def default_settings(shape: Shape, h_over_r: float, **overrides: Any) -> Any:
    """Continuation settings scaled to the problem: on a closed shell κ scales with 1/h.

    Args:
        shape: the shell.
        h_over_r: thickness over the shape's length scale.
        **overrides: ``ContinuationSettings`` fields that replace the defaults.

    Returns:
        The ``ContinuationSettings``.
    """
    from shells.algorithms.settings import ContinuationSettings

    scale = 1.0 / h_over_r if shape.closed else 1.0  # in λ = κ L
    base = dict(method="arclength", ds=0.5 * scale if shape.closed else 0.05,
                ds_max=1.0 * scale if shape.closed else 0.2, ds_min=1e-7 * scale,
                target_newton_its=4, max_newton_its=12, newton_tol=1e-8)
    base.update(overrides)
    return ContinuationSettings(**base)


def unloaded_roundoff(model: AxisymModel, blocks: list[int]) -> float:
    """The relative round-off of the Fourier blocks ``blocks`` at the model's current state
    (meant for the unloaded reference, κ = 0 and no displacement, where every block is positive
    definite): the largest |μ - q| / q over the blocks that are not positive definite by the
    stability test's margin (``shells.algorithms.stability.DEFINITE_MARGIN``; a block that is
    has its lowest eigenvalue far above its round-off), μ the block's eigenvalue nearest 0 from its
    factorisation (what its inertia sees), q that eigenvector's Rayleigh quotient by
    quadrature (``hessian_quadratic``: the stiff terms' cancellation is not in it). Infinite
    where a q is not positive or an eigenpair did not converge."""
    from shells.algorithms.stability import DEFINITE_MARGIN, Stability, rayleigh_quotient

    tested = model.definite_blocks(list(blocks), DEFINITE_MARGIN) or {}
    todo = [m for m in blocks if not tested.get(m, False)]
    if not todo:
        return 0.0
    st = Stability(model)
    worst = 0.0
    try:
        for m in todo:
            vals, vecs = st.eigenpairs(1, modes=True, block=m, refine=False)
            if not vals:
                return math.inf
            q = rayleigh_quotient(model.hessian_quadratic(m, vecs[0]), st.mass(m), vecs[0],
                                  math.nan)
            for v in vecs:
                v.destroy()
            if not q > 0:
                return math.inf
            worst = max(worst, abs(vals[0] - q) / q)
    finally:
        st.destroy()
    return worst


def default_penalty(shape: Shape) -> float:
    """The C1 penalty a run starts from: ``CLOSED_PENALTY`` on a closed shell, else
    ``PENALTY``."""
    return CLOSED_PENALTY if shape.closed else PENALTY


def resolve_penalty(model: AxisymModel, cfg: RunConfig) -> tuple[float, float]:
    """The C1 penalty of a run, set on ``model`` (its state the unloaded reference), and the
    round-off of its blocks there (``unloaded_roundoff``, over m ≤ 12).

    The penalty's weight multiplies the largest entries of every block, and with them the
    round-off of their factorisations, while a thin shell's softest eigenvalues fall as h², so
    a fixed penalty lets round-off decide a thin shell's counts (docs/model.md, "The thin
    end"). ``cfg.penalty`` None:
    ``default_penalty``, or where its round-off exceeds ``ROUNDOFF_TARGET`` a tenth of it, and so
    on, down to ``PENALTY_FLOOR`` h/R (the consistency error that allows). An explicit penalty is
    kept.

    Raises:
        InputError: the round-off stays above ``ROUNDOFF_LIMIT``: the discretisation cannot be
            trusted (too many cells for double precision at this h/R).
    """
    blocks = [m for m in model.modes if m <= 12]
    if cfg.penalty is not None:
        rungs = [float(cfg.penalty)]
    else:
        top = default_penalty(cfg.shape)
        floor = PENALTY_FLOOR * cfg.h_over_r
        rungs = [p for p in (top / 10.0**k for k in range(20)) if p > floor] or [top]
        if rungs[-1] > floor and floor < top:
            rungs.append(floor)
    for pen in rungs:
        model.pen.value = pen
        rho = unloaded_roundoff(model, blocks)
        if rho <= ROUNDOFF_TARGET:
            break
    if rho > ROUNDOFF_LIMIT:
        raise InputError(f"the 1D model cannot be trusted on {cfg.n_cells} cells at h/R = "
                         f"{cfg.h_over_r:g}: at kappa = 0 the round-off of its Fourier blocks is "
                         f"{rho:.2g} of their lowest eigenvalue (C1 penalty {pen:g}), above "
                         f"{ROUNDOFF_LIMIT:g}; use fewer cells"
                         + ("" if cfg.penalty is None else " or the default penalty"))
    model.params = replace(model.params, penalty=pen)
    return pen, rho


def _check_common(shape: Any, h_over_r: Any, nu: Any) -> None:
    if not isinstance(shape, Shape):
        raise InputError(f"shape must be a shells.geometry.shapes shape, got {shape!r}")
    check_supported(shape)
    check_h_over_r(h_over_r)
    check_nu(nu)


# ------------------------------------------------------------------------------------------------
# the branch with per-m stability, and critical points
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class RunConfig(RunScales):
    """One axisymmetric run (validated).

    Attributes:
        shape: a Sphere, SphericalCap, EllipsoidalCap or Disk.
        h_over_r: thickness over the shape's length scale L (``characteristic_size``).
        nu: Poisson ratio.
        direction: "up" (κ > 0) or "down" (κ < 0).
        m_max: Fourier modes 0..m_max are checked at every point.
        kappa_max: end of the range, |κ| R (R: pole radius; the disk's radius).
        cells, layer_cells, grading, penalty: discretisation (``AxisymParameters``); penalty
            None: ``default_penalty``, lowered where its round-off requires
            (``resolve_penalty``).
        rel_tol: location accuracy of critical points, relative in κ.
        max_critical: stop after this many critical points (None: up to the first fold or the
            end of range).
        settings: continuation settings (None: ``default_settings``).
        kappa_field: the natural-curvature stimulus (``shells.geometry.stimulus``; default:
            uniform).

    Raises:
        InputError: on construction, for a parameter out of range or an unsupported shape.
    """

    shape: Shape
    h_over_r: float
    nu: float = 0.5
    direction: str = "up"
    m_max: int | None = None
    kappa_max: float | None = None
    cells: int | None = None
    layer_cells: float = 8.0
    grading: float = 1.1
    penalty: float | None = None
    rel_tol: float = 1.0e-4
    max_critical: int | None = None
    settings: Any = None
    kappa_field: CurvatureField = UNIFORM

    def __post_init__(self) -> None:
        _check_common(self.shape, self.h_over_r, self.nu)
        if not isinstance(self.kappa_field, CurvatureField):
            raise InputError(f"kappa_field must be a CurvatureField, got {self.kappa_field!r}")
        self.kappa_field.check_on(self.shape, axisymmetric=True)
        if self.direction not in ("up", "down"):
            raise InputError(f"direction must be 'up' or 'down', got {self.direction!r}")
        if self.m_max is not None and not (isinstance(self.m_max, (int, np.integer))
                                           and 0 <= self.m_max <= 2000):
            raise InputError(f"m_max must be an integer in [0, 2000], got {self.m_max!r}")
        if self.kappa_max is not None and not (isinstance(self.kappa_max, (int, float))
                                               and math.isfinite(self.kappa_max)
                                               and self.kappa_max > 0):
            raise InputError(f"kappa_max must be a positive number (|kappa| R at the end of "
                             f"the range), got {self.kappa_max!r}")
        if not (0 < self.rel_tol < 0.1):
            raise InputError(f"rel_tol must lie in (0, 0.1), got {self.rel_tol!r}")
        if self.max_critical is not None and not (isinstance(self.max_critical, int)
                                                  and self.max_critical >= 1):
            raise InputError(f"max_critical must be a positive integer, got {self.max_critical!r}")
        self.params()  # validates the discretisation

    @property
    def n_cells(self) -> int:
        """The bulk cells: ``cells``, or ``default_cells``."""
        return self.cells if self.cells is not None else default_cells(self.shape, self.h_over_r)

    @property
    def modes(self) -> list[int]:
        """The Fourier modes checked: 0..m_max (default 12; spheres 1.3 n + 4)."""
        if self.m_max is not None:
            return list(range(self.m_max + 1))
        if is_sphere(self.shape):
            return list(range(int(math.ceil(1.3 * sphere_mode_n(self.h_over_r, self.nu))) + 5))
        return list(range(13))

    @property
    def kappa_end(self) -> float:
        """Signed κ at the end of the range."""
        if self.kappa_max is not None:
            mag = self.kappa_max / self.R
        elif is_sphere(self.shape):
            mag = 1.25 * sphere_kappa_b_h(self.nu) / self.h
        else:
            mag = open_shell_kappa_R_max(self.shape, self.h_over_r) / self.R
        return mag if self.direction == "up" else -mag

    def params(self) -> AxisymParameters:
        """The 1D model's parameters of this run."""
        return AxisymParameters(h=self.h, nu=self.nu, cells=self.n_cells,
                                layer_cells=self.layer_cells, grading=self.grading,
                                penalty=default_penalty(self.shape) if self.penalty is None
                                else self.penalty,
                                kappa_field=self.kappa_field)


@dataclass
class _Run:
    """The model and Newton solver of a run."""

    cfg: RunConfig
    model: AxisymModel = field(init=False)

    def __post_init__(self) -> None:
        from shells.algorithms.newton import NewtonSolver

        self.model = AxisymModel(self.cfg.shape, self.cfg.params())
        self.model.modes = tuple(self.cfg.modes)
        # on the unloaded reference state, before any solve
        self.penalty, self.roundoff = resolve_penalty(self.model, self.cfg)
        self.ns = NewtonSolver(self.model, options=SNES_OPTIONS)
        # the residual bound is the continuation's own (relative to the κ-load, plus the
        # round-off floor of the penalty-stiff Jacobian): no model-specific tolerance here
        self.settings = self.cfg.settings or default_settings(self.cfg.shape, self.cfg.h_over_r)

    def follow(self, crit: Any = None, locate_points: bool = True,
               scalars: bool = True) -> Iterator[tuple]:
        """``critical.follow`` over the run's range with the inertia of every H_m."""
        from shells.algorithms.following import follow

        return follow(self.model, self.settings, self.cfg.kappa_end, crit, solver=self.ns,
                      blocks=self.model.modes, locate_points=locate_points, scalars=scalars)

    def record(self, p: Any, counts: dict[int, int]) -> dict[str, Any]:
        d = p.as_dict()
        d["kappa_R"] = p.kappa * self.cfg.R
        d["kappa_h"] = p.kappa * self.cfg.h
        d["negative_counts"] = [counts[m] for m in sorted(counts)]
        d["unstable_modes"] = [m for m in sorted(counts) if counts[m] > 0]
        return d

    def destroy(self) -> None:
        self.ns.destroy()


def branch(shape: Shape, h_over_r: float, nu: float = 0.5, direction: str = "up",
           m_max: int | None = None, kappa_max: float | None = None,
           **numerics: Any) -> Iterator[dict[str, Any]]:
    """Follow the axisymmetric branch from κ = 0 and check modes m = 0..m_max at every point.

    Args:
        shape: a ``shells.geometry.shapes`` Sphere, SphericalCap, EllipsoidalCap or Disk.
        h_over_r: thickness over the shape's length scale (``characteristic_size``).
        nu: Poisson ratio in (-1, 1/2].
        direction: "up" (κ > 0) or "down" (κ < 0).
        m_max: highest Fourier mode checked (default: 12; spheres: 1.3 n + 4).
        kappa_max: end of the range, |κ| R (default: spheres 1.25 κ_b; caps 2 θ̄ + 6).
        **numerics: ``cells``, ``layer_cells``, ``grading``, ``penalty``, ``settings``
            (a ``ContinuationSettings``), ``kappa_field`` (a ``CurvatureField``), see ``RunConfig``.

    Yields:
        One dict per converged point: ``kappa_R``, ``kappa_h``, ``kappa``, ``psi3_over_h`` (mean
        normal displacement over h; the sphere's change of radius), ``apex_uz_over_h``,
        ``energy`` and its split, ``newton_its``, ``dkappa_ds`` (κ-component of the unit
        tangent: its sign change marks a fold), ``negative_counts`` (list indexed by m) and
        ``unstable_modes`` (the m with a negative eigenvalue).

    Raises:
        InputError: bad parameters.
    """
    cfg = RunConfig(shape=shape, h_over_r=h_over_r, nu=nu, direction=direction, m_max=m_max,
                    kappa_max=kappa_max, **_numerics(numerics, ("rel_tol", "max_critical")))
    run = _Run(cfg)
    try:
        for p, res, _ in run.follow(locate_points=False):
            yield run.record(p, res.counts)
    finally:
        run.destroy()


def _numerics(numerics: dict[str, Any], extra: tuple[str, ...] = ()) -> dict[str, Any]:
    allowed = {"cells", "layer_cells", "grading", "penalty", "settings", "rel_tol",
               "max_critical", "kappa_field"} - set(extra)
    bad = set(numerics) - allowed
    if bad:
        raise InputError(f"unknown numerics option(s): {', '.join(sorted(bad))} "
                         f"(allowed: {', '.join(sorted(allowed))})")
    return numerics


def critical(shape: Shape, h_over_r: float, nu: float = 0.5, direction: str = "up",
             m_max: int | None = None, kappa_max: float | None = None,
             **numerics: Any) -> dict[str, Any]:
    """Critical points of the axisymmetric branch from κ = 0.

    The first one, and all of them up to and including the first fold or the end of the
    range. At every branch point the inertia of H_m (m = 0..m_max) is computed; a change of a
    negative count, or a sign change of dκ/ds, between two points is located inside that step
    (``shells.algorithms.locate``) to |Δκ|/|κ| < ``rel_tol`` (default 1e-4). Kinds: "fold"
    (dκ/ds changes sign; its mode is m = 0) and "bifurcation". Only the critical points are
    the result, so the corrector takes chord steps from the quadratic predictor
    (``REUSE_CRITICAL``) unless ``settings`` are given.

    Args:
        shape: Sphere, SphericalCap, EllipsoidalCap or Disk (``shells.geometry.shapes``).
        h_over_r: thickness over the shape's length scale (``characteristic_size``).
        nu: Poisson ratio in (-1, 1/2].
        direction: "up" (κ > 0) or "down" (κ < 0).
        m_max: highest Fourier mode checked (default 12; spheres 1.3 n + 4).
        kappa_max: end of the range in |κ| R (default: spheres 1.25 κ_b, caps 2 θ̄ + 6).
        **numerics: ``cells``, ``layer_cells``, ``grading``, ``penalty``, ``rel_tol``,
            ``settings`` (``ContinuationSettings``), ``kappa_field`` (``CurvatureField``),
            ``max_critical`` (stop after this many
            critical points; default 1 for closed spheres, whose perfect-sphere branch beyond
            the first multiplet is of no interest, else unlimited).

    Returns:
        {"kind": "fold" | "bifurcation" | "none", "kappa_R", "kappa_h", "mode_m", "mode_n",
        "h_over_R", "nu", "theta_deg", "model": "axisym", "dofs", "critical_points": [{"kind",
        "kappa_R", "kappa_h", "mode_m", "mode_n", "kappa_R_bracket", "accuracy"}, ...]}; the
        top-level values describe the first critical point (None if there is none);
        ``mode_m`` is the block whose count changes, ``mode_n`` the degree on a sphere (None
        for non-spheres and folds); ``theta_deg`` is None for a sphere or a disk; ``dofs``
        counts the base-state unknowns; ``penalty`` is the C1 penalty used
        (``resolve_penalty``).

    Raises:
        InputError: bad parameters.
        RuntimeError: the continuation stopped before the end of the range.
    """
    numerics = dict(_numerics(numerics))
    if isinstance(shape, Shape) and is_sphere(shape):
        numerics.setdefault("max_critical", 1)
    cfg = RunConfig(shape=shape, h_over_r=h_over_r, nu=nu, direction=direction, m_max=m_max,
                    kappa_max=kappa_max, **numerics)
    from shells.algorithms.settings import CriticalSettings

    run = _Run(cfg)
    if cfg.settings is None:  # only the critical points are wanted: chord steps, and
        # Newton from the branch's quadratic extrapolation (``REUSE_CRITICAL``)
        run.settings = replace(run.settings, factor_reuse=REUSE_CRITICAL, predictor="quadratic")
    L = run.model.shape.characteristic_size()
    # a closed sphere's axisymmetric modes of neighbouring degrees bifurcate within 1e-4 in κ:
    # there the locator's corrector omits dominant components along the Jacobian's four
    # eigenvectors nearest 0 (else it lands on a branch bifurcating close by). Elsewhere it
    # must not: on a thin disk the soft axisymmetric bending modes are among them, and their
    # components are the corrections Newton needs (docs/model.md, "Stability and critical
    # points")
    crit = CriticalSettings(rel_tol=cfg.rel_tol, stop_at_fold=True,
                            max_critical=cfg.max_critical,
                            deflate=0)
    try:
        found = _located(run, cfg, crit, L)
        dofs = run.model.num_dofs()
        penalty = run.penalty
    finally:
        run.destroy()
    return _critical_result(cfg, found, dofs, penalty)


def _located(run: _Run, cfg: RunConfig, crit: Any, L: float) -> list[Any]:
    """The critical points of ``run``'s branch (``crit``: how they are located and when the
    run stops).

    Raises:
        RuntimeError: the continuation gave up (step below ds_min, or max_steps) short of the
            end: the critical points beyond are unknown, "none" would be a false claim.
    """
    found: list[Any] = []
    last = None
    for p, _, cps in run.follow(crit, scalars=False):  # its points' scalars unused
        last = p
        found.extend(cps)
    stop = bool(found) and (found[-1].kind == "fold" or (
        cfg.max_critical is not None and len(found) >= cfg.max_critical))
    lam_end = cfg.kappa_end * L
    if not stop and (last is None or abs(last.kappa_L - lam_end) > 1e-9 * abs(lam_end)):
        reached = None if last is None else last.kappa * cfg.R
        raise RuntimeError(f"the axisymmetric continuation stopped at kappa R = {reached} "
                           f"before the end of the range, kappa R = "
                           f"{cfg.kappa_end * cfg.R:.6g}; critical points beyond it are "
                           "not known")
    return found


def _critical_result(cfg: RunConfig, found: list[Any], dofs: int, penalty: float
                     ) -> dict[str, Any]:
    """``critical``'s result from the located points ``found``."""
    R, h = cfg.R, cfg.h
    pts = [{"kind": c.kind, "kappa_R": c.kappa * R, "kappa_h": c.kappa * h,
            "mode_m": 0 if c.kind == "fold" else c.mode_m,
            "mode_n": c.mode_n if c.kind != "fold" else None,
            "kappa_R_bracket": [c.kappa_lo * R, c.kappa_hi * R], "accuracy": c.accuracy,
            "locator_accuracy": c.accuracy}
           for c in found]
    first = pts[0] if pts else {"kind": "none", "kappa_R": None, "kappa_h": None,
                                "mode_m": None, "mode_n": None}
    theta = getattr(cfg.shape, "theta", None)
    return {"kind": first["kind"], "kappa_R": first["kappa_R"], "kappa_h": first["kappa_h"],
            "mode_m": first["mode_m"], "mode_n": first["mode_n"], "h_over_R": cfg.h_over_r,
            "nu": cfg.nu, "theta_deg": (None if theta is None or is_sphere(cfg.shape)
                                        else math.degrees(theta)),
            "model": "axisym", "dofs": dofs, "penalty": penalty, "critical_points": pts}
