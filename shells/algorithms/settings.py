"""Settings of the path-following algorithms (algorithm layer), frozen dataclasses validated on
construction: ``ContinuationSettings`` (continuation and its corrector), ``CriticalSettings``
(locating critical points), ``MinimiseSettings`` (energy minimisation at fixed κ), and the
conversion of steps to arclength.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Any

from shells.errors import InputError

__all__ = ["ContinuationSettings", "CriticalSettings", "DynamicsSettings", "MinimiseSettings",
           "in_arclength"]


@dataclass(frozen=True)
class ContinuationSettings:
    """All continuation settings, validated on construction.

    Attributes:
        method: "arclength" (pseudo-arclength, passes folds) or "natural" (steps in κ, SNES).
        ds: initial step: in λ = κL for "natural", in arclength for "arclength".
        ds_min, ds_max: bounds of the adaptive step; below ds_min the run stops.
        target_newton_its: the step grows when Newton needs fewer, shrinks when more.
        max_newton_its: a corrector needing more counts as failed (step halved, retried).
        newton_tol: convergence: relative Newton increment (state RMS / L and |δλ|).
        residual_tol: an absolute bound on the residual norm that replaces the relative one
            below (None, the default: the relative bound).
        residual_rtol: the arclength corrector also needs ||R|| at most ``residual_rtol``
            ||∂R/∂κ|| max(|κ|, κ_ref) + ``residual_roundoff`` ε ||J||_F ||w||: relative to the
            κ-load, the force that κ imposes (κ_ref: 1 % of the run's largest |κ|, so the bound
            does not vanish where the branch crosses κ = 0), plus the round-off floor of a
            residual assembled with the Jacobian J at the state w (ε: machine epsilon). Both
            terms are model-independent: a stiff Jacobian (the 1D model's C1 penalty) has a
            round-off floor that can exceed the relative term on thin bending-dominated shells
            (a disk's load is O(h²)). Natural steps (SNES) accept a residual below the
            same bound with 10⁻³ ``residual_rtol`` and no round-off term, since a relative
            decrease from the small start residual of a short step can lie below round-off
            (docs/model.md, "Solvers").
        residual_roundoff: the factor of the round-off term; it lies above the round-off
            floors of both models (docs/design-notes.md, "Residual acceptance").
        state_weight: ξ in the arclength norm.
        max_steps: safety limit on the number of points.
        kappa_stops: values of κL (natural method) the run lands on exactly.
        ds_unit: "arclength" (default) or "kappa": for the arclength method, ds, ds_min and
            ds_max are then given as steps in κL and converted with the first tangent
            (ds_arc = ds / |dλ/ds|), which makes them independent of how much the state moves
            per unit κ (a disk moves many thicknesses per unit κL, a sphere a fraction of one).
        factor_reuse: the corrector keeps the LU factorisation of an earlier iterate's
            Jacobian (a chord step: a solve instead of a factorisation) while the state has
            moved less than this since (RMS, in units of ``state_scale()``, and |δλ| in units of
            max(1, |λ|)) and the last step contracted by at least 10; the tangent at a
            converged point uses the corrector's factorisation under the same bound. Near the
            solution Newton's Jacobian changes by O(|δw|/h), so the chord steps converge as fast
            as Newton's there. 0 (the default): factor at every iteration and for the tangent,
            since elsewhere a branch's points are the result. The critical-point runs use it
            (``REUSE_SURFACE``, ``REUSE_CRITICAL``; docs/design-notes.md, "Chord steps").
        predictor: where the arclength corrector starts (the hyperplane is the tangent
            predictor's either way): "tangent" (default), the predictor itself, or
            "quadratic", the quadratic through the last two points with the tangent at the
            last (an error of O(s³) instead of O(s²)). Its converged points are the same to
            the Newton tolerance, but fewer iterations grow the adaptive step sooner, so
            where the step is below ``ds_max`` the run takes other points. The 1D model's
            ``critical`` uses it (docs/design-notes.md, "Quadratic predictor").

    Raises:
        InputError: on construction, for a setting out of its range.
    """

    method: str = "arclength"
    ds: float = 0.1
    ds_min: float = 1.0e-6
    ds_max: float = 2.0
    target_newton_its: int = 4
    max_newton_its: int = 12
    newton_tol: float = 1.0e-10
    residual_tol: float | None = None
    residual_rtol: float = 1.0e-5
    residual_roundoff: float = 0.1
    state_weight: float = 1.0
    max_steps: int = 10000
    kappa_stops: tuple[float, ...] = ()
    ds_unit: str = "arclength"
    factor_reuse: float = 0.0
    predictor: str = "tangent"

    def __post_init__(self) -> None:
        if self.method not in ("arclength", "natural"):
            raise InputError(f"continuation method must be 'arclength' or 'natural', "
                             f"got {self.method!r}")
        if not (0 < self.ds_min <= self.ds <= self.ds_max):
            raise InputError(f"steps must satisfy 0 < ds_min <= ds <= ds_max, got "
                             f"{self.ds_min}, {self.ds}, {self.ds_max}")
        if self.target_newton_its < 1 or self.max_newton_its < self.target_newton_its:
            raise InputError("need 1 <= target_newton_its <= max_newton_its")
        if self.residual_tol is not None and not (isinstance(self.residual_tol, (int, float))
                                                  and math.isfinite(self.residual_tol)
                                                  and self.residual_tol > 0):
            raise InputError(f"residual_tol must be None or a positive number, got "
                             f"{self.residual_tol!r}")
        if not (isinstance(self.residual_rtol, (int, float)) and 0 < self.residual_rtol < 1):
            raise InputError(f"residual_rtol must lie in (0, 1), got {self.residual_rtol!r}")
        if not (isinstance(self.residual_roundoff, (int, float))
                and 0 <= self.residual_roundoff < math.inf):
            raise InputError(f"residual_roundoff must be a non-negative number, got "
                             f"{self.residual_roundoff!r}")
        if not self.state_weight > 0:
            raise InputError("state_weight must be positive")
        if self.ds_unit not in ("arclength", "kappa"):
            raise InputError(f"ds_unit must be 'arclength' or 'kappa', got {self.ds_unit!r}")
        if not (isinstance(self.factor_reuse, (int, float)) and 0 <= self.factor_reuse < 1):
            raise InputError(f"factor_reuse must lie in [0, 1), got {self.factor_reuse!r}")
        if self.predictor not in ("tangent", "quadratic"):
            raise InputError(f"predictor must be 'tangent' or 'quadratic', got "
                             f"{self.predictor!r}")

    def describe(self) -> dict[str, Any]:
        """The settings as a plain dict (for a run's JSON record)."""
        return asdict(self)


def in_arclength(st: ContinuationSettings, tl: float) -> ContinuationSettings:
    """The settings with their steps in arclength.

    Settings with ``ds_unit`` "kappa" are converted with the κ-component of the run's first
    unit tangent (ds_arc = ds / |dλ/ds|), as the arclength loop does at a run's start; a
    resumed run passes the converted settings, and its first point's ``dkappa_ds`` decides
    them.

    Args:
        st: the settings.
        tl: the κ-component dλ/ds of the first unit tangent.

    Returns:
        ``st`` itself if its steps are in arclength already, else a converted copy.
    """
    if st.ds_unit != "kappa":
        return st
    scale = 1.0 / max(abs(tl), 1e-6)
    return replace(st, ds_unit="arclength", ds=st.ds * scale, ds_min=st.ds_min * scale,
                   ds_max=st.ds_max * scale)


@dataclass(frozen=True)
class CriticalSettings:
    """How critical points are located.

    Attributes:
        rel_tol: location accuracy, relative in κ.
        max_evaluations: at most this many corrector solves per critical point.
        stop_at_fold: stop following the branch after the first fold.
        stop_at_first: stop after the first critical point of any kind.
        max_critical: stop after this many critical points (None: no limit).
        folds_only_after_first: after the first bifurcation, stop computing inertia (the
            counts are carried) and locate folds only: the branch is then followed up to its
            fold at the price of the corrector alone.
        nev: eigenvalues computed at each trial point (nearest 0).
        deflate: in steps without a fold, the locator's corrector omits from each Newton step
            its components along the ``deflate`` eigenvectors of the Jacobian nearest 0 when
            such a component exceeds 10 times the rest of the step: round-off amplified by
            the nearly singular Jacobian, or the start of a switch to a branch bifurcating
            close by (a closed sphere's cluster of axisymmetric modes). Costs one eigensolve
            per Newton iteration: for the 1D model. 0 (default): off.

    Raises:
        InputError: on construction, for a setting out of its range.
    """

    rel_tol: float = 1.0e-4
    max_evaluations: int = 25
    stop_at_fold: bool = True
    stop_at_first: bool = False
    max_critical: int | None = None
    folds_only_after_first: bool = False
    nev: int = 4
    deflate: int = 0

    def __post_init__(self) -> None:
        if not (0 < self.rel_tol < 0.1):
            raise InputError(f"rel_tol must lie in (0, 0.1), got {self.rel_tol}")
        if self.max_evaluations < 2 or self.nev < 1:
            raise InputError("need max_evaluations >= 2 and nev >= 1")
        if self.max_critical is not None and not (isinstance(self.max_critical, int)
                                                  and self.max_critical >= 1):
            raise InputError(f"max_critical must be a positive integer, got "
                             f"{self.max_critical!r}")
        if not (isinstance(self.deflate, int) and 0 <= self.deflate <= 20):
            raise InputError(f"deflate must be an integer in [0, 20], got {self.deflate!r}")


@dataclass(frozen=True)
class MinimiseSettings:
    """How a stable equilibrium is found by minimising the energy at fixed κ (TAO).

    Attributes:
        method: the TAO solver: "nls" (Newton with a Moré-Thuente line search, its Hessian
            shifted by a perturbation while it is not positive definite: TAONLS) or "ntr"
            (trust-region Newton: TAONTR).
        gatol: convergence: the gradient's norm (the residual's, in the problem's units) at
            most ``gatol``.
        grtol: or the gradient's norm at most ``grtol`` times |E|.
        max_it: at most this many Newton iterations.
        newton_below: TAO hands over to Newton once the gradient's norm is below
            ``newton_below`` where the Hessian is definite up to the least shift ``sigma0``:
            in the basin of a minimum Newton converges quadratically (0: TAO to the end; a
            failed Newton solve returns to TAO). A state with a symmetry orbit (a pattern
            turned about a shell's axis) goes to Newton modulo the orbit
            (``shells.algorithms.orbit``, ``shells_orbit_``), any other to SNES
            (``shells_newton_``).
        ftol: where Newton failed from a small gradient (``newton_below``) with the Hessian
            definite, the minimisation has converged once the energy changes by less than
            ``ftol`` |E| over ten iterations: the iterates then creep along a nearly neutral
            valley. The energy may then still lie above the valley's floor by more than
            ``ftol`` |E|: the test stops a creep, it does not bound the distance left.
        sigma0: the least nonzero shift of the Hessian by the mass (``ShiftedFactor``), in
            the units of its eigenvalues μ (H v = μ M v).
        options: further PETSc options under the prefix ``shells_minimise_`` (TAO, its KSP
            and PC), e.g. {"tao_monitor": None}.

    Raises:
        InputError: on construction, for a setting out of its range.
    """

    method: str = "nls"
    gatol: float = 1.0e-9
    grtol: float = 0.0
    max_it: int = 3000
    newton_below: float = 1.0e-3
    ftol: float = 1.0e-6
    sigma0: float = 1.0e-6
    options: tuple[tuple[str, Any], ...] = ()

    def __post_init__(self) -> None:
        if self.method not in ("nls", "ntr"):
            raise InputError(f"method must be 'nls' or 'ntr', got {self.method!r}")
        if not (self.gatol > 0 and self.grtol >= 0):
            raise InputError("need gatol > 0 and grtol >= 0")
        if not (isinstance(self.max_it, int) and self.max_it >= 1):
            raise InputError(f"max_it must be a positive integer, got {self.max_it!r}")
        if not (self.newton_below >= 0 and math.isfinite(self.newton_below)):
            raise InputError(f"newton_below must be a non-negative number, got "
                             f"{self.newton_below!r}")
        if not (self.ftol >= 0 and math.isfinite(self.ftol)):
            raise InputError(f"ftol must be a non-negative number, got {self.ftol!r}")
        if not (self.sigma0 > 0 and math.isfinite(self.sigma0)):
            raise InputError(f"sigma0 must be a positive number, got {self.sigma0!r}")

    def describe(self) -> dict[str, Any]:
        """The settings as a plain dict (for a run's JSON record)."""
        return asdict(self)


@dataclass(frozen=True)
class DynamicsSettings:
    """Settings of ``shells.algorithms.dynamics.integrate`` (M ü + C u̇ + R(u; κ) = 0, PETSc
    TS generalised-α for second-order systems), validated on construction.

    Attributes:
        t_end: the final time, in units of L √(ρ/E).
        dt: the (initial) time step, same units.
        rho_inf: the spectral radius at infinite step ρ∞ in [0, 1] (1: no numerical
            dissipation, the trapezoidal rule's energy behaviour).
        mass_damping: α of the Rayleigh damping C = α M + β K₀ (≥ 0).
        stiffness_damping: β, K₀ the Jacobian at the start (≥ 0).
        adaptive: adapt the step (TSAdapt "basic" on TSALPHA2's error estimate).
        step_tol: the adaptive step's tolerance on the local error (TS's rtol and atol).
        dt_min: the adaptive step's least value (None: no bound); a step at it is accepted
            whatever its error estimate (TSAdapt's rule).
        dt_max: the adaptive step's greatest value (None: no bound). Near a slowly left
            saddle the error estimate lets the step grow past the basin of the stage's Newton
            solve, which then crawls under its line search or fails and retries.
        rest_tol: stop once the kinetic energy falls below this (None: run to ``t_end``).
        max_steps: safety limit on the steps.

    Raises:
        InputError: on construction, for a setting out of its range.
    """

    # time: the end, the (first) step, the generalised-α's dissipation, adaptive steps
    t_end: float = 1.0
    dt: float = 0.01
    rho_inf: float = 1.0
    adaptive: bool = False
    step_tol: float = 1.0e-4
    dt_min: float | None = None
    dt_max: float | None = None
    # damping C = mass_damping M + stiffness_damping K
    mass_damping: float = 0.0
    stiffness_damping: float = 0.0
    # the stops besides t_end
    rest_tol: float | None = None
    max_steps: int = 100000

    def __post_init__(self) -> None:
        if not (math.isfinite(self.t_end) and self.t_end > 0):
            raise InputError(f"t_end must be positive, got {self.t_end!r}")
        if not (math.isfinite(self.dt) and 0 < self.dt <= self.t_end):
            raise InputError(f"dt must lie in (0, t_end], got {self.dt!r}")
        if not 0.0 <= self.rho_inf <= 1.0:
            raise InputError(f"rho_inf must lie in [0, 1], got {self.rho_inf!r}")
        for name in ("mass_damping", "stiffness_damping"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise InputError(f"{name} must be non-negative, got {v!r}")
        if self.dt_min is not None and not (math.isfinite(self.dt_min)
                                            and 0 < self.dt_min <= self.dt):
            raise InputError(f"dt_min must lie in (0, dt], got {self.dt_min!r}")
        if self.dt_max is not None and not (math.isfinite(self.dt_max)
                                            and self.dt <= self.dt_max):
            raise InputError(f"dt_max must be finite and at least dt, got {self.dt_max!r}")
        if not (math.isfinite(self.step_tol) and self.step_tol > 0):
            raise InputError(f"step_tol must be positive, got {self.step_tol!r}")
        if self.rest_tol is not None and not self.rest_tol > 0:
            raise InputError(f"rest_tol must be positive, got {self.rest_tol!r}")
        if not (isinstance(self.max_steps, int) and self.max_steps >= 1):
            raise InputError(f"max_steps must be a positive integer, got {self.max_steps!r}")
