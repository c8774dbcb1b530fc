"""Dynamics of a shell (algorithm layer): ``integrate`` M ü + C u̇ + R(u; κ) = 0 in time.

M is the problem's kinetic mass (``shells.problem.interface.KineticMass``, assembled once at
the start state), R the residual (the energy's gradient), C = α M + β K₀ Rayleigh damping (K₀
the Jacobian at the start; zero allowed). Time is in units of L √(ρ/E). PETSc TS's
generalised-α method for second-order systems (TSALPHA2, options prefix
``shells_dynamics_``), ρ∞ from the settings (1: no numerical dissipation), a fixed or an
adaptive step (TSAdapt "basic").

The gauge is no support: the kinetic mass is the free shell's relative to its centre of mass
(``shells.problem.kinetic``), its rigid part a rank-k term -U Uᵀ (a MATLRC). The Newton
systems J = a M + b C + K are solved by GMRES preconditioned by their exact inverse
(``LowRankInverse``: the LU of the sparse part, the Woodbury identity for the rank-k term).
The gauge's constrained DOFs keep zero (unit rows of K, zero residual). A free shell's
centre of mass thus keeps its momentum (zero in this frame): the gauged coordinates describe
the motion relative to it, and the rigid motion that the gauge removes is never accelerated
by a reaction. The rigid motions are those of the start state
(exact for translations; rotations linearised there).

``Integrator`` is an integration that goes on: each ``advance`` continues the same TS (no
restart: TSALPHA2 restarts only at its first step, where it estimates the start acceleration
from two backward-Euler half steps, whose error excites the stiff membrane modes and holds the
adaptive step down for some steps). ``integrate`` is one ``advance`` to the end.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from shells.algorithms.newton import apply_options, configure_factor, setup_factor
from shells.algorithms.settings import DynamicsSettings
from shells.errors import InputError
from shells.problem.interface import Energy, KineticMass

__all__ = ["DYNAMICS_PREFIX", "DynamicsResult", "Integrator", "LowRankInverse", "integrate"]

log = logging.getLogger("shells")

#: PETSc options prefix of the time stepper
DYNAMICS_PREFIX = "shells_dynamics_"


@dataclass
class DynamicsResult:
    """A time series (one entry per accepted step, the start included).

    Attributes:
        times: t in units of L √(ρ/E).
        kinetic: ½ u̇ᵀ M u̇.
        elastic: the energy E(u, κ) (NaN where the problem has no ``Energy``).
        reason: "time" (reached t_end), "steps" (reached an ``advance``'s step limit or
            ``max_steps``), "rest" (kinetic energy below ``rest_tol``), "monitor" (the
            monitor asked to stop), or "diverged".
        steps: the accepted steps (of all ``advance`` calls).
        velocity: the velocity at the end (a state-shaped PETSc vector, the caller's; with the
            final state and time, what a later ``integrate`` continues from).
        dt: the step the stepper would take next (adaptive: its proposal).
    """

    times: list[float] = field(default_factory=list)
    kinetic: list[float] = field(default_factory=list)
    elastic: list[float] = field(default_factory=list)
    reason: str = "time"
    steps: int = 0
    velocity: Any = None
    dt: float = 0.0


class _LowRank:
    """x ↦ (M - M_sparse) x: the low-rank part of a MATLRC mass."""

    def __init__(self, M: Any, Ms: Any) -> None:
        self.M, self.Ms = M, Ms

    def mult(self, x: Any, y: Any) -> None:
        self.M.mult(x, y)
        t = y.duplicate()
        self.Ms.mult(x, t)
        y.axpy(-1.0, t)
        t.destroy()

    def destroy(self) -> None:
        pass


class LowRankInverse:
    """A preconditioner (petsc4py's python PC): the exact inverse of the time step's Jacobian
    J = P + s U diag(c) Uᵀ, P the sparse matrix (the PC's Pmat), U diag(c) Uᵀ the low-rank
    part of a MATLRC mass (``shells.problem.kinetic.free_body_mass``: c = -1) and s its
    scale in J (``_Jacobian.scale``), by the Woodbury identity

        J⁻¹ = P⁻¹ - W (diag(1/(s c)) + UᵀW)⁻¹ Wᵀ,   W = P⁻¹ U,

    with one LU of P (``LOWRANK_OPTIONS``: MUMPS, under the prefix
    ``shells_dynamics_lowrank_``, set up and factored as the other solvers' factors are:
    ``shells.algorithms.newton.configure_factor``, ``setup_factor``) and k extra solves per
    factorisation (k the rank). GMRES around it (``integrate``) converges in one or two
    iterations; it mops up the rounding of the k×k system, which cancels when s M dominates K.

    Args:
        M: the MATLRC mass.
        jacobian: the ``_Jacobian`` context whose ``scale`` is s.
    """

    PREFIX = "shells_dynamics_lowrank_"
    #: the factorisation of P (options under ``PREFIX`` override them)
    LOWRANK_OPTIONS: dict[str, Any] = {"ksp_type": "preonly", "pc_type": "lu",
                                       "pc_factor_mat_solver_type": "mumps"}

    def __init__(self, M: Any, jacobian: Any) -> None:
        _, U, c, _ = M.getLRCMats()
        self._Ud = U
        self.c = c.getArray().copy()
        dense = U.getDenseArray()
        self.U = []
        for j in range(dense.shape[1]):
            u = U.createVecLeft()
            u.array_w[:] = dense[:, j]
            self.U.append(u)
        self.W: list[Any] = []
        self.jacobian = jacobian
        self.Sinv: np.ndarray | None = None
        self._ksp: Any = None
        self._options: dict[str, Any] = {}

    def setUp(self, pc: Any) -> None:  # noqa: N802 - petsc4py's name
        """Factor P, and W and the k×k system for the present scale."""
        from petsc4py import PETSc

        P = pc.getOperators()[1]
        if self._ksp is None:
            self._ksp = PETSc.KSP().create(P.getComm())
            self._options = apply_options(self._ksp, self.PREFIX, self.LOWRANK_OPTIONS)
            configure_factor(self._ksp, P, self._options)
        self._ksp.setOperators(P)
        if not setup_factor(self._ksp, P, self._options):
            raise RuntimeError("the time step's sparse matrix could not be factored")
        if not self.W:
            self.W = [u.duplicate() for u in self.U]
        self._solve_columns()
        s = self.jacobian.scale
        if s == 0.0:
            self.Sinv = None
            return
        G = np.array([[float(u.dot(w)) for w in self.W] for u in self.U])
        self.Sinv = np.linalg.inv(np.diag(1.0 / (s * self.c)) + 0.5 * (G + G.T))

    def _solve_columns(self) -> None:
        """W = P⁻¹ U: the k columns at once (one MUMPS solve with k right-hand sides, which
        in parallel communicates once instead of k times), else one by one."""
        pc = self._ksp.getPC()
        if pc.getFactorSolverType() == "mumps":
            F = pc.getFactorMatrix()
            B, X = self._Ud.duplicate(copy=True), self._Ud.duplicate()
            F.matSolve(B, X)
            arr = X.getDenseArray(readonly=True)
            for j, w in enumerate(self.W):
                w.array_w[:] = arr[:, j]
            B.destroy()
            X.destroy()
            return
        for u, w in zip(self.U, self.W, strict=True):
            self._ksp.solve(u, w)

    def apply(self, pc: Any, x: Any, y: Any) -> None:
        """y = J⁻¹ x."""
        self._ksp.solve(x, y)
        if self.Sinv is None:
            return
        a = self.Sinv @ np.array([float(u.dot(y)) for u in self.U])
        for w, aj in zip(self.W, a, strict=True):
            y.axpy(-float(aj), w)

    def destroy(self, pc: Any = None) -> None:
        """Free the factorisation and the vectors."""
        for o in (self._ksp, *self.U, *self.W):
            if o is not None:
                o.destroy()
        self._ksp, self.U, self.W = None, [], []


class _Jacobian:
    """The shell Mat of J = a M + b C + K with M (and C's M part) possibly low-rank corrected:
    P x plus the low-rank part, P the sparse matrix assembled each Jacobian."""

    def __init__(self, P: Any, lowrank: Any) -> None:
        self.P, self.lowrank, self.scale = P, lowrank, 0.0

    def mult(self, mat: Any, x: Any, y: Any) -> None:
        self.P.mult(x, y)
        if self.lowrank is not None and self.scale != 0.0:
            t = y.duplicate()
            self.lowrank.mult(x, t)
            y.axpy(self.scale, t)
            t.destroy()


def integrate(problem: Any, settings: DynamicsSettings, velocity: Any = None,
              block: Any = None,
              monitor: Callable[[float, Any, float], bool | None] | None = None, *,
              t0: float = 0.0) -> DynamicsResult:
    """Integrate the equations of motion from the problem's state at its κ (one
    ``Integrator``'s ``advance`` to the end).

    Args:
        problem: a ``Problem`` with ``KineticMass``; its state is the start (and on return the
            final state).
        settings: the ``DynamicsSettings``.
        velocity: the start velocity (a state-shaped vector; None: at rest).
        block: the block whose kinetic mass is used: the state's own (None).
        monitor: called as ``monitor(t, problem, kinetic)`` at the start and after every
            accepted step, the problem holding the state at t (synced), ``kinetic`` the kinetic
            energy there; a true return stops the run (reason "monitor").
        t0: the start time: a run continued from where an earlier one stopped, from its
            final state, ``velocity`` and time (the settings' ``t_end`` stays the end). It
            starts afresh there (the kinetic mass assembled at that state, TSALPHA2's start
            acceleration computed from it), so two runs continued from one (state, velocity,
            t0) take the same steps, which one run through t0 does not quite.

    Returns:
        The ``DynamicsResult``; the problem holds the final state.

    Raises:
        InputError: a problem without a kinetic mass.
    """
    run = Integrator(problem, settings, velocity, block, monitor, t0=t0)
    try:
        return run.advance()
    finally:
        run.destroy()


class Integrator:
    """An integration of the equations of motion that goes on: ``advance`` takes the next
    steps of the same TS, as one uninterrupted run would.

    Args:
        problem, settings, velocity, block, monitor, t0: as ``integrate``'s; the monitor is
            called at the start on construction.

    Raises:
        InputError: a problem without a kinetic mass.
    """

    def __init__(self, problem: Any, settings: DynamicsSettings, velocity: Any = None,
                 block: Any = None,
                 monitor: Callable[[float, Any, float], bool | None] | None = None, *,
                 t0: float = 0.0) -> None:
        if not isinstance(problem, KineticMass):
            raise InputError("this problem has no kinetic mass (assemble_kinetic_mass)")
        self._run = _Integration(problem, settings, block, monitor)
        try:
            self._run.start(velocity, t0)
        except BaseException:
            self._run.destroy()
            raise

    def advance(self, steps: int | None = None) -> DynamicsResult:
        """Up to ``steps`` more accepted steps (None: until ``t_end``, at rest, the monitor's
        stop or ``max_steps``).

        Returns:
            The ``DynamicsResult`` of the whole integration so far (its ``reason`` this
            call's); the problem holds the state reached.
        """
        return self._run.advance(steps)

    def destroy(self) -> None:
        """Free the time stepper, matrices and vectors."""
        self._run.destroy()


class _Integration:
    """One ``Integrator``: the mass, damping and Jacobian matrices, the residual and Jacobian
    of M ü + C u̇ + R(u), the TS, and the record of each step. Arguments as ``integrate``'s."""

    def __init__(self, problem: Any, s: DynamicsSettings, block: Any,
                 monitor: Callable[[float, Any, float], bool | None] | None) -> None:
        from petsc4py import PETSc

        from shells.problem.kinetic import sparse_part

        self.problem, self.s, self.monitor = problem, s, monitor
        self.comm = problem.state.getComm()
        # the mass once per integration: one changed under the running TS (the rigid motions
        # taken at a later state) leaves the acceleration it carries inconsistent, which
        # excites the stiff membrane modes and holds the adaptive step at its least
        self.M = problem.assemble_kinetic_mass(block)
        self.Ms = sparse_part(self.M)
        self.lowrank = _LowRank(self.M, self.Ms) if self.M.getType() == "lrc" else None
        self.K0 = problem.create_jacobian()
        problem.assemble_jacobian(self.K0)
        self.Cs = None
        if s.mass_damping or s.stiffness_damping:
            self.Cs = self.K0.copy()
            self.Cs.scale(s.stiffness_damping)
            self.Cs.axpy(s.mass_damping, self.Ms,
                         structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
        self.P = problem.create_jacobian()
        self.ctx = _Jacobian(self.P, self.lowrank)
        n_loc, n = problem.state.getLocalSize(), problem.state.getSize()
        self.J = PETSc.Mat().createPython(((n_loc, n), (n_loc, n)), self.ctx, comm=self.comm)
        self.J.setUp()
        self.work, self.tmp = problem.create_vector(), problem.create_vector()
        self.u0 = problem.state.copy()
        self.v0 = problem.create_vector()
        self.ts: Any = None
        self.pc_ctx: LowRankInverse | None = None
        self.out = DynamicsResult()
        self.energy = isinstance(problem, Energy)

    def set_state(self, u: Any) -> None:
        """The problem's state from ``u``."""
        u.copy(self.problem.state)
        self.problem.sync()

    def residual(self, ts: Any, t: float, u: Any, v: Any, a: Any, F: Any) -> None:
        """F = R(u) + M a + C v (TS's I2Function)."""
        self.set_state(u)
        self.problem.assemble_residual(self.work)
        self.work.copy(F)
        self.M.mult(a, self.tmp)
        F.axpy(1.0, self.tmp)
        if self.Cs is not None:
            self.Cs.mult(v, self.tmp)
            F.axpy(1.0, self.tmp)
            if self.lowrank is not None and self.s.mass_damping:
                self.lowrank.mult(v, self.tmp)
                F.axpy(self.s.mass_damping, self.tmp)

    def jacobian(self, ts: Any, t: float, u: Any, v: Any, a: Any, shift_v: float,
                 shift_a: float, Jm: Any, Pm: Any) -> None:
        """K(u) + shift_a M + shift_v C: its sparse part into P, the low-rank part scaled in
        the shell matrix (TS's I2Jacobian)."""
        from petsc4py import PETSc

        self.set_state(u)
        self.problem.assemble_jacobian(self.P)
        self.P.axpy(shift_a, self.Ms, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        if self.Cs is not None:
            self.P.axpy(shift_v, self.Cs, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        self.ctx.scale = shift_a + shift_v * self.s.mass_damping
        Jm.assemble()

    def make_ts(self) -> Any:
        """TSALPHA2 under ``DYNAMICS_PREFIX``, the settings' values unless the user set them."""
        from petsc4py import PETSc

        s = self.s
        ts = PETSc.TS().create(comm=self.comm)
        ts.setOptionsPrefix(DYNAMICS_PREFIX)
        ts.setType("alpha2")
        opts = PETSc.Options()
        ours = []
        for k, val in (("ts_alpha_radius", s.rho_inf),
                       ("ts_adapt_type", "basic" if s.adaptive else "none"),
                       ("ts_rtol", s.step_tol), ("ts_atol", s.step_tol),
                       *((("ts_adapt_dt_min", s.dt_min),) if s.dt_min is not None else ()),
                       *((("ts_adapt_dt_max", s.dt_max),) if s.dt_max is not None else ())):
            if not opts.hasName(f"{DYNAMICS_PREFIX}{k}"):  # a user's option wins
                opts[f"{DYNAMICS_PREFIX}{k}"] = val
                ours.append(f"{DYNAMICS_PREFIX}{k}")
        ts.setI2Function(self.residual, self.problem.create_vector())
        ts.setI2Jacobian(self.jacobian, self.J, self.P)
        ts.setTime(0.0)
        ts.setTimeStep(s.dt)
        ts.setMaxTime(s.t_end)
        ts.setMaxSteps(s.max_steps)
        ts.setExactFinalTime(PETSc.TS.ExactFinalTime.MATCHSTEP)
        if s.adaptive:  # a failed Newton solve retries with a smaller step
            ts.setMaxSNESFailures(-1)
        snes = ts.getSNES()
        snes.setTolerances(rtol=1e-10, atol=1e-14, max_it=25)
        ksp = snes.getKSP()
        pc = ksp.getPC()
        if self.lowrank is None:
            ksp.setType("preonly")
            pc.setType("lu")
            pc.setFactorSolverType("mumps")
        else:
            ksp.setType("gmres")
            ksp.setTolerances(rtol=1e-12, atol=1e-30, max_it=50)
            pc.setType("python")
            self.pc_ctx = LowRankInverse(self.M, self.ctx)
            pc.setPythonContext(self.pc_ctx)
        ts.setFromOptions()
        for k in ours:  # the settings' values for this run only
            opts.delValue(k)
        return ts

    def record(self, t: float, u: Any, v: Any) -> None:
        """The time, kinetic and elastic energy at (u, v); the problem left at u."""
        self.set_state(u)
        self.M.mult(v, self.tmp)
        self.out.times.append(float(t))
        self.out.kinetic.append(0.5 * float(v.dot(self.tmp)))
        self.out.elastic.append(self.problem.total_energy() if self.energy else float("nan"))

    def post_step(self, ts: Any) -> None:
        """Record the accepted step; stop at rest or where the monitor says."""
        from petsc4py import PETSc

        u, v = ts.getSolution2()
        self.record(ts.getTime(), u, v)
        out, s = self.out, self.s
        out.steps += 1
        if s.rest_tol is not None and out.kinetic[-1] < s.rest_tol and out.steps > 1:
            out.reason = "rest"
            ts.setConvergedReason(PETSc.TS.ConvergedReason.CONVERGED_USER)
        elif self.monitor is not None and self.monitor(float(ts.getTime()), self.problem,
                                                       out.kinetic[-1]):
            out.reason = "monitor"
            ts.setConvergedReason(PETSc.TS.ConvergedReason.CONVERGED_USER)

    def start(self, velocity: Any, t0: float = 0.0) -> None:
        """The TS at the problem's state with ``velocity`` (None: at rest) at ``t0``; the
        start recorded (and shown to the monitor)."""
        if velocity is None:
            self.v0.set(0.0)
        else:
            velocity.copy(self.v0)
            self.problem.zero_constrained(self.v0)
        self.ts = self.make_ts()
        self.ts.setSolution2(self.u0, self.v0)
        self.ts.setTime(t0)
        self.record(t0, self.u0, self.v0)
        if self.monitor is not None:
            self.monitor(float(t0), self.problem, self.out.kinetic[-1])
        self.ts.setPostStep(self.post_step)

    def advance(self, steps: int | None) -> DynamicsResult:
        """Up to ``steps`` more accepted steps of the same TS (None: to its end)."""
        from petsc4py import PETSc

        limit = self.s.max_steps
        if steps is not None:
            limit = min(int(self.ts.getStepNumber()) + steps, limit)
        self.ts.setMaxSteps(limit)
        self.out.reason = "time"
        try:
            self.ts.solve(self.u0)
        finally:
            reason = int(self.ts.getConvergedReason())
            if reason < 0:
                self.out.reason = "diverged"
            elif reason == PETSc.TS.ConvergedReason.CONVERGED_ITS:
                self.out.reason = "steps"
            u, v = self.ts.getSolution2()
            self.set_state(u)
            if self.out.velocity is None:
                self.out.velocity = v.copy()
            else:  # in place: the caller's vector holds the latest velocity
                v.copy(self.out.velocity)
            self.out.dt = float(self.ts.getTimeStep())
        return self.out

    def destroy(self) -> None:
        """Free the solver, matrices and vectors."""
        for o in (self.ts, self.J, self.P, self.K0, self.work, self.tmp, self.v0, self.u0,
                  self.Cs, self.lowrank, self.pc_ctx):
            if o is not None:
                o.destroy()
