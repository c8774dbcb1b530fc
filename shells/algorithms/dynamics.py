"""Dynamics of a shell (algorithm layer): ``integrate`` M ü + C u̇ + R(u; κ) = 0 in time.

M is the problem's kinetic mass (``shells.problem.interface.KineticMass``, assembled once at
the start state), R the residual (the energy's gradient), C = α M + β K₀ Rayleigh damping (K₀
the Jacobian at the start; zero allowed). Time is in units of L √(ρ/E). PETSc TS's
generalised-α method for second-order systems (TSALPHA2, options prefix
``shells_dynamics_``), ρ∞ from the settings (1: no numerical dissipation), a fixed or an
adaptive step (TSAdapt "basic").

The gauge is no support: the kinetic mass is the free shell's relative to its centre of mass
(``shells.problem.kinetic``), its rigid part a rank-k term -U Uᵀ (a MATLRC). The Newton
systems J = a M + b C + K are solved by GMRES preconditioned by the LU of the sparse part (the
low-rank term adds at most k iterations). The gauge's constrained DOFs keep zero (unit rows of
K, zero residual). A free shell's centre of mass thus keeps its momentum (zero in this frame):
the gauged coordinates describe the motion relative to it, and the rigid motion that the gauge
removes is never accelerated by a reaction. The rigid motions are those of the start state
(exact for translations; rotations linearised there).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from shells.algorithms.settings import DynamicsSettings
from shells.errors import InputError
from shells.problem.interface import Energy, KineticMass

__all__ = ["DYNAMICS_PREFIX", "DynamicsResult", "integrate"]

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
        reason: "time" (reached t_end), "rest" (kinetic energy below ``rest_tol``),
            "monitor" (the monitor asked to stop), or "diverged".
        steps: the accepted steps.
    """

    times: list[float] = field(default_factory=list)
    kinetic: list[float] = field(default_factory=list)
    elastic: list[float] = field(default_factory=list)
    reason: str = "time"
    steps: int = 0


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
              monitor: Callable[[float, Any, float], bool | None] | None = None
              ) -> DynamicsResult:
    """Integrate the equations of motion from the problem's state at its κ.

    Args:
        problem: a ``Problem`` with ``KineticMass``; its state is the start (and on return the
            final state).
        settings: the ``DynamicsSettings``.
        velocity: the start velocity (a state-shaped vector; None: at rest).
        block: the block whose kinetic mass is used: the state's own (None).
        monitor: called as ``monitor(t, problem, kinetic)`` at the start and after every
            accepted step, the problem holding the state at t (synced), ``kinetic`` the kinetic
            energy there; a true return stops the run (reason "monitor").

    Returns:
        The ``DynamicsResult``; the problem holds the final state.

    Raises:
        InputError: a problem without a kinetic mass.
    """
    from petsc4py import PETSc

    from shells.problem.kinetic import sparse_part

    if not isinstance(problem, KineticMass):
        raise InputError("this problem has no kinetic mass (assemble_kinetic_mass)")
    s = settings
    comm = problem.state.getComm()
    M = problem.assemble_kinetic_mass(block)
    Ms = sparse_part(M)
    lowrank = _LowRank(M, Ms) if M.getType() == "lrc" else None
    K0 = problem.create_jacobian()
    problem.assemble_jacobian(K0)
    Cs = None
    if s.mass_damping or s.stiffness_damping:
        Cs = K0.copy()
        Cs.scale(s.stiffness_damping)
        Cs.axpy(s.mass_damping, Ms, structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
    P = problem.create_jacobian()
    ctx = _Jacobian(P, lowrank)
    n_loc, n = problem.state.getLocalSize(), problem.state.getSize()
    J = PETSc.Mat().createPython(((n_loc, n), (n_loc, n)), ctx, comm=comm)
    J.setUp()
    work, tmp = problem.create_vector(), problem.create_vector()

    def set_state(u: Any) -> None:
        u.copy(problem.state)
        problem.sync()

    def residual(ts: Any, t: float, u: Any, v: Any, a: Any, F: Any) -> None:
        set_state(u)
        problem.assemble_residual(work)
        work.copy(F)
        M.mult(a, tmp)
        F.axpy(1.0, tmp)
        if Cs is not None:
            Cs.mult(v, tmp)
            F.axpy(1.0, tmp)
            if lowrank is not None and s.mass_damping:
                lowrank.mult(v, tmp)
                F.axpy(s.mass_damping, tmp)

    def jacobian(ts: Any, t: float, u: Any, v: Any, a: Any, shift_v: float, shift_a: float,
                 Jm: Any, Pm: Any) -> None:
        set_state(u)
        problem.assemble_jacobian(P)
        P.axpy(shift_a, Ms, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        if Cs is not None:
            P.axpy(shift_v, Cs, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        ctx.scale = shift_a + shift_v * s.mass_damping
        Jm.assemble()

    u0 = problem.state.copy()
    v0 = problem.create_vector()
    if velocity is None:
        v0.set(0.0)
    else:
        velocity.copy(v0)
        problem.zero_constrained(v0)
    ts = PETSc.TS().create(comm=comm)
    ts.setOptionsPrefix(DYNAMICS_PREFIX)
    ts.setType("alpha2")
    opts = PETSc.Options()
    ours = []
    for k, val in (("ts_alpha_radius", s.rho_inf),
                   ("ts_adapt_type", "basic" if s.adaptive else "none")):
        if not opts.hasName(f"{DYNAMICS_PREFIX}{k}"):  # a user's option wins
            opts[f"{DYNAMICS_PREFIX}{k}"] = val
            ours.append(f"{DYNAMICS_PREFIX}{k}")
    ts.setI2Function(residual, problem.create_vector())
    ts.setI2Jacobian(jacobian, J, P)
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
    if lowrank is None:
        ksp.setType("preonly")
    else:
        ksp.setType("gmres")
        ksp.setTolerances(rtol=1e-12, atol=1e-30)
    pc = ksp.getPC()
    pc.setType("lu")
    pc.setFactorSolverType("mumps")
    ts.setFromOptions()
    for k in ours:  # the settings' values for this run only
        opts.delValue(k)
    ts.setSolution2(u0, v0)

    out = DynamicsResult()
    energy = isinstance(problem, Energy)

    def record(t: float, u: Any, v: Any) -> None:
        set_state(u)
        M.mult(v, tmp)
        out.times.append(float(t))
        out.kinetic.append(0.5 * float(v.dot(tmp)))
        out.elastic.append(problem.total_energy() if energy else float("nan"))

    record(0.0, u0, v0)
    if monitor is not None:
        monitor(0.0, problem, out.kinetic[-1])

    def post_step(ts: Any) -> None:
        u, v = ts.getSolution2()
        record(ts.getTime(), u, v)
        out.steps += 1
        if s.rest_tol is not None and out.kinetic[-1] < s.rest_tol and out.steps > 1:
            out.reason = "rest"
            ts.setConvergedReason(PETSc.TS.ConvergedReason.CONVERGED_USER)
        elif monitor is not None and monitor(float(ts.getTime()), problem, out.kinetic[-1]):
            out.reason = "monitor"
            ts.setConvergedReason(PETSc.TS.ConvergedReason.CONVERGED_USER)

    ts.setPostStep(post_step)
    try:
        ts.solve(u0)
    finally:
        if int(ts.getConvergedReason()) < 0:
            out.reason = "diverged"
        u, _ = ts.getSolution2()
        set_state(u)
        for o in (ts, J, P, K0, work, tmp, v0, u0, *(x for x in (Cs, lowrank) if x)):
            o.destroy()
    return out
