"""Stability of the axisymmetric model against every Fourier mode m (problem layer): the
mode Hessians H_m of ``AxisymModel``, one compiled form for all m and, for m ≥ 1, H_m as a
polynomial in m whose matrix coefficients are assembled once per base state.

Perturbations U(t) cos mφ e_r + V(t) sin mφ e_φ + W(t) cos mφ e_z about the base state. For an
axisymmetric base state the φ-integral of the second-variation density Q equals
π [Q(mφ = 0) + Q(mφ = π/2)] for m ≥ 1 and 2π Q for m = 0, so one UFL form (the second
derivative of the density at base + perturbation, at two phases) with m and the phases as
Constants gives every Hessian H_m: one compilation, no recompiles. The unknowns are (S, D, W)
with U = S + D, V = S - D for m ≥ 1 (U = S, V = D for m = 0), which turns the axis conditions
into Dirichlet conditions on each pole (``ModeForms.conditions``). Inertia per m: a Cholesky
test where H_m is definite by a margin, else an exact count (``shells.algorithms.stability``).

Assembly:

1. m = 0 from its own form, m and its phases put in as numbers (``axisymmetric_form``: the
   direct form's values at a fraction of its cost).
2. m ≥ 1: with the phases fixed, m enters the perturbation's jet linearly (φ-derivatives ∝ m,
   ∂_φφ ∝ m²) and the second variation is quadratic in the jet, so H_m = Σ_{k=0..4} m^k C_k
   before the boundary conditions. The C_k are exact forms: the Hessian's UFL differentiated
   k times in m by ``ufl.derivative`` at m = 0, over k! (no sampling of m, so no round-off
   amplified by m^k); one compiled kernel each.
3. The C_k are assembled without conditions once per base state, and again as soon as any
   input their forms read (coefficient arrays, Constant values, mesh geometry) differs, so no
   state change can be served a stale C_k. H_m = Σ m^k C_k has one nonzero pattern (the
   direct form's) and mode m's conditions applied as direct assembly does
   (MatZeroRowsColumns): the direct assembly to round-off (tests/test_axisym_modes.py).
4. On one process the C_k and H_0 are not assembled at all: their element matrices are
   tabulated once per state (H_0's from C_0's by a change of unknowns), every H_m's
   definiteness and exact count come from them (``shells.axisym.chain``), and a PETSc H_m is
   summed from them where a solver needs one.

The costs: docs/model.md (the section on the assembly of the 1D model's mode Hessians) and
docs/design-notes.md, "The 1D model's assembly".
"""

from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np

from shells.axisym.kinematics import JIT_OPTIONS, Jet, dirichlet, read_inputs, same_inputs
from shells.errors import InputError
from shells.problem.formcache import compiled_derived, file_tag

__all__ = ["ModeForms"]

log = logging.getLogger("shells")

#: the phase Constants of mode 0 and of every m ≥ 1 (``ModeForms.set_mode``)
_PHASES: dict[int, dict[str, float]] = {
    0: dict(a0=1.0, b0=1.0, a1=1.0, b1=1.0, cSU=1.0, cDU=0.0, cSV=0.0, cDV=1.0),
    1: dict(a0=1.0, b0=0.0, a1=0.0, b1=1.0, cSU=1.0, cDU=1.0, cSV=1.0, cDV=-1.0),
}
#: H_m of m ≥ 1 is a polynomial of this degree in m
DEGREE = 4
#: names the derivation of the mode forms from the Hessian's UFL (this file) in the form cache
#: (``shells.problem.formcache``): any change of this module derives them again
_DERIVATION = file_tag(__file__)


# ------------------------------------------------------------------------------------------------
# stability against Fourier modes
# ------------------------------------------------------------------------------------------------
class ModeForms:
    """The Fourier-mode Hessians H_m of the energy about the model's (axisymmetric) state.

    Unknowns (S, D, W; P_S, P_D, P_W) in P3³ x P2³: U = S + D, V = S - D for m ≥ 1 and U = S,
    V = D for m = 0 (see the module docstring for the axis conditions). One compiled form for
    every m: m and the phases are Constants (``set_mode``). ``assemble_hessian(m, H)``: m = 0
    from that form, m ≥ 1 as Σ m^k C_k from the coefficient forms ``coefficient_forms``
    (compiled on first use) and their matrices, reassembled whenever the state they were
    assembled at changed (module docstring).
    """

    def __init__(self, model: Any) -> None:
        import basix.ufl
        import ufl
        from dolfinx import default_scalar_type, fem

        self.model = model
        mesh = model.mesh
        cell = mesh.basix_cell()
        P3 = basix.ufl.element("Lagrange", cell, 3, shape=(3,))
        P2 = basix.ufl.element("Lagrange", cell, 2, shape=(3,))
        self.V = fem.functionspace(mesh, basix.ufl.mixed_element([P3, P2]))
        self.pert = fem.Function(self.V)  # stays zero: the Hessian is taken at the base state
        c = {k: fem.Constant(mesh, default_scalar_type(0.0))
             for k in ("m", "a0", "b0", "a1", "b1", "cSU", "cDU", "cSV", "cDV")}
        self.c = c
        base = model.base_jet(model.w)
        jet = self.amplitude_jet
        dens = (model.energy_density(base + jet(self.pert, c["a0"], c["b0"]))["total"]
                + model.energy_density(base + jet(self.pert, c["a1"], c["b1"]))["total"])
        energy = math.pi * dens * model.r0 * model.g * model.dx
        v, v_ = ufl.TestFunction(self.V), ufl.TrialFunction(self.V)
        self.hessian_ufl = ufl.derivative(ufl.derivative(energy, self.pert, v), self.pert, v_)
        self.form = fem.form(self.hessian_ufl, jit_options=JIT_OPTIONS)
        self.mass = fem.form(ufl.inner(v_, v) * model.r0 * model.g * model.dx,
                             jit_options=JIT_OPTIONS)
        self._bcs = {k: self._conditions(k) for k in (0, 1, 2, 3)}
        self._expanded: Any = None  # ``hessian_ufl`` with its derivatives expanded
        self._coefficient_forms: list[Any] | None = None
        self._axisymmetric_form: Any = None  # H_0's own form (``axisymmetric_form``)
        self._C: list[Any] | None = None  # the matrices C_k
        self.coefficient_inputs: list[np.ndarray] | None = None  # what they were assembled from
        self._read: tuple[dict, dict] = ({}, {})  # the coefficients and Constants they read
        self._rows: dict[int, Any] = {}  # the constrained rows of each class of m
        self._chain: Any = None  # ``definite``'s tabulator and chain test (False: unavailable)
        self._E: np.ndarray | None = None  # ``element_matrices``
        self.element_inputs: list[np.ndarray] | None = None  # what they were tabulated from
        self._csr: Any = None  # ``_set_from_elements``'s ``ElementAssembler``
        self._schur: Any = None  # ``condensed_hessian``'s matrix
        #: names the derivations of forms from ``hessian_ufl`` in this module (form cache)
        self.derivation = _DERIVATION

    # -- H_m = Σ m^k C_k for m ≥ 1 --------------------------------------------------------
    def coefficient_ufl(self) -> list[Any]:
        """The UFL forms of C_0..C_4, H_m = Σ m^k C_k (m ≥ 1, no boundary conditions): the
        Hessian with the m ≥ 1 phases as numbers and the zero perturbation as 0, its k-th
        derivative in m (m a coefficient; ``ufl.derivative`` in the direction 1) at m = 0,
        over k!. Exact: the derivatives are symbolic, nothing is sampled."""
        import ufl
        from ufl.algorithms import expand_derivatives

        h, m = self._fixed_mode_ufl(1)  # m: a DG0 coefficient, symbolic only
        out = []
        for k in range(DEGREE + 1):
            out.append((1.0 / math.factorial(k)) * ufl.replace(h, {m: ufl.zero()}))
            if k < DEGREE:
                h = expand_derivatives(ufl.derivative(h, m, ufl.as_ufl(1.0)))
        return out

    def fixed_phase_ufl(self, m: int, m_as: Any = None) -> Any:
        """The Hessian's UFL for mode m's class with its phases put in as numbers and the zero
        perturbation as 0: m = 0 the number 0; m ≥ 1 the Constant ``set_mode`` sets (the
        direct form's values at a fraction of its cost: ``hessian_quadratic``), or ``m_as`` in
        its place (a coefficient to differentiate in: ``_fixed_mode_ufl``)."""
        import ufl
        from ufl.algorithms import expand_derivatives

        c = self.c
        rep: dict[Any, Any] = {c[k]: ufl.as_ufl(v) for k, v in _PHASES[min(m, 1)].items()}
        if m == 0:
            rep[c["m"]] = ufl.as_ufl(0.0)
        elif m_as is not None:
            rep[c["m"]] = m_as
        rep[self.pert] = ufl.zero(*self.pert.ufl_shape)
        if self._expanded is None:  # once: every use expands the same (costly) Hessian
            self._expanded = expand_derivatives(self.hessian_ufl)
        return ufl.replace(self._expanded, rep)

    def _fixed_mode_ufl(self, m: int) -> tuple[Any, Any]:
        """``fixed_phase_ufl`` with m a symbolic coefficient for m ≥ 1 (m = 0: the number 0),
        and that m."""
        import ufl
        from dolfinx import fem

        mm = (ufl.as_ufl(0.0) if m == 0 else
              fem.Function(fem.functionspace(self.model.mesh, ("DG", 0))))
        return self.fixed_phase_ufl(m, m_as=mm), mm

    @property
    def axisymmetric_form(self) -> Any:
        """The compiled form of H_0 with m = 0 and its phases put in as numbers.

        Compiled on first use. Its values are the direct form's to round-off, at a fraction
        of its cost (the direct form evaluates the density at two general phases), so the
        stability check's one direct assembly per state costs less than the five coefficient
        matrices together (docs/design-notes.md, "The 1D model's assembly")."""

        if self._axisymmetric_form is None:
            forms, reads = compiled_derived(self.hessian_ufl, f"{_DERIVATION} H_0",
                                            lambda: [self._fixed_mode_ufl(0)[0]], JIT_OPTIONS)
            self._axisymmetric_form = forms[0]
            self._register_reads(reads)
        return self._axisymmetric_form

    @property
    def coefficient_forms(self) -> list[Any]:
        """The compiled forms of C_0..C_4 (``coefficient_ufl``), one kernel each; after the
        first run on a machine, without their UFL work (``shells.problem.formcache``)."""
        if self._coefficient_forms is None:
            forms, reads = compiled_derived(self.hessian_ufl, f"{_DERIVATION} C_k",
                                            self.coefficient_ufl, JIT_OPTIONS)
            self._coefficient_forms = forms
            self._register_reads(reads)
        return self._coefficient_forms

    def _register_reads(self, reads: list[tuple[list, list]]) -> None:
        """Remember the coefficients and Constants that forms read: ((coefficients,
        constants) of each form)."""
        coefficients, constants = self._read
        for ws, ks in reads:
            coefficients.update({id(w): w for w in ws})
            constants.update({id(k): k for k in ks})

    def _inputs(self) -> list[np.ndarray]:
        """Everything the coefficient forms and H_0's form read (``model.read_inputs``)."""
        coefficients, constants = self._read
        return read_inputs(coefficients.values(), constants.values(), self.model.mesh)

    def _stale(self, old: list[np.ndarray] | None) -> tuple[bool, list[np.ndarray]]:
        """Whether the inputs differ from ``old`` (compared exactly; collective: a change on
        any rank counts), and the current inputs."""
        from mpi4py import MPI

        inputs = self._inputs()
        stale = not same_inputs(old, inputs)
        comm = self.model.comm
        if comm.size > 1:
            stale = comm.allreduce(stale, op=MPI.LOR)
        return stale, inputs

    def coefficient_matrices(self) -> list[Any]:
        """C_0..C_4 at the model's current state: assembled (no boundary conditions) on first
        use and again whenever any input of the coefficient forms differs from the one they
        were assembled from (compared exactly; collective: a change on any rank counts)."""
        from dolfinx.fem.petsc import assemble_matrix, create_matrix

        forms = self.coefficient_forms
        stale, inputs = self._stale(self.coefficient_inputs)
        if stale:
            if self._C is None:  # the direct form's pattern: that of every H_m's matrix
                self._C = [create_matrix(self.form) for _ in forms]
            self.coefficient_inputs = None  # not valid while being assembled
            for C, f in zip(self._C, forms, strict=True):
                C.zeroEntries()
                assemble_matrix(C, f)
                C.assemble()
            self.coefficient_inputs = [a.copy() for a in inputs]
        return self._C

    def constrained_rows(self, m: int) -> Any:
        """Global indices of the owned DOFs constrained in mode m (a PETSc IS)."""
        from petsc4py import PETSc

        key = min(int(m), 3)
        if key not in self._rows:
            im, bs = self.V.dofmap.index_map, self.V.dofmap.index_map_bs
            local = []
            for bc in self.conditions(m):
                dofs, first_ghost = bc.dof_indices()
                local.append(np.asarray(dofs[:first_ghost]))
            local = np.unique(np.concatenate(local)) if local else np.zeros(0, np.int32)
            blocks, comp = np.divmod(local, bs)
            rows = im.local_to_global(blocks.astype(np.int32)) * bs + comp
            self._rows[key] = PETSc.IS().createGeneral(rows.astype(PETSc.IntType),
                                                       comm=self.model.comm)
        return self._rows[key]

    def assemble_hessian(self, m: int, H: Any, direct: bool = False) -> None:
        """H_m at the model's state into H (a matrix of ``create_matrix(self.form)``) with mode
        m's conditions (zero rows and columns, unit diagonal), flagged symmetric. ``direct``:
        from ``form``; m = 0: from ``axisymmetric_form``; m ≥ 1: Σ m^k C_k
        (``coefficient_matrices``). On one process both come from the element matrices
        (``element_matrices``): Σ m^k of theirs, summed into H's values by their positions,
        the conditions applied to those values (the same matrix to round-off, without five
        assemblies of the C_k after each change of state).

        Args:
            m: the mode.
            H: the matrix.
            direct: assemble from ``form`` itself (the reference).
        """
        from petsc4py import PETSc

        from shells.problem.forms import assemble_symmetric

        bcs = self.set_mode(m)
        if direct:
            assemble_symmetric(H, self.form, bcs)
            return
        E = self.element_matrices()
        if E is not None:  # one process: from the element matrices, no assembly of forms
            self._set_from_elements(H, self._block_elements(E, [m])[0], m)
            return
        if m == 0:
            assemble_symmetric(H, self.axisymmetric_form, bcs)
            return
        C = self.coefficient_matrices()
        same = PETSc.Mat.Structure.SAME_NONZERO_PATTERN
        if H.assembled:
            C[0].copy(H, structure=same)
        else:  # a new matrix, only preallocated: C_0's values (and pattern) inserted
            H.setValuesCSR(*C[0].getValuesCSR())
            H.assemble()
        for k in range(1, DEGREE + 1):
            H.axpy(float(m) ** k, C[k], structure=same)
        H.zeroRowsColumns(self.constrained_rows(m), diag=1.0)
        H.setOption(H.Option.SYMMETRIC, True)

    def chain_setup(self) -> Any:
        """(tabulator, chain test) of ``shells.axisym.chain`` for this space, made on first use;
        None in parallel or where it cannot be set up (no C compiler, an unexpected mesh)."""
        if self.model.comm.size > 1 or self._chain is False:
            return None
        if self._chain is None:
            try:
                from shells.axisym.chain import CellTabulator, ChainCholesky

                layout = self.V.dofmap.dof_layout
                tab = CellTabulator(self.coefficient_forms)
                pairs = self._sum_difference_pairs()
                chain = ChainCholesky(self.V.dofmap.list,
                                      (list(layout.entity_dofs(0, 0)),
                                       list(layout.entity_dofs(0, 1))),
                                      list(layout.entity_dofs(1, 0)))
                for key in (0, 1, 2, 3):  # every condition on a vertex DOF
                    chain.constraint_indices(np.asarray(self.constrained_rows(key).getIndices()))
            except Exception as e:  # the assembled path instead
                log.debug("element matrices of the mode forms not available: %s", e)
                self._chain = False
                return None
            self._chain = (tab, chain, pairs)
        return self._chain

    def _sum_difference_pairs(self) -> tuple[np.ndarray, np.ndarray]:
        """The element-local positions of the S and of the D DOFs of each node (values and
        slope fields), the same in every cell (``ValueError`` otherwise): the rows and columns
        that ``_axisymmetric_elements`` mixes."""
        cells = np.asarray(self.V.dofmap.list)
        first, second = [], []
        for field in (0, 1):  # the displacement and the slope field
            for comp, out in ((0, first), (1, second)):
                sub = np.asarray(self.V.sub(field).sub(comp).dofmap.list)
                # the position of each of the subspace's cell DOFs in the cell's DOF list
                where = np.argmax(cells[:, None, :] == sub[:, :, None], axis=2)
                if not (np.all(where == where[:1])
                        and np.array_equal(np.take_along_axis(cells, where, 1), sub)):
                    raise ValueError("the S and D DOFs lie at other places in some cells")
                out.extend(where[0].tolist())
        return np.array(first, dtype=np.intc), np.array(second, dtype=np.intc)

    @staticmethod
    def _axisymmetric_elements(C0: np.ndarray, pairs: tuple[np.ndarray, np.ndarray],
                               out: np.ndarray) -> None:
        """H_0's element matrices from C_0's: H_0 = 2 Tᵀ C_0 T, T the change of unknowns
        S' = (S + D)/2, D' = (S - D)/2 at every node (``chain.sum_difference``). C_0 (H_m at
        m = 0 with the m ≥ 1 phases) is π [q_UW(S + D, W) + q_V(S - D)]: the quadratic forms
        of the meridional and of the azimuthal displacement, which do not couple at m = 0
        about an axisymmetric state (the base state has no azimuthal component); H_0 is
        2π [q_UW(S, W) + q_V(D)]. Equal to the second derivative of its own form to round-off,
        at no kernel's cost (docs/model.md, "Stability and critical points")."""
        from shells.axisym.chain import sum_difference

        sum_difference(C0, pairs[0], pairs[1], out)

    def element_matrices(self) -> np.ndarray | None:
        """The element matrices of C_0..C_4 and of H_0 on every cell (6, cells, 21, 21) at
        the model's current state: tabulated on first use and again whenever an input of the
        forms changed (as ``coefficient_matrices``). None in parallel (``chain_setup``)."""
        setup = self.chain_setup()
        if setup is None:
            return None
        stale, inputs = self._stale(self.element_inputs)
        if stale:
            self.element_inputs = None  # not valid while being tabulated
            tab, _, pairs = setup
            if self._E is None:
                self._E = np.empty((DEGREE + 2, tab.ncells, tab.n, tab.n))
            tab.tabulate(out=self._E[:DEGREE + 1])
            self._axisymmetric_elements(self._E[0], pairs, self._E[DEGREE + 1])
            self.element_inputs = [a.copy() for a in inputs]
        return self._E

    @staticmethod
    def _powers(ms: list[int]) -> np.ndarray:
        """(m^k) for k = 0..DEGREE, one row per m."""
        return np.array([[float(m) ** k for k in range(DEGREE + 1)] for m in ms]
                        ).reshape(len(ms), DEGREE + 1)

    @staticmethod
    def _block_elements(E: np.ndarray, ms: list[int]) -> np.ndarray:
        """The element matrices of H_m for each m: Σ m^k of the C_k's (one matrix product),
        H_0's own for m = 0."""
        powers = ModeForms._powers(ms)
        out = (powers @ E[:DEGREE + 1].reshape(DEGREE + 1, -1)).reshape(len(ms), *E.shape[1:])
        for i, m in enumerate(ms):
            if m == 0:
                out[i] = E[DEGREE + 1]
        return out

    def _assembler(self) -> Any:
        if self._csr is None:
            from shells.axisym.chain import ElementAssembler

            self._csr = ElementAssembler(self.form)
        return self._csr

    def _set_from_elements(self, H: Any, Em: np.ndarray, m: int) -> None:
        """H's values from the element matrices Em of H_m (``chain.ElementAssembler``), mode
        m's constrained rows and columns 0 and their diagonal 1, flagged symmetric."""
        self._assembler().set(H, Em, np.asarray(self.constrained_rows(m).getIndices()))
        H.setOption(H.Option.SYMMETRIC, True)

    def create_matrix(self) -> Any:
        """A matrix of the pattern of every H_m: on one process one whose value array
        ``assemble_hessian`` writes in place (``chain.ElementAssembler.create_matrix``: no
        ``setValuesCSR``), else dolfinx's."""
        from dolfinx.fem.petsc import create_matrix

        if self.chain_setup() is not None:
            return self._assembler().create_matrix()
        return create_matrix(self.form)

    def condensed_hessian(self, m: int) -> tuple[Any, int] | None:
        """H_m's Schur complement on the vertex DOFs (the interior DOFs eliminated cell by cell,
        ``shells.axisym.chain``) as a PETSc matrix (one, reused for every m), and the number of
        eliminated DOFs: H_m's inertia is the matrix's with that many more positive
        eigenvalues. None in parallel, or if an interior block is not positive definite."""
        block = self._chain_block(m)
        if block is None:
            return None
        out = self._chain[1].schur(*block)
        if out is None:
            return None
        values, eliminated = out
        indptr, indices, _ = self._chain[1].schur_pattern()
        if self._schur is None:
            from petsc4py import PETSc

            size = len(indptr) - 1
            self._schur = PETSc.Mat().createAIJ([size, size], csr=(indptr, indices, values),
                                                comm=PETSc.COMM_SELF)
        else:
            self._schur.setValuesCSR(indptr, indices, values)
        self._schur.assemble()
        self._schur.setOption(self._schur.Option.SYMMETRIC, True)
        return self._schur, eliminated

    def inertia(self, m: int, growth: float) -> tuple[int, int, int] | None:
        """H_m's inertia from its element matrices condensed on the chain of cells, by an LDLᵀ
        without pivoting that vouches for its count (``ChainCholesky.inertia``, ``growth``);
        None in parallel or where it cannot vouch (the caller then asks MUMPS)."""
        out = self.inertias([m], growth)
        return None if out is None else out[int(m)]

    def inertias(self, ms: list[int], growth: float
                 ) -> dict[int, tuple[int, int, int] | None] | None:
        """``inertia`` of each H_m, m in ``ms``, condensed together
        (``ChainCholesky.inertias``: four or eight blocks in lockstep); None in parallel."""
        E = self.element_matrices()
        if E is None:
            return None
        ms = [int(m) for m in ms]
        blocks = [self._chain_block(m) for m in ms]  # (E, powers, own, constrained) each
        counts = self._chain[1].inertias(E, self._powers(ms), [b[2] for b in blocks],
                                         [b[3] for b in blocks], growth)
        return dict(zip(ms, counts, strict=True))

    def factor(self, m: int) -> Any:
        """H_m factored from its element matrices on the chain of cells (``ChainLU``: solves
        H_m x = b, the matrix as ``assemble_hessian`` assembles it); None in parallel, or where
        the factorisation does not apply or fails (the caller then uses MUMPS)."""
        block = self._chain_block(m)
        f = None if block is None else self._chain[1].factor(*block)
        return f if f is not None and f.ok else None

    def _chain_block(self, m: int) -> tuple[np.ndarray, np.ndarray, int, np.ndarray] | None:
        """``ChainCholesky``'s arguments for H_m at the current state (element matrices, the
        powers of m, H_0's own form for m = 0, the constrained DOFs); None in parallel."""
        E = self.element_matrices()
        if E is None:
            return None
        m = int(m)
        return (E, self._powers([m]), DEGREE + 1 if m == 0 else -1,
                np.asarray(self.constrained_rows(m).getIndices()))

    def definite(self, ms: list[int], margin: float) -> dict[int, bool] | None:
        """For each m: is H_m - ``margin`` diag(H_m) positive definite (a Cholesky factor
        exists)? From the element matrices (``element_matrices``), combined for all m at once
        and condensed on the chain of cells (``shells.axisym.chain``): the banded Cholesky's
        answer without assembling any H_m. One process only; None where that is not
        available (the caller then tests the assembled blocks)."""
        E = self.element_matrices()
        if E is None:
            return None
        ms = [int(m) for m in ms]
        constrained = [np.asarray(self.constrained_rows(m).getIndices()) for m in ms]
        powers = self._powers(ms)
        own = [DEGREE + 1 if m == 0 else -1 for m in ms]  # H_0 has its own form
        answers = self._chain[1].definite(E, powers, own, constrained, margin)
        return dict(zip(ms, answers, strict=True))

    def amplitude_jet(self, f: Any, a: Any, b: Any) -> Jet:
        """The jet of the perturbation whose amplitudes (S, D, W; P_S, P_D, P_W) are ``f`` (a
        function or an argument of ``V``), at the phase (cos mφ, sin mφ) = (a, b), with the
        mode's Constants (``set_mode``)."""
        import ufl

        c = self.c
        q, Pq = ufl.split(f)
        S, D, W = q[0], q[1], q[2]
        U, V = c["cSU"] * S + c["cDU"] * D, c["cSV"] * S + c["cDV"] * D
        PU = c["cSU"] * Pq[0] + c["cDU"] * Pq[1]
        PV = c["cSV"] * Pq[0] + c["cDV"] * Pq[1]
        PW = Pq[2]
        m = c["m"]
        d = lambda g: g.dx(0)  # noqa: E731
        return Jet(val=(U * a, V * b, W * a), t=(d(U) * a, d(V) * b, d(W) * a),
                   ph=(-m * U * b, m * V * a, -m * W * b),
                   tph=(-m * d(U) * b, m * d(V) * a, -m * d(W) * b),
                   phph=(-m**2 * U * a, -m**2 * V * b, -m**2 * W * a),
                   p=(PU * a, PV * b, PW * a), pt=(d(PU) * a, d(PV) * b, d(PW) * a),
                   pph=(-m * PU * b, m * PV * a, -m * PW * b))

    @property
    def kinetic_form(self) -> Any:
        """The compiled kinetic mass of mode m (``set_mode``): π Σ over the two phases of the
        model's ``kinetic_density`` about the base state, r° g dt (as the Hessian's φ-integral),
        compiled on first use."""
        if not hasattr(self, "_kinetic_form"):
            import ufl
            from dolfinx import fem

            model, c = self.model, self.c
            v, v_ = ufl.TestFunction(self.V), ufl.TrialFunction(self.V)
            base = model.base_jet(model.w)
            dens = sum(model.kinetic_density(base, self.amplitude_jet(v_, c[a], c[b]),
                                             self.amplitude_jet(v, c[a], c[b]))
                       for a, b in (("a0", "b0"), ("a1", "b1")))
            self._kinetic_form = fem.form(math.pi * dens * model.r0 * model.g * model.dx,
                                          jit_options=JIT_OPTIONS)
        return self._kinetic_form

    def rigid_motions(self, m: int) -> list[Any]:
        """The rigid motions of mode m = 0 or 1 that its gauge removes, about the current
        (axisymmetric) state, as vectors of ``V`` (``AxisymModel.rigid_motions``)."""
        from dolfinx import default_scalar_type, fem

        if not hasattr(self, "_rigid"):
            import ufl

            model = self.model
            u, p = ufl.split(model.w)
            r, z = model.r0 + u[0], model.z0 + u[1]
            rt, zt = model.r0t + p[0], model.z0t + p[1]
            k = {n: fem.Constant(model.mesh, default_scalar_type(0.0))
                 for n in ("D1", "Dr", "Dz", "W1", "Wr")}
            zero = 0.0 * model.t
            values = ufl.as_vector([zero, k["D1"] + k["Dr"] * r + k["Dz"] * z,
                                    k["W1"] + k["Wr"] * r])
            slopes = ufl.as_vector([zero, k["Dr"] * rt + k["Dz"] * zt, k["Wr"] * rt])
            parts = []
            for i, ex in enumerate((values, slopes)):
                Vi, dofs = self.V.sub(i).collapse()
                parts.append((fem.Function(Vi), fem.Expression(ex, Vi.element.
                                                               interpolation_points()),
                              np.asarray(dofs)))
            self._rigid = (k, parts, fem.Function(self.V))
        k, parts, f = self._rigid
        kinds = ({"W1": 1.0}, {"Dr": 1.0}) if m == 0 else ({"D1": 1.0}, {"Dz": 1.0, "Wr": -1.0})
        out = []
        for kind in kinds:
            for name, const in k.items():
                const.value = kind.get(name, 0.0)
            for g, ex, dofs in parts:
                g.interpolate(ex)
                f.x.array[dofs] = g.x.array
            f.x.scatter_forward()
            out.append(f.x.petsc_vec.copy())
        return out

    def radial_axial(self, f: Any) -> tuple[Any, Any]:
        """(u_r, u_z) amplitudes of a mode ``f`` in ``V`` (U and W; phases as last set)."""
        import ufl

        q, _ = ufl.split(f)
        return self.c["cSU"] * q[0] + self.c["cDU"] * q[1], q[2]

    def _conditions(self, mclass: int) -> list[Any]:
        V, model = self.V, self.model
        S, D, W = V.sub(0).sub(0), V.sub(0).sub(1), V.sub(0).sub(2)
        PS, PD, PW = V.sub(1).sub(0), V.sub(1).sub(1), V.sub(1).sub(2)
        poles, top = model.axis_vertices(), model.vertices_at(0.0)
        widest = model.widest_vertex()
        if mclass == 0:
            pairs = [(S, poles), (D, poles), (PW, poles), (W, top), (D, widest)]
        elif mclass == 1:
            pairs = [(S, poles), (PS, poles), (PD, poles), (W, poles), (D, top), (W, widest)]
        elif mclass == 2:
            pairs = [(S, poles), (D, poles), (W, poles), (PS, poles), (PW, poles)]
        else:
            pairs = [(S, poles), (D, poles), (W, poles), (PS, poles), (PD, poles), (PW, poles)]
        return [bc for sub, verts in pairs for bc in dirichlet(sub, verts)]

    def conditions(self, m: int) -> list[Any]:
        """The Dirichlet conditions of mode m (axis conditions and rigid-motion gauges).

        On each pole (∂: the slope field): m = 0: S = D = 0, ∂W = 0; m = 1: S = 0, W = 0,
        ∂S = ∂D = 0; m = 2: S = D = W = 0, ∂S = ∂W = 0; m ≥ 3: all values and slopes zero. A
        free rim needs no condition. Rigid motions are exact null vectors of the continuum
        Hessians and are removed by value constraints that they violate (restriction to such
        a hyperplane keeps the inertia): m = 0: W = 0 at the top pole (z-translation), D = 0
        on the widest parallel (rotation about z); m = 1: D = 0 at the top pole (translation)
        and W = 0 on the widest parallel (tilt). A slope constraint at the pole would do for
        the tilt in principle, but a point has no capacity for slopes in 2D: it leaves a
        spurious near-zero eigenvalue.

        Args:
            m: the mode.

        Returns:
            The conditions (shared by every m ≥ 3).
        """
        return self._bcs[min(int(m), 3)]

    def set_mode(self, m: int) -> list[Any]:
        """Set the Constants of mode m; returns its Dirichlet conditions."""
        if not (isinstance(m, (int, np.integer)) and m >= 0):
            raise InputError(f"the azimuthal wavenumber m must be a non-negative integer, "
                             f"got {m!r}")
        c = self.c
        c["m"].value = float(m)
        for k, v in _PHASES[min(int(m), 1)].items():
            c[k].value = v
        return self.conditions(m)
