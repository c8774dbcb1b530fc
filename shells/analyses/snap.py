"""Where a snap lands (analysis layer): ``run``.

A cap loaded past its snap fold has no nearby equilibrium: it jumps. ``run`` follows the
fundamental branch from κ = 0 to its first fold (``shells.algorithms.following.follow``),
takes the state at the fold to κ_start = (1 + ``past``) κ_fold (or a given κ beyond it),
perturbs it along the Hessian's unstable eigenvectors there (an exactly symmetric start would
stay symmetric) and minimises the energy at κ_start (``shells.algorithms.minimise``, TAO's
Newton with negative curvature). The minimum it reaches is the landing state: confirmed by the
Hessian's inertia (no negative eigenvalue beyond the symmetry orbit's), classified by the
azimuthal spectrum of its normal displacement (``symmetric`` when no m ≥ 1 carries more than
``SYMMETRY_TOL`` of the m = 0 amplitude; else ``mode_m``, the strongest), read with the rim's
rotation and Ψ3 at the pole in the shell's best-fit rigid frame (``shells.surface.frame``: the
gauge would tilt a pattern by an amount that depends on its orientation), and compared with the
axisymmetric everted state at the same κ (Newton from the shell mirrored through its rim plane,
continued in κ from half the fold's κ).

With ``method="dynamics"`` the start is integrated in time instead (``snap_dynamics``: the
equations of motion with mass-proportional damping, TSALPHA2, adaptive steps between
``DT_STEP`` and ``DT_MAX``) until the kinetic energy has fallen to ``REST_FRACTION`` of its
peak, or until it has settled: at the end of a segment (below) the kinetic energy under
``SETTLE_FRACTION`` of its peak and the Hessian without a negative eigenvalue but the
symmetry orbit's. The rest state is then polished by the same minimiser (it lies in the
minimum's basin: the polish takes it where the rest of the damped ring-down would), and
``snap_time`` is when the pole's displacement crosses halfway from the start's to the rest
state's.

The dynamics run in segments of ``DYNAMICS_SAVE_EVERY`` steps of one time stepper, each
checkpointed (state, velocity, time, the series so far): a rerun continues from the latest,
its time stepper started afresh there (two reruns from one checkpoint take the same steps; an
uninterrupted run's differ within the step tolerance). Every k-th step's state is kept as a
frame (k doubled whenever more than ``FRAMES_MAX`` would be kept), and the last step's. Once
the motion is written the frames are removed; a run without rendering keeps them (in
``checkpoint/frames``) until a rerun that renders has drawn ``snap.gif`` from them.

Output folder (rank 0 writes): ``snap.json`` (the result), ``landing.png`` and ``landing.vtu``
(the landing shape coloured by the bending energy density, in its best-fit rigid frame),
``everted.png``, with dynamics ``snap_series.csv`` (one row per step), ``snap.bp`` (VTX, the
``FieldWriter`` fields at each frame, each state in its best-fit rigid frame, time in units of
R √(ρ/E)) and ``snap.gif`` (at most ``ANIMATION_FRAMES`` of the
frames, one colour range for all), and ``checkpoint/`` (the fold's state, the dynamics' state
every ``DYNAMICS_SAVE_EVERY`` steps with their frames so far, the rest state of the dynamics,
then the minimiser's iterate every ``SAVE_EVERY`` iterations): a rerun of the same
configuration resumes from the latest.
"""

from __future__ import annotations

import json
import logging
import math
import shutil
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from shells.analyses.setup import open_shell_kappa_R_max
from shells.errors import InputError
from shells.files import json_default, write_atomic
from shells.parameters import check_h_over_r, check_nu

__all__ = ["ANIMATION_FIELD", "ANIMATION_FRAMES", "DAMPING", "DYNAMICS_SAVE_EVERY",
           "FRAMES_MAX", "METHODS", "REST_FRACTION", "SAVE_EVERY", "SERIES_COLUMNS",
           "SETTLE_FRACTION",
           "SYMMETRY_TOL", "DynamicsProgress", "SnapConfig", "classify_landing", "run",
           "snap_dynamics"]

log = logging.getLogger("shells")

#: a landing state is symmetric when no m ≥ 1 has more than this share of the m = 0 amplitude
SYMMETRY_TOL = 1.0e-2
#: the minimiser's iterate is checkpointed every this many iterations
SAVE_EVERY = 10
#: the methods of ``SnapConfig``
METHODS = ("minimise", "dynamics")
#: dynamics: the mass-proportional damping α (C = α M, units √(E/ρ)/R) of a run that sets none
DAMPING = 1.0
#: dynamics: at rest once the kinetic energy has fallen below this fraction of its peak
REST_FRACTION = 1.0e-8
#: dynamics: settled, and stopped, at the end of a segment (every ``DYNAMICS_SAVE_EVERY``
#: steps) where the kinetic energy is below this fraction of its peak and the Hessian has no
#: negative eigenvalue but the symmetry orbit's. A shell that creeps off a saddle is slow but
#: not settled (the Hessian's inertia tells the two apart); one that has settled is taken to
#: lie in that minimum's basin, and its last approach to the minimum, which the damping of the
#: slow modes makes long, is the polish's work. 0: to rest
SETTLE_FRACTION = 1.0e-4
#: dynamics: the least time step (units R √(ρ/E)) and the adaptive step's tolerance on the
#: local error, the spectral radius ρ∞ at infinite step (numerical dissipation, which removes
#: the unresolved stiff membrane modes the start excites within a few steps) and the time after
#: which a run that has not come to rest stops (its state is polished all the same). Steps
#: never shorter than DT_STEP: shorter ones would follow the ringing of those membrane modes,
#: which the steps of DT_STEP dissipate, and crawl; longer ones where the local error allows
#: (benchmarks/snap_dynamics_steps.py compares the tolerances with fixed steps)
DT_STEP = 0.05
STEP_TOL: float | None = 1.0e-4  # None: fixed steps of DT_STEP
#: dynamics: the greatest adaptive step (units R √(ρ/E)), the damping time 1/α of ``DAMPING``.
#: Where the shell creeps off a saddle (the everted state of a deep cap) the error estimate
#: alone lets the step grow past the basin of each step's Newton solve, which then crawls
#: under its line search or fails and retries (docs/design-notes.md, "Minimiser and snap
#: landing")
DT_MAX = 1.0
RHO_INF = 0.5
T_MAX = 5000.0
#: dynamics: the run's progress is checkpointed every this many steps (state, velocity, time,
#: the series so far) and a settled run is looked for; the time stepper goes on unchanged (a
#: restart, or a kinetic mass taken afresh, would make the acceleration it carries
#: inconsistent, exciting the stiff membrane modes that hold the adaptive step down for tens
#: of steps)
DYNAMICS_SAVE_EVERY = 100
#: dynamics: at most this many frames of the motion go into ``snap.bp`` (every k-th step from
#: the start, k doubled whenever more would be kept), and the last step
FRAMES_MAX = 200
#: dynamics: at most this many of those frames (evenly spaced, and the last) go into ``snap.gif``
ANIMATION_FRAMES = 100
#: the field that colours ``snap.gif`` (as ``landing.png``)
ANIMATION_FIELD = "bending_energy_density"


@dataclass(frozen=True)
class SnapConfig:
    """A snap computation on the surface model.

    Attributes:
        shape: an open shell of revolution (a cap, an ellipsoidal cap).
        h_over_r: thickness over the shape's length scale.
        nu: Poisson's ratio.
        method: "minimise" (TAO; the landing state at κ_start) or "dynamics" (the equations
            of motion integrated from the start to rest, then polished by TAO).
        past: κ_start = (1 + past) κ_fold, where ``kappa_R`` is None.
        kappa_R: κ_start R, past the fold (None: from ``past``).
        amplitude: the perturbation along each unstable eigenvector, RMS over the thickness.
        kappa_R_max: the fold is searched up to this κR (None: ``open_shell_kappa_R_max``).
        size, degree: the mesh (None: ``default_discretisation``).
        layer_elements: elements across the rim's boundary layer.
        shear_penalty: the Kirchhoff-Love penalty factor.
        damping: dynamics: the mass-proportional damping α, C = α M, in units √(E/ρ)/R
            (None: ``DAMPING``; 0: none, the run then stops at ``T_MAX``).
        step_tol: dynamics: the adaptive steps' tolerance on the local error (None:
            ``STEP_TOL``).
        t_max: dynamics: the run stops at this time, in units of R √(ρ/E), if it has not come
            to rest or settled before (None: ``T_MAX``); its state is polished all the same.
        settle: dynamics: the run stops, settled, where the kinetic energy is below this
            fraction of its peak at a segment's end and the Hessian is stable there (None:
            ``SETTLE_FRACTION``; 0: it runs to rest, ``REST_FRACTION``).

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
    damping: float | None = None
    step_tol: float | None = None
    settle: float | None = None
    t_max: float | None = None

    def __post_init__(self) -> None:
        check_h_over_r(self.h_over_r)
        check_nu(self.nu)
        if getattr(self.shape, "closed", False):
            raise InputError("snap needs an open shell (a cap): a closed sphere buckles, it "
                             "does not snap through")
        if self.method not in METHODS:
            raise InputError(f"method must be one of {', '.join(METHODS)}, got "
                             f"{self.method!r}")
        if self.damping is not None and not (math.isfinite(self.damping)
                                             and self.damping >= 0):
            raise InputError(f"damping must be a non-negative number, got {self.damping!r}")
        if self.step_tol is not None and not (math.isfinite(self.step_tol)
                                              and 0 < self.step_tol < 1):
            raise InputError(f"step_tol must lie in (0, 1), got {self.step_tol!r}")
        if self.settle is not None and not (math.isfinite(self.settle)
                                            and 0 <= self.settle < 1):
            raise InputError(f"settle must lie in [0, 1), got {self.settle!r}")
        if self.t_max is not None and not (math.isfinite(self.t_max) and self.t_max > 0):
            raise InputError(f"t_max must be a positive number, got {self.t_max!r}")
        if not (0 < self.past <= 1):
            raise InputError(f"past must lie in (0, 1], got {self.past!r}")
        if not (self.amplitude > 0 and math.isfinite(self.amplitude)):
            raise InputError(f"amplitude must be a positive number, got {self.amplitude!r}")

    def describe(self) -> dict[str, Any]:
        """Everything that decides the run's numbers, as plain data."""
        d = asdict(self)
        d["shape"] = self.shape.describe()
        if self.method == "minimise":  # no bearing on it (and the header of earlier runs)
            d.pop("damping")
        for k in _STOPS:  # the defaults; a run checkpointed before the options continues
            if d[k] is None:
                d.pop(k)
        return d


#: the settings that decide only where a dynamics run stops, not its motion
_STOPS = ("settle", "t_max")


def _continues(meta: dict[str, Any], header: dict[str, Any]) -> bool:
    """Whether a checkpoint (its ``meta``) continues the run of ``header``: the same
    configuration, or dynamics under way under another ``settle`` or ``t_max``. These decide
    only where the motion stops, not the motion: a run creeping towards its minimum can go on
    under a larger fraction (stopping at the next segment's end that passes it), a smaller one
    (0: to rest) or another time limit, and takes the steps it would have taken either way."""
    saved = meta.get("header")
    if saved == header:
        return True
    if saved is None or not str(meta.get("stage", "")).startswith("dynamics "):
        return False
    return ({k: v for k, v in saved.items() if k not in _STOPS}
            == {k: v for k, v in header.items() if k not in _STOPS})


def _counts_modulo_orbit(model: Any) -> tuple[int, int]:
    """The Hessian's negative count at the model's state, and how many of those lie along its
    symmetry orbit (``Stability.negative_count_modulo_orbit``; collective)."""
    from shells.algorithms.stability import Stability

    stab = Stability(model)
    try:
        neg, orbit = stab.negative_count_modulo_orbit()
    finally:
        stab.destroy()
    return int(neg), int(orbit)


def classify_landing(model: Any, counts: tuple[int, int] | None = None) -> dict[str, Any]:
    """The landing state's stability, symmetry and shape (collective).

    Args:
        model: the surface model holding the state.
        counts: (negative count, orbit modes among them) of this state where the caller has
            them (``minimise_to_stable``'s result); None: computed here.

    Returns:
        ``energy``, ``negative_count`` (all negative eigenvalues), ``orbit_modes`` (those along
        the symmetry orbit, neutral in the continuum), ``stable`` (no negative eigenvalue but
        the orbit's), ``symmetric``, ``mode_m`` (0 when symmetric), ``spectrum`` (the amplitude
        of each m over that of m = 0), ``rim_rotation_deg``, ``psi3_pole_over_h`` (these
        four read in the shell's best-fit rigid frame, ``RigidFrame.aligned``), and
        ``frame_rotation_deg``, the angle of the rigid rotation that took the gauge's
        representative there.
    """
    from shells.surface.frame import rotation_angle_deg

    neg, orbit = counts if counts is not None else _counts_modulo_orbit(model)
    energy = model.total_energy()
    # the aligned state's energy differs from the state's by the nodal interpolation of the
    # turned reference normal: the state's own is reported
    with model.rigid_frame().aligned() as Q:
        power = model.azimuthal_spectrum(model.state)
        s = model.scalars()
    turned = rotation_angle_deg(Q)
    amp = np.sqrt(power / max(power[0], 1e-300))
    symmetric = bool(np.max(amp[1:]) < SYMMETRY_TOL)
    return {"energy": energy, "negative_count": int(neg), "orbit_modes": int(orbit),
            "stable": bool(neg - orbit == 0), "symmetric": symmetric,
            "mode_m": 0 if symmetric else int(1 + np.argmax(amp[1:])),
            "spectrum": [float(a) for a in amp], "rim_rotation_deg": s.get("rim_rotation_deg"),
            "psi3_pole_over_h": s.get("psi3_pole_over_h"), "frame_rotation_deg": turned}


#: the columns of ``snap_series.csv`` (``snap_dynamics``): time in units of R √(ρ/E),
#: energies in units of E R³, Ψ3 at the pole over h, the rim's rotation in degrees, and the
#: amplitudes of the azimuthal modes m = 1..4 of the normal displacement relative to m = 0's
SERIES_COLUMNS = ("time", "kinetic", "elastic", "psi3_pole_over_h", "rim_rotation_deg",
                  "amp_m1", "amp_m2", "amp_m3", "amp_m4")


@dataclass
class DynamicsProgress:
    """A dynamics run so far (``snap_dynamics``): with the model's state, what its checkpoint
    holds and a continued run starts from.

    Attributes:
        rows: the series so far (``SERIES_COLUMNS``), one row per accepted step from the start
            (step 0); the last row is the current state's.
        t: the time reached, in the model's units (the last row's time, unrounded).
        dt: the time step the run takes next, in the model's units (the adaptive step's
            proposal; None: ``DT_STEP``).
        velocity: the velocity at ``t``, this rank's owned values (None: at rest).
        frames: the steps kept as frames so far (multiples of ``frame_every``, at most
            ``FRAMES_MAX``).
        frame_every: the frames' stride k (a power of 2).
    """

    rows: list[list[float]] = field(default_factory=list)
    t: float = 0.0
    dt: float | None = None
    velocity: np.ndarray | None = None
    frames: list[int] = field(default_factory=list)
    frame_every: int = 1

    @property
    def steps(self) -> int:
        """The accepted steps so far."""
        return max(len(self.rows) - 1, 0)

    def take_frame(self, step: int) -> bool:
        """Whether ``step`` (the next accepted one) is kept as a frame: a multiple of the
        stride, the stride doubled first (and the frames off it dropped) when the frames are
        full. Records it when so."""
        if step % self.frame_every:
            return False
        if len(self.frames) >= FRAMES_MAX:
            self.frame_every *= 2
            self.frames = [s for s in self.frames if s % self.frame_every == 0]
            if step % self.frame_every:
                return False
        self.frames.append(step)
        return True


def _snap_time(t: np.ndarray, x: np.ndarray) -> float | None:
    """When Ψ3/h at the pole (``x`` at times ``t``) first crosses halfway from its start
    value to its last, linearly interpolated; None where it moves by less than 1e-3."""
    half = 0.5 * (x[0] + x[-1])
    if abs(x[-1] - x[0]) <= 1e-3:
        return None
    i = int(np.argmax(np.sign(x - half) != np.sign(x[0] - half)))
    return float(t[i - 1] + (half - x[i - 1]) / (x[i] - x[i - 1]) * (t[i] - t[i - 1]))


class _Rest:
    """At rest: the kinetic energy below ``REST_FRACTION`` of its peak so far, once it has
    fallen below half of it (the snap's motion is past its peak).

    Args:
        kinetic: the kinetic energies so far (a continued run's), oldest first.
    """

    def __init__(self, kinetic: list[float]) -> None:
        self.peak, self.passed = 0.0, False
        for k in kinetic:
            self(k)

    def __call__(self, kinetic: float) -> bool:
        """Record ``kinetic`` (the latest step's); whether the shell is at rest."""
        if kinetic > self.peak:
            self.peak = kinetic
        elif kinetic < 0.5 * self.peak:
            self.passed = True
        return self.passed and kinetic < REST_FRACTION * self.peak

    def settled(self, model: Any, step: int, kinetic: float, fraction: float) -> bool:
        """Whether the shell has settled (collective): ``kinetic`` (the model's state's, at
        ``step``) below ``fraction`` of the peak, past it, and the Hessian at the model's
        state without a negative eigenvalue but its symmetry orbit's (``SETTLE_FRACTION``).
        The inertia is computed only where the kinetic energy is that low."""
        if not (fraction > 0 and self.passed and kinetic < fraction * self.peak):
            return False
        neg, orbit = _counts_modulo_orbit(model)
        log.info("snap: dynamics step %d, kinetic %.3g of its peak: %s", step,
                 kinetic / self.peak, "settled" if neg == orbit else
                 f"{neg - orbit} negative eigenvalue(s) beyond the orbit's, going on")
        return neg == orbit


def _series_row(t: float, p: Any, kinetic: float) -> list[float]:
    """One row of ``SERIES_COLUMNS`` at time ``t`` (in R √(ρ/E)), the model ``p`` at its
    state."""
    with p.rigid_frame().aligned():
        s = p.scalars()
        power = p.azimuthal_spectrum(p.state, m_max=4)
    amp = np.sqrt(power / max(float(power[0]), 1e-300))
    return [t, kinetic, s["energy"], s.get("psi3_pole_over_h", math.nan),
            s.get("rim_rotation_deg", math.nan), *(float(a) for a in amp[1:5])]


def snap_dynamics(model: Any, damping: float, t_max: float | None = None, *,
                  resume: DynamicsProgress | None = None,
                  save: Callable[[DynamicsProgress], None] | None = None,
                  keep_frame: Callable[[int, Any], None] | None = None,
                  step_tol: float | None = None, settle: float | None = None
                  ) -> dict[str, Any]:
    """Integrate the equations of motion from the model's state at its κ, at rest, to rest
    or until it has settled (collective).

    Mass-proportional damping C = α M (``damping``), TSALPHA2 with ρ∞ = ``RHO_INF``, adaptive
    steps (between ``DT_STEP`` and ``DT_MAX``, tolerance ``STEP_TOL``), in segments of
    ``DYNAMICS_SAVE_EVERY`` steps of one ``Integrator`` (a checkpoint at each segment's end;
    the time stepper, and its kinetic mass, go on unchanged).
    At rest: the kinetic energy below ``REST_FRACTION`` of its peak, after the peak. Settled:
    so at a segment's end for ``settle``, and the Hessian stable there (``SETTLE_FRACTION``).

    Args:
        model: the surface model, its state the (perturbed) start, or ``resume``'s state;
            left at the final state.
        damping: α, in units √(E/ρ)/R (0: none).
        t_max: the run stops at this time if not at rest before (None: ``T_MAX``).
        resume: the progress of a run to continue (its checkpoint's; the model at its state):
            the run goes on from there, its time stepper started afresh (TSALPHA2's start
            acceleration estimated there, so its steps differ from an uninterrupted run's
            within the step tolerance). None: from the start, at rest.
        save: called with the progress at the end of every segment that does not end the run
            (the model at its state): a checkpoint.
        keep_frame: called as ``keep_frame(step, model)`` at each step kept as a frame (the
            model at its state; ``DynamicsProgress.take_frame``).
        step_tol: the adaptive steps' tolerance (None: ``STEP_TOL``).
        settle: the kinetic energy's fraction of its peak under which a segment's end is
            checked for being settled (None: ``SETTLE_FRACTION``; 0: never).

    Returns:
        ``series`` (one row per accepted step, ``SERIES_COLUMNS``), ``frame_steps`` (the
        steps kept as frames, and the last step), ``frame_every``, ``reason`` ("rest",
        "settled" or "time"), ``steps``, ``snap_time`` (the time at which Ψ3 at the pole
        crosses halfway from its start value to its final one, linearly interpolated; None
        where it does not move by 1e-3 h), ``kinetic_peak_time``, ``end_time`` (the time
        reached), ``rest_energy`` (the elastic energy at the end), ``damping``, ``step_tol``,
        ``settle``, ``t_max``.

    Raises:
        RuntimeError: the time integration diverged.
    """
    from shells.algorithms.dynamics import Integrator
    from shells.geometry.shapes import kappa_length

    tscale = kappa_length(model.shape)  # R √(ρ/E) in the model's units (E = ρ = 1)
    prog = resume if resume is not None else DynamicsProgress()
    if prog.dt is None:
        prog.dt = DT_STEP * tscale
    rows = prog.rows
    at_rest = _Rest([r[1] for r in rows])  # a continued run's peak, as the run so far had it
    # a continued run's first monitor call is at its checkpoint's step, the last row's
    segment_start = {"skip": bool(rows)}

    def monitor(t: float, p: Any, kinetic: float) -> bool:
        if segment_start["skip"]:
            segment_start["skip"] = False
            return False
        rows.append(_series_row(t / tscale, p, kinetic))
        step = len(rows) - 1
        if prog.take_frame(step) and keep_frame is not None:
            keep_frame(step, p)
        if len(rows) % 100 == 0:
            log.info("snap: dynamics step %d, t = %.5g, kinetic %.3g, psi3(pole)/h %.4f",
                     step, rows[-1][0], kinetic, rows[-1][3])
        return at_rest(kinetic)

    tol = step_tol if step_tol is not None else STEP_TOL
    settle = SETTLE_FRACTION if settle is None else settle
    st = _dynamics_settings(prog.dt, tscale, damping, T_MAX if t_max is None else t_max, tol)
    velocity = model.create_vector()  # a continued run's, else at rest
    velocity.array_w[:] = 0.0 if prog.velocity is None else prog.velocity[
        :velocity.getLocalSize()]
    run = Integrator(model, st, velocity=velocity, monitor=monitor, t0=prog.t)
    velocity.destroy()  # the integrator holds its own copy
    try:
        while True:
            res = run.advance(DYNAMICS_SAVE_EVERY)
            if res.reason == "diverged":
                raise RuntimeError(f"the time integration diverged at t = {rows[-1][0]:.4g} R "
                                   "sqrt(rho/E)")
            prog.t, prog.dt = res.times[-1], res.dt
            if res.reason != "steps":  # at rest (the monitor's stop) or at t_max
                reason = "rest" if res.reason == "monitor" else "time"
                break
            if at_rest.settled(model, len(rows) - 1, rows[-1][1], settle):
                reason = "settled"
                break
            prog.velocity = res.velocity.array_r.copy()
            if save is not None:
                save(prog)
    finally:
        run.destroy()
    return {**_dynamics_summary(prog, reason), "damping": damping, "step_tol": tol,
            "settle": settle, "t_max": st.t_end / tscale}


def _dynamics_settings(dt: float, tscale: float, damping: float, t_max: float,
                       tol: float | None) -> Any:
    """The ``DynamicsSettings`` of ``snap_dynamics`` (times in the model's units, ``tscale``
    = R √(ρ/E) in them): the first step ``dt`` (the one the run would take next) kept
    between ``DT_STEP`` and ``DT_MAX``; ``tol`` None: fixed steps."""
    from shells.algorithms.settings import DynamicsSettings

    dt_min, dt_max = DT_STEP * tscale, DT_MAX * tscale
    return DynamicsSettings(t_end=t_max * tscale, rho_inf=RHO_INF, adaptive=tol is not None,
                            step_tol=tol or 1.0e-4, dt_min=dt_min, dt_max=dt_max,
                            dt=min(max(dt, dt_min), dt_max), mass_damping=damping / tscale)


def _dynamics_summary(prog: DynamicsProgress, reason: str) -> dict[str, Any]:
    """``snap_dynamics``' result but its settings, from the progress at the run's end."""
    a = np.array(prog.rows)
    t = a[:, 0]
    steps = len(prog.rows) - 1
    frames = prog.frames + ([steps] if not prog.frames or prog.frames[-1] != steps else [])
    return {"series": prog.rows, "frame_steps": frames, "frame_every": prog.frame_every,
            "reason": reason, "steps": steps, "snap_time": _snap_time(t, a[:, 3]),
            "kinetic_peak_time": float(t[int(np.argmax(a[:, 1]))]),
            "end_time": float(t[-1]), "rest_energy": float(a[-1, 2])}


def _write_series(path: Path, rows: list[list[float]]) -> None:
    """``snap_series.csv``."""
    lines = [",".join(SERIES_COLUMNS)] + [",".join(f"{v:.12g}" for v in r) for r in rows]
    write_atomic(path, "\n".join(lines) + "\n")


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
    kR_end = (cfg.kappa_R_max if cfg.kappa_R_max is not None
              else open_shell_kappa_R_max(cfg.shape, cfg.h_over_r))
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


class _SnapRun:
    """One ``run``: the model, the output folder and its checkpoint, the start, the landing
    (dynamics and/or minimisation), the everted state and the result. Arguments as ``run``'s."""

    def __init__(self, cfg: SnapConfig, outdir: str | Path | None, render: bool) -> None:
        from mpi4py import MPI

        from shells.geometry.shapes import kappa_length

        self.cfg, self.render = cfg, render
        self.comm = MPI.COMM_WORLD
        self.t0 = time.perf_counter()
        self.R = kappa_length(cfg.shape)
        self.model, self.params, self.mesh = _model(cfg, self.comm)
        self.out = Path(outdir) if outdir is not None else None
        self.ck = self.out / "checkpoint" if self.out is not None else None
        self.header = json.loads(json.dumps(cfg.describe(), default=json_default))
        self.meta: dict[str, Any] = {}
        self.unstable: list[dict[str, Any]] | None = None
        # a resumed dynamics checkpoint's velocity and series (``DynamicsProgress``)
        self.resumed: dict[str, np.ndarray] = {}
        self.files: dict[str, str] = {}
        self.kappa = 0.0

    def save(self, index: int, w: np.ndarray, stage: str, states: dict[str, np.ndarray]
             | None = None, scalars: dict[str, np.ndarray] | None = None,
             **extra: Any) -> None:
        """Checkpoint the state ``w`` at ``stage`` (with the run's meta and ``extra``; other
        ``states`` beside it, this rank's ``scalars``: rank 0's are the ones read back)."""
        from shells.analyses.store import save_state_checkpoint

        if self.ck is not None:
            save_state_checkpoint(self.ck, self.model, index, {"w": w, **(states or {})},
                                  scalars=scalars, meta={**self.meta, "stage": stage, **extra})

    def start(self, resume: bool) -> float:
        """The start: the checkpoint's state, or the fold's (followed to); sets the state and
        κ (perturbed along the unstable modes at a fresh start); returns κ."""
        from shells.algorithms.minimise import perturb_unstable
        from shells.analyses.store import load_state_checkpoint
        from shells.problem.interface import set_state

        cfg, R = self.cfg, self.R
        got = (load_state_checkpoint(self.ck, self.model, ("w",))
               if self.ck is not None and resume else None)
        if got is not None and _continues(got[0], self.header):
            # the checkpoint's own bookkeeping (its index, its ranks) is not carried forward
            self.meta = {k: v for k, v in got[0].items() if k not in ("index", "ranks")}
            self.meta["header"] = self.header
            w = got[1]["w"]
            self.resumed = {k: v for k, v in {**got[1], **got[2]}.items() if k != "w"}
            self.files = dict(self.meta.get("files", {}))
            log.info("snap: resuming from the checkpoint (%s)", self.meta["stage"])
        else:
            log.info("snap: %s, %d DOFs: following the fundamental branch to its snap fold",
                     cfg.shape.describe(), self.model.num_dofs())
            self._clear_frames()
            kappa_fold, w, cps = _to_fold(self.model, cfg, R)
            self.meta = {"header": self.header, "kappa_fold": kappa_fold,
                         "critical_points": cps, "stage": "fold"}
            self.save(0, w, "fold")
        kappa_fold = self.meta["kappa_fold"]
        kappa = cfg.kappa_R / R if cfg.kappa_R is not None else (1.0 + cfg.past) * kappa_fold
        if not kappa * np.sign(kappa_fold) > abs(kappa_fold):
            raise InputError(f"kappa R = {kappa * R:g} is not past the snap fold at kappa R = "
                             f"{kappa_fold * R:.6g}")
        set_state(self.model, w)
        self.model.set_kappa(kappa)
        self.unstable = self.meta.get("unstable")
        if self.meta["stage"] == "fold":
            self.unstable = perturb_unstable(self.model, cfg.amplitude)
            log.info("snap: at kappa R = %.6f (%.3g past the fold), %d unstable direction(s): "
                     "m = %s", kappa * R, kappa / kappa_fold - 1, len(self.unstable),
                     [u["mode_m"] for u in self.unstable])
        return kappa

    def integrate(self, kappa: float) -> dict[str, Any] | None:
        """The dynamics to rest (``method`` "dynamics", unless a checkpoint has them), from
        the start or from the checkpoint of a run under way; then ``snap_series.csv``,
        ``snap.bp`` and ``snap.gif``."""
        dyn = self.meta.get("dynamics")
        self.kappa = kappa
        if dyn is not None and self.render and self.meta.get("kept_frames"):
            self._draw_kept(dyn)
        if self.cfg.method != "dynamics" or dyn is not None:
            return dyn
        damping = DAMPING if self.cfg.damping is None else self.cfg.damping
        prog = self._progress()
        if prog is None:
            log.info("snap: integrating in time from kappa R = %.6f, damping %g",
                     kappa * self.R, damping)
        else:
            log.info("snap: integrating in time from step %d (t = %.5g), damping %g",
                     prog.steps, prog.rows[-1][0], damping)
        dyn = snap_dynamics(self.model, damping, resume=prog, save=self._save_progress,
                            keep_frame=self._keep_frame if self.ck is not None else None,
                            step_tol=self.cfg.step_tol, settle=self.cfg.settle,
                            t_max=self.cfg.t_max)
        rows, frames = dyn.pop("series"), dyn.pop("frame_steps")
        dyn["frames"], dyn["animation_frames"] = 0, 0
        if self.out is not None:
            if self.comm.rank == 0:
                _write_series(self.out / "snap_series.csv", rows)
            self.files["series"] = "snap_series.csv"
            times = [rows[k][0] for k in frames]
            dyn["frames"], dyn["animation_frames"] = self._motion(frames, times)
            if not self.render and self.ck is not None:
                # kept, the last step's too, for a rerun that draws the animation
                self._keep_frame(frames[-1], self.model)
                self.meta["kept_frames"] = [[k, t] for k, t in zip(frames, times, strict=True)]
        log.info("snap: %s after %d steps, snap time %s, rest energy %.10g", dyn["reason"],
                 dyn["steps"], dyn["snap_time"], dyn["rest_energy"])
        self.meta = {k: v for k, v in self.meta.items() if k != "progress"}
        self.meta.update(dynamics=dyn, unstable=self.unstable, files=self.files)
        self.save(1, self.model.state.array_r.copy(), "dynamics")
        if "kept_frames" not in self.meta:
            self._clear_frames()
        return dyn

    def _draw_kept(self, dyn: dict[str, Any]) -> None:
        """``snap.bp`` and ``snap.gif`` from the frames a run without rendering kept (a rerun
        that renders); the counts in ``dyn`` and the checkpoint's meta updated, the frames
        removed (collective)."""
        from shells.problem.interface import get_state

        kept = self.meta.pop("kept_frames")
        dyn["frames"], dyn["animation_frames"] = self._motion([int(k) for k, _ in kept],
                                                              [float(t) for _, t in kept])
        self.meta.update(dynamics=dyn, files=self.files)
        self.save(0, get_state(self.model), self.meta["stage"])
        self._clear_frames()

    def _progress(self) -> DynamicsProgress | None:
        """The progress of the checkpoint's dynamics under way (None: none, or not whole)."""
        p = self.meta.get("progress")
        if p is None:
            return None
        series, v = self.resumed.get("series"), self.resumed.get("v")
        if series is None or v is None:
            log.info("snap: the checkpoint's dynamics lack their series or velocity: "
                     "integrating from the start")
            return None
        rows = np.asarray(series, dtype=float).reshape(-1, len(SERIES_COLUMNS)).tolist()
        return DynamicsProgress(rows=rows, t=p["t"], dt=p["dt"], velocity=v,
                                frames=list(p["frames"]), frame_every=p["frame_every"])

    def _save_progress(self, prog: DynamicsProgress) -> None:
        """Checkpoint the dynamics under way (``snap_dynamics``' ``save``), then remove the
        frames it no longer keeps."""
        progress = {"t": prog.t, "dt": prog.dt, "frames": prog.frames,
                    "frame_every": prog.frame_every, "steps": prog.steps}
        self.save(prog.steps, self.model.state.array_r.copy(), f"dynamics {prog.steps}",
                  states={"v": prog.velocity},
                  scalars={"series": np.asarray(prog.rows, dtype=float).ravel()}
                  if self.comm.rank == 0 else None,
                  progress=progress, unstable=self.unstable)
        self._clear_frames(keep=prog.frames)

    def _frames_dir(self) -> Path | None:
        """Where the frames of the dynamics under way are kept (in the checkpoint)."""
        return self.ck / "frames" if self.ck is not None else None

    def _keep_frame(self, step: int, model: Any) -> None:
        """Keep the model's state as the frame of ``step`` (``snap_dynamics``' ``keep_frame``):
        a checkpoint of its own, read back on any partition."""
        from shells.analyses.store import save_state_checkpoint

        save_state_checkpoint(self._frames_dir() / str(step), model, step,
                              {"w": model.state.array_r})

    def _clear_frames(self, keep: list[int] | None = None) -> None:
        """Remove the kept frames but those of the steps ``keep`` (collective; rank 0 does)."""
        d = self._frames_dir()
        if d is None:
            return
        if self.comm.rank == 0 and d.is_dir():
            names = {str(s) for s in keep or ()}
            for f in d.iterdir():
                if f.name in names:
                    continue
                if f.is_dir():
                    shutil.rmtree(f, ignore_errors=True)
                else:
                    f.unlink(missing_ok=True)
        self.comm.barrier()

    def _motion(self, frames: list[int], times: list[float]) -> tuple[int, int]:
        """``snap.bp`` (the fields at each frame ``frames[i]`` at ``times[i]``, in units of
        R √(ρ/E)) and, where asked, ``snap.gif`` (at most ``ANIMATION_FRAMES`` of them, and the
        last); each frame's state is read from its kept frame, the last step's, where none is
        kept, is the model's. The model is left at its state. Returns the frame counts of the
        two (collective)."""
        from shells.analyses.store import load_state_checkpoint
        from shells.problem.interface import set_state
        from shells.surface.fields import FieldWriter

        final = self.model.state.array_r.copy()
        bp = self.out / "snap.bp"
        if self.comm.rank == 0 and bp.exists():
            shutil.rmtree(bp)
        self.comm.barrier()
        every = max(1, math.ceil(len(frames) / ANIMATION_FRAMES))
        drawn = set(frames[::every]) | {frames[-1]} if self.render else set()
        writer = FieldWriter(self.model, bp)
        reference, animation = None, []
        written = 0
        try:
            for step, t in zip(frames, times, strict=True):
                got = load_state_checkpoint(self._frames_dir() / str(step), self.model, ("w",))
                if got is not None:
                    w = got[1]["w"]
                elif step == frames[-1]:
                    w = final
                else:
                    log.info("snap: the frame of step %d is missing: left out", step)
                    continue
                set_state(self.model, w)
                with self.model.rigid_frame().aligned():
                    funcs = writer.write(t)
                written += 1
                if step in drawn:
                    grid, frame = self._gather_frame(funcs, t)
                    reference = reference if reference is not None else grid
                    animation.append(frame)
        finally:
            writer.close()
            set_state(self.model, final)
        self.files["fields"] = "snap.bp"
        log.info("snap: %d frames of the motion in %s", written, bp)
        if not self.render:
            return written, 0
        if self.comm.rank == 0:
            from shells.analyses.render import render_animation

            render_animation(reference, animation, self.out / "snap.gif",
                             scalars=ANIMATION_FIELD)
        self.comm.barrier()
        self.files["animation"] = "snap.gif"
        return written, len(animation)

    def _gather_frame(self, funcs: dict[str, Any], t: float
                      ) -> tuple[Any, tuple[np.ndarray, np.ndarray, str]]:
        """The fields ``funcs`` of the frame at ``t``, gathered to rank 0 for the animation:
        (the reference grid, (the displacement, ``ANIMATION_FIELD``, the title)); (None, empty
        arrays) elsewhere (collective)."""
        from shells.analyses.render import gather_fields

        grid = gather_fields(funcs)
        if grid is None:
            return None, (np.empty(0), np.empty(0), "")
        title = (f"snap, $\\kappa R$ = {self.kappa * self.R:.4f}: $t$ = {t:.4g} "
                 "$R\\sqrt{\\rho/E}$")
        return grid, (np.array(grid.point_data["displacement"]),
                      np.array(grid.point_data[ANIMATION_FIELD]), title)

    def monitor(self, tao: Any) -> None:
        """The minimiser's progress and checkpoints, every ``SAVE_EVERY`` iterations."""
        it = tao.getIterationNumber()
        if it % SAVE_EVERY:
            return
        if it > 0:
            self.save(it, tao.getSolution().array_r.copy(), f"minimise {it}",
                      unstable=self.unstable)
        if self.comm.rank == 0:
            _, f, gnorm, *_ = tao.getSolutionStatus()
            log.info("snap: minimise iteration %d, energy %.10g, |gradient| %.3g", it, f, gnorm)

    def land(self, kappa: float, dyn: dict[str, Any] | None) -> dict[str, Any]:
        """Minimise to a stable state (after dynamics: polish its rest state); classified."""
        from shells.algorithms.minimise import minimise_to_stable
        from shells.algorithms.settings import MinimiseSettings

        res = minimise_to_stable(self.model, MinimiseSettings(), amplitude=self.cfg.amplitude,
                                 monitor=self.monitor)
        if not res.converged:
            raise RuntimeError(f"the minimiser stopped without converging ({res.reason}, "
                               f"|gradient| {res.gradient_norm:.3g} after {res.iterations} "
                               "iterations): rerun to resume, or use a smaller --past")
        # a stable end's inertia is minimise_to_stable's, counted on this very state (an
        # unstable one was perturbed after its count: counted again)
        counts = ((res.negative_count, res.orbit_modes)
                  if res.negative_count is not None and res.negative_count == res.orbit_modes
                  else None)
        landing = {"kappa_R": kappa * self.R, **classify_landing(self.model, counts),
                   "iterations": res.iterations, "converged": res.converged,
                   "gradient_norm": res.gradient_norm, "minimiser_reason": res.reason,
                   "orbit_gradient": res.orbit_gradient}
        if res.reason == "CONVERGED_ENERGY_SETTLED":
            # a nearly flat valley: the energy still creeps down, slower than the settled test
            # sees (the Fig. 1 d cap: docs/paper-comparison.md)
            log.warning("snap: the minimiser stopped where its energy settled (|gradient| "
                        "%.2g), in a nearly flat valley: the landing's energy may lie above "
                        "the valley's floor; --method dynamics goes further",
                        res.gradient_norm)
        if dyn is not None:  # the dynamic rest state's energy, before the polish
            landing["rest_energy"] = dyn["rest_energy"]
        log.info("snap: landed at energy %.10g: %s, %s, negative %d (orbit %d)",
                 landing["energy"], "stable" if landing["stable"] else "UNSTABLE",
                 "symmetric" if landing["symmetric"] else f"m = {landing['mode_m']}",
                 landing["negative_count"], landing["orbit_modes"])
        with self.model.rigid_frame().aligned():  # drawn as read: axis up, untilted
            self.draw(self.model, "landing", f"landing state, kappa R = {kappa * self.R:.4f}"
                      + ("" if landing["symmetric"] else f", m = {landing['mode_m']}"),
                      vtu=True)
        return landing

    def draw(self, model: Any, name: str, title: str, vtu: bool = False) -> None:
        """``DIR/name.png`` (and ``.vtu``) of the model's state, where asked."""
        if self.out is None or not self.render or model is None:
            return
        from shells.analyses.render import render_state

        render_state(model, self.out / f"{name}.png",
                     vtu=self.out / f"{name}.vtu" if vtu else None, title=title)
        self.files[f"{name}_image"] = f"{name}.png"
        if vtu:
            self.files[f"{name}_fields"] = f"{name}.vtu"

    def result(self, kappa: float, landing: dict[str, Any], ev: dict[str, Any],
               dyn: dict[str, Any] | None) -> dict[str, Any]:
        """The run's result (``run``'s), written to ``DIR/snap.json``."""
        kf = self.meta["kappa_fold"]
        result = {"start": {"kappa_R": kappa * self.R, "kind": "fold",
                            "kappa_fold_R": kf * self.R, "unstable": self.unstable},
                  "method": self.cfg.method, "landing": landing, "axisymmetric_everted": ev,
                  "snap_time": None if dyn is None else dyn["snap_time"], "dynamics": dyn,
                  "critical_points": self.meta["critical_points"],
                  "dofs": self.model.num_dofs(), "mesh": self.mesh, "config": self.header,
                  "wall_time": time.perf_counter() - self.t0,
                  "files": {"result": "snap.json", **self.files} if self.out is not None
                  else {}}
        if self.out is not None and self.comm.rank == 0:
            write_atomic(self.out / "snap.json",
                         json.dumps(result, indent=1, default=json_default))
        return result


def run(cfg: SnapConfig, outdir: str | Path | None = None, *, render: bool = True,
        resume: bool = True) -> dict[str, Any]:
    """Where the shell of ``cfg`` lands when it snaps (the surface model; collective).

    Args:
        cfg: the shell and the run's settings.
        outdir: the output folder (None: nothing written or resumed).
        render: draw ``landing.png``, ``everted.png`` and (dynamics) ``snap.gif`` (needs
            pyvista); without it a dynamics run keeps its frames in ``checkpoint/frames`` for
            a rerun that renders to draw ``snap.gif`` from.
        resume: resume from ``outdir/checkpoint`` when it is of the same configuration.

    Returns:
        ``start`` ({"kappa_R", "kind": "fold", "kappa_fold_R", "unstable": [{eigenvalue,
        mode_m}]}), ``method``, ``landing`` (``classify_landing`` plus ``kappa_R``,
        ``iterations``, ``converged``), ``axisymmetric_everted`` ({"energy",
        "negative_count", "rim_rotation_deg"}), ``snap_time`` (None: minimisation has no
        time; dynamics: ``snap_dynamics``' in units of R √(ρ/E)), ``dynamics``
        (``snap_dynamics``' result without its series and frame steps, with ``frames`` and
        ``animation_frames``, the frame counts of ``snap.bp`` and ``snap.gif``, 0 where not
        written; None for minimisation; the landing then carries ``rest_energy``, the energy
        at rest before the polish), ``critical_points``, ``dofs``, ``mesh``, ``wall_time``,
        ``files`` (the output folder's files of this run by what they are: "result",
        "series", "fields" (``snap.bp``), "animation" (``snap.gif``), "landing_image",
        "landing_fields", "everted_image"; empty without a folder).

    Raises:
        InputError: no fold in the range, or κ_start not past the fold.
        RuntimeError: the minimiser stopped without converging.
    """
    run = _SnapRun(cfg, outdir, render)
    kappa = run.start(resume)
    dyn = run.integrate(kappa)
    landing = run.land(kappa, dyn)
    ev = _everted(run.model, run.params, kappa, run.meta["kappa_fold"])
    run.draw(ev.pop("model"), "everted",
             f"axisymmetric everted state, kappa R = {kappa * run.R:.4f}")
    return run.result(kappa, landing, ev, dyn)
