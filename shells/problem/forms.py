"""The assembly half of the ``Problem`` interface from compiled dolfinx forms (problem layer).

``FormProblem`` is a mixin for the two finite-element models. A model that mixes it in provides
the attributes

* ``w`` (the state ``fem.Function``), ``kappa`` (a ``fem.Constant``), ``h`` (a ``fem.Constant``),
  ``shape`` (its ``characteristic_size()`` is L), ``shell.comm``;
* ``residual``, ``hessian``, ``dres_dkappa``: compiled forms of R, ∂R/∂w and ∂R/∂κ, all
  ``ufl.derivative``s of the one energy;
* ``bcs``: the gauge as homogeneous Dirichlet conditions;

and gets the state, parameter and assembly methods of ``shells.problem.interface.Problem``. The
stability blocks, scalars and mode classification stay with each model.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from shells.problem.formcache import compiled_derived, file_tag

__all__ = ["FormProblem", "dkappa_ufl", "assemble_symmetric"]

#: names ``_derive_forms``' derivation of dR/dκ (this file) in the form cache
_DERIVATION = file_tag(__file__)


def dkappa_ufl(residual: Any, kappa: Any) -> Any:
    """dR/dκ of a residual affine in the Constant κ: R(κ=1) - R(κ=0).

    ``ufl.replace`` expands R's derivatives, which takes time: the models derive this form
    through the form cache (``shells.problem.formcache``).

    Args:
        residual: the UFL residual form.
        kappa: the ``fem.Constant`` κ it is affine in.

    Returns:
        The UFL form of dR/dκ.
    """
    import ufl

    return (ufl.replace(residual, {kappa: ufl.as_ufl(1.0)})
            - ufl.replace(residual, {kappa: ufl.as_ufl(0.0)}))


class FormProblem:
    """Residual, Jacobian, dR/dκ and the gauge of a dolfinx model (see the module docstring)."""

    w: Any
    kappa: Any
    h: Any
    shape: Any
    shell: Any
    residual: Any
    hessian: Any
    dres_dkappa: Any
    bcs: list[Any]

    W: Any

    @property
    def comm(self) -> Any:
        return self.shell.comm

    def _derive_forms(self, energy: Any, jit_options: dict[str, Any] | None = None) -> None:
        """From the energy (a UFL form of ``w`` and ``kappa``): ``energy_ufl``, the residual
        R = ∂E/∂w, the Hessian ∂R/∂w and dR/dκ, as UFL and compiled forms (dR/dκ compiled
        only: from the form cache, ``shells.problem.formcache``, where it has a record). The energy
        is quadratic in κ with a state-independent κ² term, so R is affine in κ and
        R(κ=1) - R(κ=0) is dR/dκ exactly."""
        import ufl
        from dolfinx import fem

        dw, w_ = ufl.TestFunction(self.W), ufl.TrialFunction(self.W)
        self.energy_ufl = energy
        self.residual_ufl = residual = ufl.derivative(energy, self.w, dw)
        self.hessian_ufl = ufl.derivative(self.residual_ufl, self.w, w_)
        opts = {} if jit_options is None else {"jit_options": jit_options}
        self.residual = fem.form(self.residual_ufl, **opts)
        self.hessian = fem.form(self.hessian_ufl, **opts)
        self.dres_dkappa = compiled_derived(
            residual, f"{_DERIVATION} dR/dkappa", lambda: [dkappa_ufl(residual, self.kappa)],
            jit_options)[0][0]

    @property
    def state(self) -> Any:
        return self.w.x.petsc_vec

    def sync(self) -> None:
        self.w.x.scatter_forward()

    def get_kappa(self) -> float:
        return float(self.kappa.value)

    def set_kappa(self, kappa: float) -> None:
        self.kappa.value = kappa

    def length_scale(self) -> float:
        return float(self.shape.characteristic_size())

    def state_scale(self) -> float:
        return float(self.h.value)

    def create_vector(self) -> Any:
        from dolfinx.fem.petsc import create_vector

        return create_vector(self.residual)

    def create_jacobian(self) -> Any:
        from dolfinx.fem.petsc import create_matrix

        return create_matrix(self.hessian)

    def assemble_residual(self, b: Any) -> None:
        from dolfinx.fem.petsc import apply_lifting, assemble_vector, set_bc
        from petsc4py import PETSc

        with b.localForm() as bl:
            bl.set(0.0)
        assemble_vector(b, self.residual)
        apply_lifting(b, [self.hessian], bcs=[self.bcs], x0=[self.state], alpha=-1.0)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        set_bc(b, self.bcs, self.state, -1.0)

    def assemble_jacobian(self, A: Any) -> None:
        from dolfinx.fem.petsc import assemble_matrix

        A.zeroEntries()
        assemble_matrix(A, self.hessian, bcs=self.bcs)
        A.assemble()

    def assemble_dkappa(self, b: Any) -> None:
        from dolfinx.fem.petsc import assemble_vector, set_bc
        from petsc4py import PETSc

        with b.localForm() as bl:
            bl.set(0.0)
        assemble_vector(b, self.dres_dkappa)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        set_bc(b, self.bcs, alpha=0.0)

    def zero_constrained(self, v: Any) -> None:
        from dolfinx.fem.petsc import set_bc

        set_bc(v, self.bcs, alpha=0.0)

    # -- helpers for the models' stability blocks -------------------------------------------------
    def _quadratic(self, key: Any, bilinear: Any, bcs: list[Any], v: Any,
                   jit_options: dict[str, Any] | None = None,
                   derived: tuple[str, Callable[[], Any]] | None = None) -> float:
        """vᵀ A v for the bilinear form A (UFL, symmetric) by quadrature of A(v, v) as a
        functional, the DOFs of ``bcs`` of v taken as zero (a block's ``hessian_quadratic``).
        Each quadrature point's value comes from v's own values and derivatives there, so its
        round-off is ε times the terms of A(v, v) itself, where that of a product with the
        assembled matrix is ε |v|ᵀ|A||v|: on the 1D model's stiff blocks ~1e-6 against an
        eigenvalue of 1e-7 next to a crossing (``benchmarks/locator_noise.py``). The functional
        is compiled on first use for each ``key`` (the form's variable data, Constants and
        coefficients, are read at each call). ``derived`` = (tag, derive): the functional of
        the bilinear form ``derive()`` instead, a form derived from ``bilinear`` (its first
        argument's space), recorded in the form cache under ``bilinear``'s signature and
        ``tag``, which must change whenever the derivation does: no UFL work, nor the
        signature of a derived expression, where the record is found."""
        import ufl
        from dolfinx import fem
        from dolfinx.fem.petsc import set_bc
        from mpi4py import MPI

        cache = self.__dict__.setdefault("_quadratics", {})
        if key not in cache:
            f = fem.Function(bilinear.arguments()[0].ufl_function_space())
            # through the form cache: the action's UFL work and signature are costly on the
            # 1D model's mode Hessian, for a kernel compiled long ago
            tag, derive = derived if derived is not None else ("", lambda: bilinear)
            forms, _ = compiled_derived(
                bilinear, f"{_DERIVATION}{' ' + tag if tag else ''} quadratic",
                lambda: [ufl.action(ufl.action(derive(), f), f)], jit_options, extra=(f,))
            cache[key] = (f, forms[0])
        f, q = cache[key]
        x = f.x.petsc_vec
        x.array_w[:] = v.array_r
        set_bc(x, bcs, alpha=0.0)
        f.x.scatter_forward()
        return float(self.comm.allreduce(fem.assemble_scalar(q), op=MPI.SUM))

    @staticmethod
    def _assemble_mass(form: Any, bcs: list[Any]) -> Any:
        from dolfinx.fem.petsc import assemble_matrix

        M = assemble_matrix(form, bcs=bcs, diagonal=1.0e-12)
        M.assemble()
        return FormProblem._without_zeros(M)

    @staticmethod
    def _without_zeros(A: Any) -> Any:
        """A copy of A that stores only its nonzero values (A destroyed). dolfinx's pattern
        couples every pair of DOFs of a cell, but a mass matrix couples each field component
        with itself alone: on the 1D model's Fourier blocks 13.8k of 81k stored values are
        nonzero. The eigensolves multiply by M a few dozen times each (B-inner products, the
        shift-invert's B x): 9 instead of 30 µs a product there, the same values (the
        products' terms are the same, in the same order, less exact zeros)."""
        import numpy as np
        from petsc4py import PETSc

        ai, aj, values = A.getValuesCSR()
        keep = values != 0.0
        rows = np.repeat(np.arange(len(ai) - 1), np.diff(ai))
        counts = np.bincount(rows[keep], minlength=len(ai) - 1)
        indptr = np.concatenate([[0], np.cumsum(counts)]).astype(ai.dtype)
        B = PETSc.Mat().createAIJ(A.getSizes(), csr=(indptr, aj[keep], values[keep]),
                                  comm=A.getComm())
        B.assemble()
        A.destroy()
        return B


def assemble_symmetric(H: Any, form: Any, bcs: list[Any]) -> None:
    """Assemble the bilinear ``form`` into the symmetric matrix ``H`` in place.

    Args:
        H: a PETSc matrix with ``form``'s layout; its entries are replaced.
        form: a compiled symmetric bilinear form.
        bcs: Dirichlet conditions: their rows and columns are zeroed, with 1 on the diagonal.
    """
    from dolfinx.fem.petsc import assemble_matrix

    H.zeroEntries()
    assemble_matrix(H, form, bcs=bcs, diagonal=1.0)
    H.assemble()
    H.setOption(H.Option.SYMMETRIC, True)
