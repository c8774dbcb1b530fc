"""PETSc solvers on the problem interface: SNES Newton and a reusable LU for bordered systems
(algorithm layer).

Every solver has a stable, documented options prefix, so a user can address it from the PETSc
options database (``-shells_newton_snes_monitor``, ``PETSC_OPTIONS=...``):

| prefix | solver |
| --- | --- |
| ``shells_newton_`` | Newton (SNES, its KSP and PC) |
| ``shells_newton_lin_`` | the LU of the bordered (arclength, pinned) corrector's solves |
| ``shells_inertia_`` | the LDLᵀ factorisation whose inertia decides stability |
| ``shells_eigen_`` | the SLEPc eigensolver (EPS, its ST and KSP) of the stability blocks |

The package's defaults are passed as dicts, set in the database only for the duration of
``setFromOptions`` and removed afterwards (the global database is left as it was); an option the
user has set under the same prefix takes precedence over the default and is left in place.
Defaults: Newton with a basic line search, MUMPS LU; a problem may recommend another
factorisation (``factor_options``: the 1D model on one process, PETSc's own LU), which falls
back to MUMPS at its first failure (``fall_back_to_mumps``).
"""

from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np

from shells.problem.interface import FactorOptions

__all__ = [
    "DEFAULT_SNES_OPTIONS",
    "NewtonSolver",
    "apply_options",
    "configure_factor",
    "reset_factor",
    "fall_back_to_mumps",
    "setup_factor",
]

log = logging.getLogger("shells")

#: the options prefixes (see the module docstring)
NEWTON_PREFIX = "shells_newton_"
INERTIA_PREFIX = "shells_inertia_"
EIGEN_PREFIX = "shells_eigen_"

DEFAULT_SNES_OPTIONS: dict[str, Any] = {
    "snes_type": "newtonls",
    "snes_linesearch_type": "basic",
    "snes_rtol": 1.0e-9,
    "snes_atol": 1.0e-12,
    "snes_stol": 0.0,
    "snes_max_it": 20,
    "snes_divergence_tolerance": -1,
    "ksp_type": "preonly",
    "pc_type": "lu",
    "pc_factor_mat_solver_type": "mumps",
    "mat_mumps_icntl_14": 200,
}


def apply_options(obj: Any, prefix: str, options: dict[str, Any]) -> dict[str, Any]:
    """Configure a PETSc object from default options without leaving them in the database.

    Sets ``options`` under ``prefix``, calls ``obj.setFromOptions()``, then removes them
    again. An option the user already has in the database under ``prefix`` wins and stays.

    Args:
        obj: a PETSc object with ``setOptionsPrefix`` and ``setFromOptions`` (SNES, KSP, EPS).
        prefix: its options prefix.
        options: the defaults, without the prefix.

    Returns:
        The options in effect (the user's values as strings).
    """
    from petsc4py import PETSc

    opts = PETSc.Options()
    obj.setOptionsPrefix(prefix)
    effective = dict(options)
    mine = []
    for k, v in options.items():
        if opts.hasName(prefix + k):
            effective[k] = opts.getString(prefix + k)
        else:
            opts[prefix + k] = v
            mine.append(k)
    try:
        obj.setFromOptions()
    finally:
        for k in mine:
            opts.delValue(prefix + k)
    return effective


def configure_factor(ksp: Any, A: Any, options: dict[str, Any]) -> None:
    """Give ``ksp`` the operator ``A`` and set the MUMPS controls of ``options`` on its factor.

    MUMPS reads ICNTL/CNTL when the factor matrix is created (at PC set-up), by which time the
    prefixed options are gone from the database, so they are set here through the API.

    Args:
        ksp: the KSP whose PC factors ``A``; nothing is set unless it is a MUMPS LU or
            Cholesky.
        A: the operator.
        options: the options in effect (``mat_mumps_icntl_<i>``, ``mat_mumps_cntl_<i>``).
    """
    ksp.setOperators(A)
    pc = ksp.getPC()
    if pc.getType() not in ("lu", "cholesky") or pc.getFactorSolverType() != "mumps":
        return
    pc.setFactorSetUpSolverType()
    F = pc.getFactorMatrix()
    for k, v in options.items():
        if k.startswith("mat_mumps_icntl_"):
            F.setMumpsIcntl(int(k.rsplit("_", 1)[1]), int(v))
        elif k.startswith("mat_mumps_cntl_"):
            F.setMumpsCntl(int(k.rsplit("_", 1)[1]), float(v))


def reset_factor(ksp: Any, A: Any, options: dict[str, Any]) -> None:
    """Drop ``ksp``'s factorisation so that the next set-up factors afresh.

    Needed after a failed factorisation: MUMPS keeps INFOG(1) < 0 and PETSc then skips the
    numeric phase of every later factorisation of that factor, so one bad matrix (a diverged
    Newton iterate) would make every later solve fail or return Inf.

    Args:
        ksp: the KSP.
        A: its operator.
        options: the options in effect (for ``configure_factor``).
    """
    ksp.getPC().reset()
    configure_factor(ksp, A, options)


def setup_factor(ksp: Any, A: Any, options: dict[str, Any]) -> bool:
    """Factor ``A`` (``ksp.setUp()``), falling back to MUMPS if another package fails.

    A factorisation by a package other than MUMPS that fails (PETSc's own LU does not pivot: a
    zero pivot) is repeated with MUMPS, which ``ksp`` then keeps (``fall_back_to_mumps``).

    Args:
        ksp: the KSP, configured by ``configure_factor``.
        A: its operator.
        options: the options in effect (updated if the solver falls back to MUMPS).

    Returns:
        True if ``A`` is factored; False, with the factor reset, if the factorisation failed.

    Raises:
        petsc4py.PETSc.Error: if MUMPS itself raises.
    """
    from petsc4py import PETSc

    try:
        ksp.setUp()
    except PETSc.Error:
        # PETSc's own LU raises where a pattern lacks a diagonal entry; MUMPS never does
        if ksp.getPC().getFactorSolverType() == "mumps":
            raise
    else:
        if int(ksp.getPC().getFailedReason()) == 0:
            return True
    if fall_back_to_mumps(ksp, A, options):
        ksp.setUp()
        if int(ksp.getPC().getFailedReason()) == 0:
            return True
    reset_factor(ksp, A, options)
    return False


def fall_back_to_mumps(ksp: Any, A: Any, options: dict[str, Any]) -> bool:
    """Switch ``ksp``'s factorisation to MUMPS for good if it is another package's.

    MUMPS pivots; the other packages' factorisations are faster where they apply (the 1D
    model's banded matrices on one process) but stop at a zero pivot.

    Args:
        ksp: the KSP.
        A: its operator.
        options: the options in effect, updated to match.

    Returns:
        True if it switched; False if the factorisation is MUMPS already (or ``ksp`` does
        not factor).
    """
    pc = ksp.getPC()
    if pc.getType() not in ("lu", "cholesky") or pc.getFactorSolverType() == "mumps":
        return False
    log.info("a %s factorisation by '%s' failed (a zero pivot): MUMPS from now on",
             pc.getType(), pc.getFactorSolverType())
    options["pc_factor_mat_solver_type"] = "mumps"
    pc.reset()
    pc.setFactorSolverType("mumps")
    configure_factor(ksp, A, options)
    return True


class NewtonSolver:
    """SNES Newton on a ``shells.problem.interface.Problem``'s residual and Jacobian.

    Also exposes the assembled Jacobian and a KSP on it for bordered (arclength) solves.

    Args:
        problem: the problem; its state is the Newton iterate.
        options: options over the defaults (``DEFAULT_SNES_OPTIONS``, then the problem's
            ``factor_options``).
        prefix: the options prefix (default ``shells_newton_``; see the module docstring).
    """

    def __init__(self, problem: Any, options: dict[str, Any] | None = None,
                 prefix: str | None = None) -> None:
        from petsc4py import PETSc

        self.problem = problem
        self.prefix = prefix or NEWTON_PREFIX
        self.b = problem.create_vector()
        self.A = problem.create_jacobian()
        self.x = problem.state.duplicate()
        self.snes = PETSc.SNES().create(problem.comm)
        self.snes.setFunction(self._F, self.b)
        self.snes.setJacobian(self._J, self.A)
        self.snes.setConvergenceTest(self._converged)
        self._test: dict[str, float | None] = {}
        self.noise_accepted = False
        # the problem's recommended factorisation (``FactorOptions``) between the defaults and
        # the caller's options
        recommended = problem.factor_options if isinstance(problem, FactorOptions) else {}
        self.options = apply_options(self.snes, self.prefix,
                                     {**DEFAULT_SNES_OPTIONS, **recommended, **(options or {})})
        self.ksp = self.snes.getKSP()
        configure_factor(self.ksp, self.A, self.options)
        # a second KSP for bordered solves with its own prefix
        self.lin = PETSc.KSP().create(problem.comm)
        self.lin_opts = apply_options(self.lin, self.prefix + "lin_",
                                      {k: v for k, v in self.options.items()
                                       if k.startswith(("ksp_", "pc_", "mat_"))})
        configure_factor(self.lin, self.A, self.lin_opts)

    # -- callbacks ---------------------------------------------------------------------------
    def _set_state(self, x: Any) -> None:
        x.copy(self.problem.state)
        self.problem.sync()

    def _F(self, snes: Any, x: Any, b: Any) -> None:
        self._set_state(x)
        self.assemble_residual(b)

    def _J(self, snes: Any, x: Any, A: Any, P: Any) -> None:
        self._set_state(x)
        self.assemble_jacobian(A)

    # -- assembly ----------------------------------------------------------------------------
    def assemble_residual(self, b: Any) -> None:
        """The residual at the current state into ``b``."""
        self.problem.assemble_residual(b)

    def assemble_jacobian(self, A: Any) -> None:
        """The Jacobian at the current state into ``A``."""
        self.problem.assemble_jacobian(A)

    def assemble_dkappa(self, v: Any) -> None:
        """dR/dκ at the current state, zero on the constrained DOFs."""
        self.problem.assemble_dkappa(v)

    # -- solves ------------------------------------------------------------------------------
    def solve(self, atol: float | None = None) -> tuple[bool, int]:
        """Newton from the current state at the current κ.

        A residual that round-off keeps above the tolerances is accepted when it is below
        ``NOISE_FACTOR`` times the residual's measured round-off (``residual_noise``) at two
        successive iterates and Newton's step has settled (``NOISE_STEP``). The residual alone
        is not enough: on an ill-conditioned Jacobian Newton contracts only linearly at
        round-off, so its first iterate there can still be far from the solution
        (docs/model.md, "Solvers"). ``self.noise_accepted`` tells whether the last solve
        ended so. A factorisation other than MUMPS that fails is replaced by MUMPS and the
        solve repeated.

        Args:
            atol: an absolute residual tolerance for this solve (the larger of it and the
                solver's own ``snes_atol``); continuation passes its residual bound, relative
                to the κ-load, because a relative decrease from a small start residual (a
                short step) can lie below round-off.

        Returns:
            (converged, iterations). A failed solve leaves the state as it was.
        """
        from petsc4py import PETSc

        self.problem.state.copy(self.x)
        start = self.x.copy()
        rtol, atol0, stol, max_it = self.snes.getTolerances()
        for attempt in range(2):
            self._test = {"atol": max(atol0, atol or 0.0), "rtol": rtol, "stol": stol,
                          "max_it": max_it, "f0": math.inf, "noise": None, "at_noise": False,
                          "ynorm": math.inf}
            self.noise_accepted = False
            try:
                self.snes.solve(None, self.x)
                reason = self.snes.getConvergedReason()
                failed = int(self.ksp.getPC().getFailedReason()) != 0
            except PETSc.Error:
                # PETSc's own LU raises on a pattern without a diagonal entry
                if attempt > 0 or self.ksp.getPC().getFactorSolverType() == "mumps":
                    raise
                reason, failed = -1, True
            if not (attempt == 0 and reason <= 0 and failed
                    and fall_back_to_mumps(self.ksp, self.A, self.options)):
                break
            start.copy(self.x)  # again, from the start, with a pivoting factorisation
            self._set_state(self.x)
        its = self.snes.getIterationNumber()
        if reason <= 0 and int(self.ksp.getPC().getFailedReason()) != 0:
            reset_factor(self.ksp, self.A, self.options)  # or every later solve fails too
        self._set_state(self.x if reason > 0 else start)
        start.destroy()
        return reason > 0, its

    #: a residual below this multiple of its measured round-off is at round-off
    #: (``residual_noise`` samples two inputs only; Newton stalls a little above it:
    #: docs/design-notes.md, "Newton at round-off")
    NOISE_FACTOR = 4.0
    #: and the state is converged at round-off when Newton's step is below this fraction of
    #: it, or no longer shrinks (halves)
    NOISE_STEP = 1.0e-6

    def _converged(self, snes: Any, its: int, norms: tuple[float, float, float]) -> int:
        """SNES's convergence test: PETSc's default (atol, rtol, stol, max_it) and the
        round-off acceptance of ``solve``. The round-off is measured only when the residual is
        below the a-priori bound ``roundoff_floor()``; that bound can exceed the actual
        round-off by orders of magnitude, so it never accepts a residual itself
        (docs/model.md, "Solvers")."""
        from petsc4py import PETSc

        R = PETSc.SNES.ConvergedReason
        xnorm, ynorm, fnorm = norms
        t = self._test
        if not math.isfinite(fnorm):
            return R.DIVERGED_FNORM_NAN
        if its == 0:
            t["f0"] = fnorm
        if fnorm <= t["atol"]:
            return R.CONVERGED_FNORM_ABS
        if its > 0 and fnorm <= t["rtol"] * t["f0"]:
            return R.CONVERGED_FNORM_RELATIVE
        if its > 0 and t["stol"] > 0 and ynorm <= t["stol"] * xnorm:
            return R.CONVERGED_SNORM_RELATIVE
        at_noise = False
        if fnorm <= self.roundoff_floor():
            if t["noise"] is None:
                t["noise"] = self.residual_noise()
            at_noise = fnorm <= self.NOISE_FACTOR * t["noise"]
        settled = ynorm <= self.NOISE_STEP * xnorm or ynorm >= 0.5 * t["ynorm"]
        if at_noise and t["at_noise"] and settled:
            self.noise_accepted = True
            return R.CONVERGED_FNORM_ABS
        t["at_noise"], t["ynorm"] = at_noise, ynorm
        if its >= t["max_it"]:
            return R.DIVERGED_MAX_IT
        return R.ITERATING

    def residual_noise(self) -> float:
        """Measure the round-off of the assembled residual at the current state.

        ||R(w') - R(w) - J (w' - w)|| with w' = w (1 ± ε) (random signs, exact differences;
        J: the last assembled Jacobian, whose change over the last Newton step is negligible
        against ε). The linear term removed, what remains is the assembly's rounding, sampled
        at two inputs: the level at which Newton's residual stalls.

        Returns:
            The norm above; the state is restored.
        """
        if not self.A.isAssembled():
            self.assemble_jacobian(self.A)
        w = self.problem.state
        w0, d = w.duplicate(), w.duplicate()
        r0, r1 = self.b.duplicate(), self.b.duplicate()
        try:
            w.copy(w0)
            self.assemble_residual(r0)
            rng = np.random.default_rng(12345 + self.problem.comm.rank)
            signs = rng.choice((-1.0, 1.0), size=w.getLocalSize())
            eps = float(np.finfo(float).eps)
            w.array_w[:] = w0.array_r * (1.0 + eps * signs)
            self.problem.sync()
            self.assemble_residual(r1)
            w.copy(d)
            d.axpy(-1.0, w0)
            r1.axpy(-1.0, r0)
            self.A.mult(d, r0)
            r1.axpy(-1.0, r0)
            return float(r1.norm())
        finally:
            w0.copy(w)
            self.problem.sync()
            for v in (w0, d, r0, r1):
                v.destroy()

    def roundoff_floor(self, factor: float = 0.1) -> float:
        """An a-priori upper bound of the residual's round-off at the current state.

        Args:
            factor: the multiple of ε ||J||_F ||w|| (J: the last assembled Jacobian,
                assembled here if there is none yet).

        Returns:
            ``factor`` ε ||J||_F ||w||.
        """
        if not self.A.isAssembled():
            self.assemble_jacobian(self.A)
        w = self.problem.state
        return factor * float(np.finfo(float).eps) * float(self.A.norm()) * float(w.norm())

    def residual_norm(self) -> float:
        """||R|| at the current state (assembled into the solver's residual vector)."""
        self.assemble_residual(self.b)
        return float(self.b.norm())

    def factor(self, attempts: int = 1) -> bool:
        """Assemble and factor the Jacobian at the current state for ``lin_solve``.

        Args:
            attempts: how many times to try (a failed factor is reset, so a later attempt
                factors afresh).

        Returns:
            False if every attempt failed (``lin_solve`` then returns Inf).
        """
        for _ in range(attempts):
            self.assemble_jacobian(self.A)
            self.lin.setOperators(self.A)  # same matrix object: the configured factor is kept
            if setup_factor(self.lin, self.A, self.lin_opts):
                return True
        return False

    def lin_solve(self, rhs: Any, out: Any) -> None:
        """Solve J out = rhs with the factorisation of the last ``factor``."""
        self.lin.solve(rhs, out)

    def destroy(self) -> None:
        """Free the solvers, the Jacobian and the work vectors."""
        for o in (self.snes, self.lin, self.A, self.b, self.x):
            o.destroy()
