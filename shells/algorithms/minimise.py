"""Energy minimisation at fixed κ with PETSc TAO (algorithm layer).

Where a branch ends at a fold, or an equilibrium has negative eigenvalues, the shell leaves it:
the state it lands in is a local minimum of the energy at the same κ, which continuation from
κ = 0 may never reach (the axisymmetric path of a deep cap winds through many folds before it
comes back to a stable state, and a snap that breaks the symmetry leaves that path at once).
``minimise`` finds it by a second-order method that uses negative curvature: Newton on the
problem's energy, its gradient the residual and its Hessian the Jacobian (the same UFL energy,
``ufl.derivative``), globalised by TAO.

Both TAO methods solve with the shifted Hessian H + σ M (``ShiftedFactor``, M the mass; a MUMPS
LDLᵀ whose inertia picks the least σ that makes it positive definite): a shell's Hessian is too
ill-conditioned (membrane against bending stiffness, (R/h)²) for Krylov methods without a
strong preconditioner, and an indefinite one gives Newton directions that lead back to saddles.

* ``"nls"`` (TAONLS, the default): the shifted Newton step, always a descent direction, with a
  Moré-Thuente line search; on a definite Hessian (σ = 0) Newton's own step and quadratic
  convergence.
* ``"ntr"`` (TAONTR): trust-region Newton, the step from the Steihaug-Toint CG (STCG) on H
  preconditioned by the shifted factor, which meets negative curvature at the trust region's
  boundary.

A state with a symmetry orbit (a pattern that breaks the symmetry of a shell of revolution) lies
in a valley that the mesh pins only weakly: the energy varies along the orbit by a
discretisation error, and TAO's steps creep along it. There the hand-over is to Newton modulo
the orbit (``shells.algorithms.orbit``), which holds the orientation and converges
quadratically in every other direction: the end is ``CONVERGED_MODULO_ORBIT``, its gradient
the mesh's pinning force along the orbit (``MinimiseResult.orbit_gradient``).

A start on an exactly symmetric saddle stays on it (Newton's iterates keep the symmetry), so the
caller perturbs the start along the unstable eigenvectors first (``perturb_unstable``); and
``minimise_to_stable`` checks each minimiser's end by the Hessian's inertia and leaves a saddle
along its unstable eigenvectors, until the end is stable.

Options prefixes ``shells_minimise_`` (TAO and its KSP; ``-shells_minimise_tao_monitor``) and
``shells_minimise_shift_`` (the shifted factorisation).
The gauge's constrained DOFs keep their values: their gradient rows are zero and their Hessian
rows unit rows, so every step is zero there.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from shells.algorithms.newton import apply_options
from shells.algorithms.orbit import OrbitNewtonResult
from shells.algorithms.settings import MinimiseSettings
from shells.errors import InputError
from shells.problem.interface import Energy

__all__ = ["MINIMISE_PREFIX", "MinimiseResult", "minimise", "minimise_to_stable",
           "perturb_unstable", "perturbed"]

log = logging.getLogger("shells")

#: the options prefix of the minimiser (TAO, its KSP and PC)
MINIMISE_PREFIX = "shells_minimise_"

_METHOD_OPTIONS: dict[str, dict[str, Any]] = {
    "nls": {"ksp_type": "preonly"},
    "ntr": {"ksp_type": "stcg"},
}
#: hand-overs to Newton tried at most (``MinimiseSettings.newton_below``), and the TAO
#: iterations between a failed one and the next
MAX_NEWTON_ATTEMPTS = 3
NEWTON_RETRY_AFTER = 10
#: the iterations over which the energy's change is compared with ``MinimiseSettings.ftol``
FLAT_WINDOW = 10
#: a state with an orbit is handed over to Newton modulo the orbit where the Hessian is
#: definite up to a shift of this many ``MinimiseSettings.sigma0``: the mesh's pinning may
#: turn the orbit's own curvature (a few sigma0) negative, which that Newton does not see
ORBIT_SHIFT_MAX = 64.0
#: the steps of one hand-over to Newton modulo the orbit: it converges in a few where it will
#: at all; near a bifurcation (a pattern barely broken) its steps oscillate instead, and TAO
#: goes on sooner
ORBIT_NEWTON_MAX_IT = 12
#: the LDLᵀ that decides the shift's definiteness (its own prefix: ``shells_minimise_shift_``)
SHIFT_PREFIX = MINIMISE_PREFIX + "shift_"
SHIFT_OPTIONS: dict[str, Any] = {
    "ksp_type": "preonly", "pc_type": "cholesky", "pc_factor_mat_solver_type": "mumps",
    "mat_mumps_icntl_13": 1, "mat_mumps_icntl_24": 1, "mat_mumps_icntl_14": 200,
}


class ShiftedFactor:
    """A preconditioner (petsc4py's python PC): (H + σ M)⁻¹, M the problem's mass (the
    metric of its eigenproblems), with the least σ of 0, σ₀, 4 σ₀, 16 σ₀, ... for which the
    shifted Hessian is positive definite (MUMPS' LDLᵀ and its inertia decide).

    A positive definite preconditioner is what the trust-region CG (STCG) needs, and with it
    a Newton step (``"nls"``) is always a descent direction: on an indefinite Hessian the
    shift turns the step towards the negative curvature, on a definite one it is Newton's.
    σ starts at a quarter of the previous iteration's σ, so that it follows the Hessian's
    lowest eigenvalue (of H v = μ M v) as the iterates leave the saddle and reach the
    minimum. The mass, not the Hessian's diagonal, measures the shift: a shell's diagonal is
    its membrane stiffness, (R/h)² above the bending eigenvalues that go negative, and a shift
    on that scale would stall the bending modes.

    Args:
        M: the mass matrix (the Hessian's layout or a subset of it).
        sigma0: the first nonzero shift, in the eigenvalues' units.

    Attributes:
        sigma: the last shift (relative to |diag H|).
        factorisations: how many LDLᵀ were computed.
    """

    def __init__(self, M: Any, sigma0: float) -> None:
        self.M = M
        self.sigma0 = sigma0
        self.sigma = 0.0
        self.factorisations = 0
        self._ksp: Any = None
        self._B: Any = None
        self._options: dict[str, Any] = {}

    def setUp(self, pc: Any) -> None:  # noqa: N802 - petsc4py's name
        """Factor the least definite shift of the PC's operator."""
        from petsc4py import PETSc

        from shells.algorithms.newton import configure_factor, setup_factor

        A = pc.getOperators()[0]
        if self._B is None:
            self._B = A.duplicate(copy=True)
            self._ksp = PETSc.KSP().create(A.getComm())
            self._options = apply_options(self._ksp, SHIFT_PREFIX, SHIFT_OPTIONS)
            configure_factor(self._ksp, self._B, self._options)
        sigma = self.sigma / 4 if self.sigma > self.sigma0 else 0.0
        while True:
            A.copy(self._B, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
            if sigma > 0:
                self._B.axpy(sigma, self.M, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
            self._ksp.setOperators(self._B)
            self.factorisations += 1
            ok = setup_factor(self._ksp, self._B, self._options)
            if ok and self._ksp.getPC().getFactorMatrix().getInertia()[0] == 0:
                break
            if sigma > 1.0e12 * self.sigma0:
                raise RuntimeError("the shifted Hessian stays indefinite up to a shift of "
                                   f"{sigma:.3g} times the mass")
            sigma = max(4 * sigma, self.sigma0)
        self.sigma = sigma
        log.debug("minimise: shift sigma = %.3g (%d factorisations so far)", sigma,
                  self.factorisations)

    def apply(self, pc: Any, x: Any, y: Any) -> None:
        """y = (H + σ |diag H|)⁻¹ x."""
        self._ksp.solve(x, y)

    def destroy(self, pc: Any = None) -> None:
        """Free the factorisation."""
        for obj in (self._ksp, self._B):
            if obj is not None:
                obj.destroy()
        self._ksp = self._B = None


@dataclass(frozen=True)
class MinimiseResult:
    """What a minimisation ended with (the state is left in the problem).

    Attributes:
        converged: TAO met its gradient tolerance.
        reason: TAO's converged reason (its name).
        iterations: TAO iterations (the steps of a Newton hand-over not counted).
        energy: E at the final state.
        energy_start: E at the start (after any perturbation).
        gradient_norm: the gradient's (residual's) norm at the final state.
        wall_time: seconds.
        rounds: minimisations run (``minimise_to_stable``: one more per saddle left).
        negative_count: the Hessian's negative eigenvalues at the end (None: not computed).
        orbit_modes: how many of those lie along the state's symmetry orbit (neutral).
        orbit_gradient: where the end was converged modulo the state's orbit
            (``CONVERGED_MODULO_ORBIT``): the gradient's norm along the orbit, the mesh's
            pinning force (``shells.algorithms.orbit``); else None.
    """

    converged: bool
    reason: str
    iterations: int
    energy: float
    energy_start: float
    gradient_norm: float
    wall_time: float
    rounds: int = 1
    negative_count: int | None = None
    orbit_modes: int | None = None
    orbit_gradient: float | None = None

    def as_dict(self) -> dict[str, Any]:
        """The record as a plain dict (for JSON)."""
        return dict(self.__dict__)


def perturbed(problem: Any, directions: list[np.ndarray], amplitude: float) -> None:
    """Add ``amplitude`` times the state scale along each direction, normalised, to the state.

    The directions are this rank's owned values of state-shaped vectors (unstable eigenvectors);
    each is scaled to unit RMS over the unknowns, so ``amplitude`` is the RMS displacement
    in units of ``problem.state_scale()`` (the thickness).

    Args:
        problem: the problem (its state is changed in place and synced).
        directions: the directions (owned values; constrained DOFs are zeroed).
        amplitude: the perturbation's RMS size over the thickness.
    """
    v = problem.state
    work = v.duplicate()
    n = max(problem.num_dofs(), 1)
    for d in directions:
        work.array_w[:] = d[: work.getLocalSize()]
        problem.zero_constrained(work)
        norm = work.norm()
        if norm > 0:
            v.axpy(amplitude * problem.state_scale() * math.sqrt(n) / norm, work)
    work.destroy()
    problem.sync()


class _TaoRun:
    """One ``minimise``: TAO on the problem's energy with the shifted factor as its PC, the
    convergence test with its hand-over to Newton, and the solve loop."""

    def __init__(self, problem: Any, st: MinimiseSettings,
                 monitor: Callable[[Any], None] | None) -> None:
        from petsc4py import PETSc

        self.problem, self.st = problem, st
        self.R = PETSc.TAO.ConvergedReason
        self.x = problem.create_vector()
        self.x.array_w[:] = problem.state.array_r[: self.x.getLocalSize()]
        self.g = problem.create_vector()
        self.H = problem.create_jacobian()
        self.M = problem.assemble_mass(None)
        self.shifted = ShiftedFactor(self.M, st.sigma0)
        #: Newton hand-overs left, and the iteration of a solve before which none is tried
        self.left = MAX_NEWTON_ATTEMPTS if st.newton_below > 0 else 0
        self.after = 0
        self.energies: list[float] = []
        self.done = 0  # TAO iterations of earlier solves (a solve after a failed hand-over)
        self.orbit: OrbitNewtonResult | None = None  # a converged Newton modulo the orbit
        self.tao = self._make_tao(monitor)

    def load(self, xv: Any) -> None:
        """The iterate ``xv`` into the problem's state."""
        self.problem.state.array_w[: xv.getLocalSize()] = xv.array_r
        self.problem.sync()

    def _objective_gradient(self, tao: Any, xv: Any, gv: Any) -> float:
        self.load(xv)
        self.problem.assemble_residual(gv)
        return self.problem.total_energy()

    def _hessian(self, tao: Any, xv: Any, A: Any, P: Any) -> None:
        self.load(xv)
        self.problem.assemble_jacobian(A)

    def _make_tao(self, monitor: Callable[[Any], None] | None) -> Any:
        """The TAO solver, its KSP and the shifted factor as the KSP's PC."""
        from petsc4py import PETSc

        st = self.st
        tao = PETSc.TAO().create(self.problem.comm)
        tao.setType(st.method)
        tao.setObjectiveGradient(self._objective_gradient, self.g)
        tao.setHessian(self._hessian, self.H)
        tao.setSolution(self.x)
        tao.setTolerances(gatol=st.gatol, grtol=st.grtol, gttol=0.0)
        tao.setMaximumIterations(st.max_it)
        tao.setConvergenceTest(self.converged)
        if monitor is not None:
            tao.setMonitor(monitor)
        tao.setOptionsPrefix(MINIMISE_PREFIX)
        options = {**_METHOD_OPTIONS[st.method], **dict(st.options)}
        apply_options(tao, MINIMISE_PREFIX, options)
        ksp = tao.getKSP()
        ksp.setOptionsPrefix(MINIMISE_PREFIX)
        apply_options(ksp, MINIMISE_PREFIX, options)
        pc = ksp.getPC()
        pc.setType("python")
        pc.setPythonContext(self.shifted)
        return tao

    def converged(self, tao: Any) -> None:
        """TAO's convergence test: its own tolerances, the hand-over to Newton (a small
        gradient where the Hessian is definite up to the least shift lies in the basin of a
        minimum, where Newton converges quadratically and the shifted steps would creep; on a
        state with an orbit, definite up to ``ORBIT_SHIFT_MAX`` shifts), and the energy settled
        where Newton failed (a neutral valley)."""
        st, R = self.st, self.R
        its, f, gnorm, *_ = tao.getSolutionStatus()
        self.energies.append(f)
        sigma = self.shifted.sigma
        definite = gnorm <= st.newton_below and (
            sigma <= st.sigma0 or (sigma <= ORBIT_SHIFT_MAX * st.sigma0 and self._has_orbit()))
        settled = (len(self.energies) > FLAT_WINDOW and gnorm <= st.newton_below and definite
                   and self.energies[-FLAT_WINDOW - 1] - f <= st.ftol * abs(f))
        if not math.isfinite(f) or not math.isfinite(gnorm):
            reason = R.DIVERGED_NAN
        elif gnorm <= max(st.gatol, st.grtol * abs(f)):
            reason = R.CONVERGED_GATOL
        elif settled and self.left < MAX_NEWTON_ATTEMPTS:
            reason = R.CONVERGED_STEPTOL
        elif self.left > 0 and its > self.after and gnorm <= st.newton_below and definite:
            reason = R.CONVERGED_USER
        elif its >= st.max_it:
            reason = R.DIVERGED_MAXITS
        else:
            reason = R.CONTINUE_ITERATING
        tao.setConvergedReason(reason)

    def _has_orbit(self) -> bool:
        """Whether TAO's iterate has a symmetry orbit (``shells.algorithms.orbit``)."""
        from shells.algorithms.orbit import has_orbit

        self.load(self.tao.getSolution())
        return has_orbit(self.problem)

    def _newton(self) -> tuple[bool, int]:
        """Newton from the state: modulo its orbit where it has one (plain Newton does not
        converge along a nearly neutral orbit), else SNES."""
        from shells.algorithms.newton import NewtonSolver
        from shells.algorithms.orbit import has_orbit, newton_modulo_orbit

        if has_orbit(self.problem):
            res = newton_modulo_orbit(self.problem, atol=self.st.gatol,
                                      max_it=ORBIT_NEWTON_MAX_IT)
            if res.converged:
                self.orbit = res
            return res.converged, res.iterations
        return NewtonSolver(self.problem).solve(atol=self.st.gatol)

    def solve(self) -> int:
        """TAO, and Newton where TAO hands over; returns the converged reason."""
        while True:
            self.tao.solve()
            self.load(self.x)
            reason = self.tao.getConvergedReason()
            if reason != self.R.CONVERGED_USER:
                return reason
            ok, its = self._newton()
            log.debug("minimise: Newton%s from TAO's iterate %d: %s in %d iterations",
                      " modulo the orbit" if self.orbit is not None else "",
                      self.done + self.tao.getIterationNumber(),
                      "converged" if ok else "failed", its)
            if ok:
                self.x.array_w[:] = self.problem.state.array_r[: self.x.getLocalSize()]
                return self.R.CONVERGED_GATOL
            self.done += self.tao.getIterationNumber()
            # on with TAO from its iterate (a failed Newton solve leaves the state as it was)
            self.left -= 1
            self.after = NEWTON_RETRY_AFTER
            self.tao.setMaximumIterations(max(self.st.max_it - self.done, 1))

    def reason_name(self, reason: int) -> str:
        """TAO's name of a converged reason (the settled energy's own)."""
        if reason == self.R.CONVERGED_STEPTOL:
            return "CONVERGED_ENERGY_SETTLED"
        if reason == self.R.CONVERGED_GATOL and self.orbit is not None:
            return "CONVERGED_MODULO_ORBIT"
        names = {v: k for k, v in vars(self.R).items() if isinstance(v, int)}
        return names.get(reason, str(reason))

    def destroy(self) -> None:
        """Free the solver, its factor, vectors and matrices."""
        self.shifted.destroy()
        for obj in (self.tao, self.x, self.g, self.H, self.M):
            obj.destroy()


def minimise(problem: Any, settings: MinimiseSettings | None = None, *,
             monitor: Callable[[Any], None] | None = None) -> MinimiseResult:
    """Minimise the problem's energy at its current κ, from its current state, with TAO.

    Args:
        problem: a ``shells.problem.interface.Problem`` that is also an ``Energy``; its state
            is the start and is left at the final iterate.
        settings: the method and tolerances (None: ``MinimiseSettings()``).
        monitor: called with the TAO object after every iteration (``tao.getSolution()`` is
            the iterate, ``tao.getSolutionStatus()`` its iteration, energy and gradient
            norm): progress, checkpoints.

    Returns:
        The ``MinimiseResult``; ``converged`` False when TAO stopped otherwise (the caller
        decides: the state is then the last iterate, not an equilibrium).

    Raises:
        InputError: for a problem without ``total_energy``.
    """
    if not isinstance(problem, Energy):
        raise InputError("this problem has no energy to minimise (no total_energy())")
    run = _TaoRun(problem, settings or MinimiseSettings(), monitor)
    e0 = problem.total_energy()
    t0 = time.perf_counter()
    reason = run.solve()
    problem.assemble_residual(run.g)
    out = MinimiseResult(converged=reason > 0, reason=run.reason_name(reason),
                         iterations=run.done + int(run.tao.getIterationNumber()),
                         energy=problem.total_energy(), energy_start=e0,
                         gradient_norm=float(run.g.norm()), wall_time=time.perf_counter() - t0,
                         orbit_gradient=(run.orbit.orbit_gradient if run.orbit is not None
                                         and reason == run.R.CONVERGED_GATOL else None))
    run.destroy()
    log.debug("minimise: %s after %d iterations, E %.10g -> %.10g, |g| %.3g", out.reason,
              out.iterations, e0, out.energy, out.gradient_norm)
    return out


def perturb_unstable(problem: Any, amplitude: float, nev: int = 2) -> list[dict[str, Any]]:
    """Perturb the state along every negative eigenvector of the Hessian (block ``None``).

    Args:
        problem: the problem, its state and κ the point (the state is changed and synced).
        amplitude: RMS size of each direction's perturbation over the state scale
            (``perturbed``).
        nev: eigenpairs computed beyond the negative count.

    Returns:
        One {"eigenvalue", "mode_m", "mode_n"} per direction used (the negative ones).
    """
    from shells.algorithms.stability import Stability

    stab = Stability(problem)
    neg = stab.inertia()[0]
    unstable: list[tuple[float, Any]] = []
    if neg:
        vals, vecs = stab.eigenpairs(max(neg + nev, 4), modes=True)
        unstable = [(mu, v) for mu, v in zip(vals, vecs, strict=False) if mu < 0]
    info = []
    for mu, v in unstable:
        mode = problem.classify_mode(v, None)
        info.append({"eigenvalue": float(mu), "mode_m": mode.m, "mode_n": mode.n})
    perturbed(problem, [v.array_r.copy() for _, v in unstable], amplitude)
    stab.destroy()
    return info


def minimise_to_stable(problem: Any, settings: MinimiseSettings | None = None, *,
                       amplitude: float = 0.1, rounds: int = 6,
                       monitor: Callable[[Any], None] | None = None) -> MinimiseResult:
    """``minimise``, then confirm the end by the Hessian's inertia; from a saddle, perturb
    along its unstable eigenvectors (``perturb_unstable``) and minimise again, each round
    twice as far as the last: a nearly neutral unstable direction (an m = 1 direction of a
    snapped cap's m = 2 saddle) gives its saddle a basin of Newton's iteration wider than a
    small step, and the minimiser, which hands over to Newton once its shifted Hessian is
    nearly definite, comes back to the saddle it left.

    The negative eigenvalues along the state's symmetry orbit (a pattern's rotation about the
    axis: neutral in the continuum, of either sign on a mesh) do not count
    (``Stability.negative_count_modulo_orbit``).

    Args:
        problem: the problem (an ``Energy``), its state the start (perturbed by the caller
            where the start is a symmetric saddle).
        settings: as for ``minimise``.
        amplitude: the first perturbation off a saddle, RMS over the state scale (doubled
            each further round).
        rounds: at most this many minimisations.
        monitor: as for ``minimise``.

    Returns:
        The last ``MinimiseResult``, with ``rounds``, ``negative_count`` and ``orbit_modes``;
        the end is stable when ``converged`` and ``negative_count == orbit_modes``. The
        problem holds that end (after the last round a saddle is not left).
    """
    from dataclasses import replace

    from shells.algorithms.stability import Stability

    e0 = None
    res = None
    for r in range(1, rounds + 1):
        res = minimise(problem, settings, monitor=monitor)
        e0 = res.energy_start if e0 is None else e0
        if not res.converged:
            break
        stab = Stability(problem)
        neg, orbit = stab.negative_count_modulo_orbit()
        stab.destroy()
        res = replace(res, rounds=r, energy_start=e0, negative_count=int(neg),
                      orbit_modes=int(orbit))
        if neg == orbit or r == rounds:  # the last round's end stays: what ``res`` describes
            break
        left = perturb_unstable(problem, amplitude * 2.0 ** (r - 1))
        log.info("minimise: a saddle with %d negative eigenvalue(s) (m = %s), left along them",
                 neg - orbit, [d["mode_m"] for d in left])
    assert res is not None
    return res
