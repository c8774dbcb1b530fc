"""PETSc solvers for the shell model: SNES Newton and a reusable LU for bordered systems.

Options are passed as a dict under a unique prefix per solver instance (``shells_snes_<n>_``),
set only for the duration of ``setFromOptions`` and removed afterwards, so the global PETSc
options database is left as it was. Defaults: Newton with a basic line search, MUMPS LU.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np

__all__ = [
    "DEFAULT_SNES_OPTIONS",
    "NewtonSolver",
    "apply_options",
    "configure_factor",
    "reset_factor",
    "setup_factor",
]

_counter = itertools.count()

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


def apply_options(obj: Any, prefix: str, options: dict[str, Any]) -> None:
    """Set ``options`` under ``prefix``, call ``obj.setFromOptions()``, then remove them again."""
    from petsc4py import PETSc

    opts = PETSc.Options()
    obj.setOptionsPrefix(prefix)
    for k, v in options.items():
        opts[prefix + k] = v
    try:
        obj.setFromOptions()
    finally:
        for k in options:
            opts.delValue(prefix + k)


def configure_factor(ksp: Any, A: Any, options: dict[str, Any]) -> None:
    """Give ``ksp`` the operator ``A`` and set the MUMPS controls of ``options`` on its factor.

    MUMPS reads ICNTL/CNTL when the factor matrix is created (at PC set-up), by which time the
    prefixed options are gone from the database, so they are set here through the API.
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
    """
    ksp.getPC().reset()
    configure_factor(ksp, A, options)


def setup_factor(ksp: Any, A: Any, options: dict[str, Any]) -> bool:
    """Factor ``A`` (``ksp.setUp()``); False, and the factor reset, if the factorisation failed."""
    ksp.setUp()
    if int(ksp.getPC().getFailedReason()) == 0:
        return True
    reset_factor(ksp, A, options)
    return False


class NewtonSolver:
    """SNES Newton on the model's residual/Hessian with homogeneous point supports.

    Also exposes the assembled Jacobian and a KSP on it for bordered (arclength) solves.
    """

    def __init__(self, model: Any, options: dict[str, Any] | None = None,
                 prefix: str | None = None) -> None:
        from dolfinx.fem.petsc import create_matrix, create_vector
        from petsc4py import PETSc

        self.model = model
        self.options = {**DEFAULT_SNES_OPTIONS, **(options or {})}
        self.prefix = prefix or f"shells_snes_{next(_counter)}_"
        comm = model.shell.comm
        self.b = create_vector(model.residual)
        self.A = create_matrix(model.hessian)
        self.x = model.w.x.petsc_vec.duplicate()
        self.snes = PETSc.SNES().create(comm)
        self.snes.setFunction(self._F, self.b)
        self.snes.setJacobian(self._J, self.A)
        apply_options(self.snes, self.prefix, self.options)
        self.ksp = self.snes.getKSP()
        configure_factor(self.ksp, self.A, self.options)
        # a second KSP for bordered solves with its own prefix
        self.lin = PETSc.KSP().create(comm)
        self.lin_opts = {k: v for k, v in self.options.items()
                         if k.startswith(("ksp_", "pc_", "mat_"))}
        apply_options(self.lin, self.prefix + "lin_", self.lin_opts)
        configure_factor(self.lin, self.A, self.lin_opts)

    # -- callbacks ---------------------------------------------------------------------------
    def _set_state(self, x: Any) -> None:
        from petsc4py import PETSc

        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        x.copy(self.model.w.x.petsc_vec)
        self.model.w.x.scatter_forward()

    def _F(self, snes: Any, x: Any, b: Any) -> None:
        self._set_state(x)
        self.assemble_residual(b)

    def _J(self, snes: Any, x: Any, A: Any, P: Any) -> None:
        self._set_state(x)
        self.assemble_jacobian(A)

    # -- assembly ----------------------------------------------------------------------------
    def assemble_residual(self, b: Any) -> None:
        from dolfinx.fem.petsc import apply_lifting, assemble_vector, set_bc
        from petsc4py import PETSc

        m = self.model
        with b.localForm() as bl:
            bl.set(0.0)
        assemble_vector(b, m.residual)
        apply_lifting(b, [m.hessian], bcs=[m.bcs], x0=[m.w.x.petsc_vec], alpha=-1.0)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        set_bc(b, m.bcs, m.w.x.petsc_vec, -1.0)

    def assemble_jacobian(self, A: Any) -> None:
        from dolfinx.fem.petsc import assemble_matrix

        A.zeroEntries()
        assemble_matrix(A, self.model.hessian, bcs=self.model.bcs)
        A.assemble()

    def assemble_dkappa(self, v: Any) -> None:
        """dR/dκ at the current state, zero on the supports."""
        from dolfinx.fem.petsc import assemble_vector, set_bc
        from petsc4py import PETSc

        with v.localForm() as vl:
            vl.set(0.0)
        assemble_vector(v, self.model.dres_dkappa)
        v.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        set_bc(v, self.model.bcs, alpha=0.0)

    # -- solves ------------------------------------------------------------------------------
    def solve(self, atol: float | None = None) -> tuple[bool, int]:
        """Newton from the current state at the current κ. Returns (converged, iterations).

        ``atol``: an absolute residual tolerance for this solve (the larger of it, the solver's
        own ``snes_atol`` and the round-off floor ``roundoff_floor()``); continuation passes its
        residual bound, relative to the κ-load, because a relative decrease of 1e-9 from a
        small start residual (a short step) lies below round-off.
        """
        self.model.w.x.petsc_vec.copy(self.x)
        rtol, atol0, stol, max_it = self.snes.getTolerances()
        # never below the round-off floor of the residual (else Newton stalls there until
        # max_it: measured at 1e-12 on a 39k-DOF cap, where snes_atol is 1e-12)
        self.snes.setTolerances(atol=max(atol0, atol or 0.0, self.roundoff_floor()))
        try:
            self.snes.solve(None, self.x)
        finally:
            self.snes.setTolerances(atol=atol0)
        reason = self.snes.getConvergedReason()
        its = self.snes.getIterationNumber()
        if reason <= 0 and int(self.ksp.getPC().getFailedReason()) != 0:
            reset_factor(self.ksp, self.A, self.options)  # or every later solve fails too
        self._set_state(self.x)
        return reason > 0, its

    def roundoff_floor(self, factor: float = 0.1) -> float:
        """``factor`` ε ||J||_F ||w||: the residual's round-off floor at the current state (J:
        the last assembled Jacobian; assembled here if there is none yet)."""
        if not self.A.isAssembled():
            self.assemble_jacobian(self.A)
        w = self.model.w.x.petsc_vec
        return factor * float(np.finfo(float).eps) * float(self.A.norm()) * float(w.norm())

    def residual_norm(self) -> float:
        self.assemble_residual(self.b)
        return float(self.b.norm())

    def factor(self) -> bool:
        """Assemble and factor the Jacobian at the current state for ``lin_solve``; False if
        the factorisation failed (``lin_solve`` then returns Inf, and the next call factors
        afresh)."""
        self.assemble_jacobian(self.A)
        self.lin.setOperators(self.A)  # same matrix object: the configured factor is kept
        return setup_factor(self.lin, self.A, self.lin_opts)

    def lin_solve(self, rhs: Any, out: Any) -> None:
        self.lin.solve(rhs, out)

    def destroy(self) -> None:
        for o in (self.snes, self.lin, self.A, self.b, self.x):
            o.destroy()
