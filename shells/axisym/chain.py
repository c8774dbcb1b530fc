"""Definiteness, exact counts and solves of the 1D model's Fourier blocks from their element
matrices, condensed on the meridian's chain of cells (problem layer: ``ModeForms.definite``,
``inertia``, ``factor`` and ``condensed_hessian``, behind ``AxisymModel.definite_blocks``,
``block_inertia``, ``block_factor`` and ``condensed_hessian``; and the Jacobian assembled
from its element matrices, ``AxisymModel.assemble_jacobian``).

A stability check of the 1D model tests every Fourier block H_m at every point of a branch.
Assembling each block (sparse, half-bandwidth 20) through PETSc from the five coefficient
matrices C_k of H_m = Σ m^k C_k and factoring it costs far more than the FFCx kernels
themselves, so the test works on element matrices instead (the costs: docs/model.md,
"Stability and critical points"):

1. ``CellTabulator``: one C loop (compiled once with cffi, cached like FFCx's own modules)
   calls the forms' FFCx kernels cell by cell into an array of element matrices: no sparse
   insertion, no copies out of PETSc (H_0's element matrices follow from C_0's by a change
   of unknowns, ``sum_difference``).
2. ``ChainCholesky``: the nine interior DOFs of a cell couple to nothing outside it, so they
   are eliminated cell by cell (a 9 x 9 Cholesky in a second C loop, which also forms each
   block's element matrix Σ m^k C_k on the fly, four or eight blocks in lockstep, one per
   SIMD lane, each lane with the arithmetic of its block alone); what remains is the Schur
   complement on the vertex DOFs, block tridiagonal (half-bandwidth 11), factored by a
   banded Cholesky in C (``definite_chain``). Boundary conditions (on vertex DOFs only) are
   applied to that complement: a constrained DOF's row and column zeroed and its diagonal
   one, which is what the complement of the constrained matrix is.
3. The exact count of a block that is not definite, from that complement without the
   margin: its inertia is the block's but for one positive eigenvalue per eliminated DOF
   (Haynsworth). ``ChainCholesky.inertia`` counts it by an LDLᵀ without pivoting that
   vouches for its count within a growth bound; ``ChainCholesky.schur`` hands it to MUMPS.
4. ``ChainCholesky.factor`` (``ChainLU``): the block for solves (the shift-invert
   eigensolves' operator). ``ElementAssembler``: a form's matrix from element matrices.

The answer is the banded Cholesky's of the assembled block: H - τ diag(H) is positive
definite iff its interior blocks are and the Schur complement is (Haynsworth), and both
factorisations are backward stable, so they can differ only for a block within round-off of
the margin τ (``shells.algorithms.stability.DEFINITE_MARGIN``), where either answer is
correct. One process only; a mesh whose cells do not form one chain, or a constrained
interior DOF, makes ``ChainCholesky`` refuse at construction (``ValueError``) and the caller
keeps the assembled path.
"""

from __future__ import annotations

import hashlib
import importlib.util
import logging
import os
import re
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["CellTabulator", "ChainCholesky", "ChainLU", "ElementAssembler", "sum_difference"]

log = logging.getLogger("shells")


def _source(name: str) -> str:
    """The text of the C source or header ``name`` beside this module: the loops themselves
    (``chain.c``; ``chain_lanes.c``, a template instantiated per SIMD lane width) and their
    declarations for cffi (``chain.h``, ``chain_lanes.h``)."""
    return (Path(__file__).with_name(name)).read_text(encoding="utf-8")


_C_DECL = _source("chain.h")

#: the declarations of ``_C_LANES``'s functions (their names end in _l@LANES@)
_C_LANES_DECL = _source("chain_lanes.h")

_C_COMMON = _source("chain.c")

#: the lane-dependent part: typedefs and functions for NL = @LANES@ lanes, instantiated for
#: each width in ``_WIDTHS`` (``_lanes_source``)
_C_LANES = _source("chain_lanes.c")

_LIBRARY: Any = None


def _cpu_flags() -> set[str]:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("flags"):
                    return set(line.split(":", 1)[1].split())
    except OSError:
        pass
    return set()


# -ffp-contract=off: no fused multiply-adds, so that definite_chain's lanes compute what the
# scalar loops would (and the module the same values on every machine). AVX2 where the CPU has
# it (its four double lanes are definite_chain's), named in the module's hash: no -march=native,
# as the cache folder may serve another machine
_CFLAGS = ["-O3", "-ffp-contract=off"] + (["-mavx2"] if "avx2" in _cpu_flags() else [])
#: the lane widths built: 8 too where the CPU has AVX-512 (a pass of eight blocks costs less
#: than two of four, even where the AVX-512 units are 256 bits wide: docs/model.md,
#: "Stability and critical points"), and ``_lanes_for`` picks one per call. Each lane's
#: arithmetic is its block's alone, in the same order (no fused multiply-adds): the values do
#: not depend on the width
_WIDTHS = (4, 8) if "avx512f" in _cpu_flags() else (4,)
if 8 in _WIDTHS:
    _CFLAGS.append("-mavx512f")


def _lanes_source(template: str, lanes: int) -> str:
    """``template`` (``_C_LANES``, ``_C_LANES_DECL``) for ``lanes`` lanes: its vector types and
    functions renamed with the suffix _l<lanes> (one instance per width in a module)."""
    out = template.replace("@LANES@", str(lanes))
    for name in ("v4u", "v4", "condense_cell", "lane_weights", "condense_chain",
                 "definite_chain"):
        out = re.sub(rf"\b{name}\b", f"{name}_l{lanes}", out)
    return out


def _lanes_for(blocks: int) -> int:
    """The lane width for a call on ``blocks`` blocks: eight where built and more than four
    blocks (fewer passes), else four (a pass of four costs less)."""
    return 8 if blocks > 4 and 8 in _WIDTHS else 4


_C_SOURCE = _C_COMMON + "".join(_lanes_source(_C_LANES, n) for n in _WIDTHS)
_C_DECLARATIONS = _C_DECL + "".join(_lanes_source(_C_LANES_DECL, n) for n in _WIDTHS)
# LAPACK by its run-time name (no -dev link needed): the library PETSc has loaded already
_LDFLAGS = ["-l:liblapack.so.3"]


def cache_dir() -> Path:
    """The package's cache folder (``shells.problem.formcache.cache_root``), where the C loop is
    built."""
    from shells.problem.formcache import cache_root

    return cache_root()


def loaded() -> bool:
    """Whether the compiled C loop is loaded in this process."""
    return _LIBRARY is not None


def unload() -> None:
    """Forget the loaded C loop: the next ``library()`` loads it again (or builds it, into
    ``cache_dir()``), as a new process would."""
    global _LIBRARY
    _LIBRARY = None


def library() -> Any:
    """The compiled C loop (cffi module ``lib``, ``ffi``): built on first use into the cache
    folder under a name that hashes its source, atomically (parallel test workers may build it
    at once), and loaded from there afterwards."""
    global _LIBRARY
    if _LIBRARY is not None:
        return _LIBRARY
    import cffi

    tag = hashlib.sha1((_C_DECLARATIONS + _C_SOURCE + " ".join(_CFLAGS + _LDFLAGS)
                        + cffi.__version__).encode()
                       ).hexdigest()[:12]
    name = f"_shells_cells_{tag}"
    folder = cache_dir()
    found = sorted(folder.glob(f"{name}*.so")) if folder.is_dir() else []
    if not found:
        folder.mkdir(parents=True, exist_ok=True)
        ffi = cffi.FFI()
        ffi.cdef(_C_DECLARATIONS)
        ffi.set_source(name, _C_SOURCE, extra_compile_args=_CFLAGS,
                       extra_link_args=_LDFLAGS)
        with tempfile.TemporaryDirectory(dir=folder) as tmp:
            built = Path(ffi.compile(tmpdir=tmp))
            os.replace(built, folder / built.name)  # atomic: a reader sees all or nothing
        found = sorted(folder.glob(f"{name}*.so"))
    spec = importlib.util.spec_from_file_location(name, found[0])
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    _LIBRARY = module
    return module


def sum_difference(C: np.ndarray, s: np.ndarray, d: np.ndarray, out: np.ndarray) -> None:
    """out[c] = 2 Tᵀ C[c] T for each of the matrices C (cells x n x n, C-contiguous, as
    ``out``), T the change of unknowns x'_s = (x_s + x_d)/2, x'_d = (x_s - x_d)/2 of the index
    pairs (s[k], d[k]) (the identity elsewhere); the arithmetic of numpy's
    ``0.5 * (a + b)``, ``0.5 * (a - b)`` on columns, then rows.

    Args:
        C: the element matrices (cells x n x n).
        s, d: the index pairs (int arrays of equal length).
        out: receives the result (the shape of ``C``).
    """
    if C.shape != out.shape or C.ndim != 3 or not (C.flags.c_contiguous
                                                   and out.flags.c_contiguous):
        raise ValueError("C and out: C-contiguous arrays of one shape (cells, n, n)")
    lib = library()
    ffi = lib.ffi
    s = np.ascontiguousarray(s, dtype=np.intc)
    d = np.ascontiguousarray(d, dtype=np.intc)
    lib.lib.sum_difference(C.shape[0], C.shape[1], len(s), ffi.cast("int*", ffi.from_buffer(s)),
                           ffi.cast("int*", ffi.from_buffer(d)),
                           ffi.cast("double*", ffi.from_buffer(C)),
                           ffi.cast("double*", ffi.from_buffer(out)))


class CellTabulator:
    """Element matrices of compiled bilinear forms (one cell integral each, on the same mesh
    and spaces) over every local cell: ``tabulate()`` -> (forms, cells, n, n), the rows and
    columns in the order of the space's ``dofmap.list``. Coefficients and constants are packed
    anew at each call (the state changes), the geometry once."""

    def __init__(self, forms: list[Any]) -> None:
        from dolfinx.fem import IntegralType

        self.forms = list(forms)
        lib = library()
        self._lib, self._ffi = lib.lib, lib.ffi
        pointers = []
        for f in self.forms:
            if set(f.integral_types) != {IntegralType.cell} or \
                    f.ufcx_form.form_integral_offsets[1] != 1:
                raise ValueError("a form of one cell integral is needed")
            kernel = f.ufcx_form.form_integrals[0].tabulate_tensor_float64
            pointers.append(int(f.module.ffi.cast("uintptr_t", kernel)))
        self._kernels = self._ffi.new("uintptr_t[]", pointers)
        mesh = self.forms[0].mesh
        geometry = mesh.geometry
        self.ncells = mesh.topology.index_map(mesh.topology.dim).size_local
        self._coords = np.ascontiguousarray(geometry.x[geometry.dofmap[: self.ncells]])
        V = self.forms[0].function_spaces[0]
        self.n = V.dofmap.dof_layout.num_dofs * V.dofmap.bs

    def tabulate(self, out: np.ndarray | None = None) -> np.ndarray:
        """(forms, cells, n, n): every form's element matrix on every local cell, now; into
        ``out`` if given (C-contiguous, that shape: no new 4 MB array per state)."""
        from dolfinx.fem.assemble import _pack_coefficients, _pack_constants

        ffi = self._ffi
        coeffs, consts = [], []
        for f in self.forms:
            packed = list(_pack_coefficients(f._cpp_object).values())
            w = packed[0] if packed else np.zeros((self.ncells, 0))
            coeffs.append(np.ascontiguousarray(w[: self.ncells], dtype=np.float64))
            consts.append(np.ascontiguousarray(_pack_constants(f._cpp_object),
                                               dtype=np.float64))
        shape = (len(self.forms), self.ncells, self.n, self.n)
        if out is None or out.shape != shape or out.dtype != np.float64 \
                or not out.flags.c_contiguous:
            out = np.empty(shape)
        ptr = lambda a: ffi.cast("const double*", ffi.from_buffer(a))  # noqa: E731
        self._lib.tabulate_cells(
            len(self.forms), self._kernels, self.ncells, self.n,
            ffi.cast("double*", ffi.from_buffer(out)),
            ffi.new("const double*[]", [ptr(a) for a in coeffs]),
            ffi.new("int[]", [a.shape[1] for a in coeffs]),
            ffi.new("const double*[]", [ptr(a) for a in consts]),
            ptr(self._coords), self._coords.shape[1])
        return out


_VALUES = "shells_csr_values"  # the attribute holding a matrix's own value array


class ElementAssembler:
    """A bilinear form's matrix from its element matrices (one process): each entry the sum of
    the element values at its position, added in cell order as dolfinx's assembler adds them
    (the same values), the rows and columns of constrained DOFs zero and their diagonal a
    given value (as ``assemble_matrix(..., bcs, diagonal)``), into a PETSc matrix of the
    form's pattern (``create_matrix(form)``) by one ``setValuesCSR``, or written in place into
    a matrix of ``create_matrix``: no per-cell insertion.

    Args:
        form: the compiled form (its pattern and its test space's cell DOFs).
    """

    def __init__(self, form: Any) -> None:
        from dolfinx import fem

        pattern = fem.create_matrix(form)  # the CSR order of PETSc's matrices too
        indptr, indices = pattern.indptr.copy(), pattern.indices.copy()
        n = len(indptr) - 1
        rows = np.repeat(np.arange(n), np.diff(indptr))
        keys = rows.astype(np.int64) * n + indices
        dm = form.function_spaces[0].dofmap
        cells = np.asarray(dm.list if hasattr(dm, "list") else dm.map()).astype(np.int64)
        bs = dm.bs
        if bs > 1:  # blocked dofmap: each node's bs DOFs
            cells = (cells[:, :, None] * bs + np.arange(bs)).reshape(len(cells), -1)
        k = cells.shape[1]
        ekeys = (np.repeat(cells, k, axis=1) * n + np.tile(cells, (1, k))).ravel()
        pos = np.searchsorted(keys, ekeys)
        if not np.array_equal(keys[np.minimum(pos, len(keys) - 1)], ekeys):
            raise ValueError("an element entry outside the form's pattern")
        self._indptr, self._indices = indptr.astype(np.int32), indices.astype(np.int32)
        self._pos, self._rows = np.ascontiguousarray(pos, dtype=np.int64), rows
        lib = library()
        self._lib, self._ffi = lib.lib, lib.ffi
        self._masks: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

    def set(self, A: Any, elements: np.ndarray, constrained: np.ndarray,
            diagonal: float = 1.0) -> None:
        """A's values from ``elements`` (cells x n x n, rows in the dofmap's order), the
        ``constrained`` DOFs' rows and columns zero and their diagonal ``diagonal``;
        assembled."""
        own = A.getAttr(_VALUES)
        if own is None or own.shape != (len(self._indices),):
            own = None
        values = np.empty(len(self._indices)) if own is None else own
        w = np.ascontiguousarray(elements, dtype=np.float64).reshape(-1)
        if w.size != self._pos.size:
            raise ValueError("element matrices of another shape than the form's")
        ffi = self._ffi
        self._lib.scatter_add(w.size, ffi.cast("const long*", ffi.from_buffer(self._pos)),
                              ffi.cast("const double*", ffi.from_buffer(w)), values.size,
                              ffi.cast("double*", ffi.from_buffer(values)))
        key = np.asarray(constrained).tobytes()
        if key not in self._masks:
            cons = np.asarray(constrained)
            hit = np.isin(self._rows, cons)
            self._masks[key] = (np.nonzero(hit | np.isin(self._indices, cons))[0],
                                np.nonzero(hit & (self._rows == self._indices))[0])
        zero, diag = self._masks[key]
        values[zero] = 0.0
        values[diag] = diagonal
        if own is None:  # written in place where the matrix's own value array is at hand
            A.setValuesCSR(self._indptr, self._indices, values)
        A.assemble()  # also marks the values changed, for a factorisation's reuse test

    def create_matrix(self) -> Any:
        """A sequential AIJ matrix of the form's pattern whose value array is a numpy array
        ``set`` writes in place (``setValuesCSR`` costs many times the write; docs/design-notes.md,
        "The 1D model's assembly"), with identity local-to-global maps (dolfinx's assembler can
        still assemble into it)."""
        from petsc4py import PETSc

        n = len(self._indptr) - 1
        values = np.zeros(len(self._indices))
        A = PETSc.Mat().createAIJWithArrays([n, n], (self._indptr, self._indices, values),
                                            comm=PETSc.COMM_SELF)
        lg = PETSc.LGMap().create(np.arange(n, dtype=PETSc.IntType), comm=PETSc.COMM_SELF)
        A.setLGMap(lg, lg)
        lg.destroy()
        A.setAttr(_VALUES, values)
        A.assemble()
        return A


def _weights(E: np.ndarray, powers: np.ndarray, own: list[int]) -> np.ndarray:
    """(blocks, forms): block b's matrix is Σ_f weights[b, f] E[f]: E[own[b]] where
    own[b] ≥ 0, else Σ_k powers[b, k] E[k]."""
    powers = np.atleast_2d(np.asarray(powers, dtype=np.float64))
    nf, nk = len(E), powers.shape[1]
    if len(powers) != len(own) or nk > nf or any(o >= nf for o in own):
        raise ValueError("inconsistent blocks")
    weights = np.zeros((len(own), nf))
    for b, o in enumerate(own):
        if o >= 0:
            weights[b, o] = 1.0
        else:
            weights[b, :nk] = powers[b]
    return weights


class ChainCholesky:
    """Positive definiteness by a margin of symmetric matrices assembled from element matrices
    on a chain of cells (module docstring): ``definite(E, powers, own, constrained, margin)``,
    and their Schur complements on the vertex DOFs (``schur``).

    Args (construction):
        cell_dofs: (cells, n) global DOF of each element row (one process: local = global).
        vertex_dofs: two lists of the element rows on the cell's two vertices.
        interior_dofs: the element rows of DOFs that belong to the cell alone.
    """

    def __init__(self, cell_dofs: np.ndarray, vertex_dofs: tuple[list[int], list[int]],
                 interior_dofs: list[int]) -> None:
        cell_dofs = np.asarray(cell_dofs)
        ncells = len(cell_dofs)
        ends = np.empty((ncells, 2), dtype=np.int64)
        vertex_of: dict[tuple[int, ...], int] = {}
        for c in range(ncells):
            for s in (0, 1):
                key = tuple(sorted(int(d) for d in cell_dofs[c, vertex_dofs[s]]))
                ends[c, s] = vertex_of.setdefault(key, len(vertex_of))
        nv = len(vertex_of)
        if nv != ncells + 1:
            raise ValueError("the cells do not form one chain")
        # walk the chain from a vertex of one cell
        cells_at: list[list[int]] = [[] for _ in range(nv)]
        for c in range(ncells):
            for s in (0, 1):
                cells_at[ends[c, s]].append(c)
        starts = [v for v in range(nv) if len(cells_at[v]) == 1]
        if len(starts) != 2 or any(len(x) > 2 for x in cells_at):
            raise ValueError("the cells do not form one chain")
        order, flip, seen = [], [], set()
        v = starts[0]
        while True:
            nxt = [c for c in cells_at[v] if c not in seen]
            if not nxt:
                break
            c = nxt[0]
            seen.add(c)
            order.append(c)
            flip.append(ends[c, 0] != v)
            v = ends[c, 1] if ends[c, 0] == v else ends[c, 0]
        if len(order) != ncells:
            raise ValueError("the cells do not form one chain")
        self.order = np.asarray(order)
        nvd = len(vertex_dofs[0])
        self.nvd = nvd
        # element rows of the chain's lower and upper vertex of each cell (in chain order), each
        # in the order of its global DOFs (the same order from both cells that share a vertex)
        rows = np.empty((ncells, 2 * nvd), dtype=np.int64)
        for p, (c, f) in enumerate(zip(self.order, flip, strict=True)):
            lo, hi = (vertex_dofs[1], vertex_dofs[0]) if f else (vertex_dofs[0], vertex_dofs[1])
            for s, loc in enumerate((lo, hi)):
                loc = np.asarray(loc)
                rows[p, s * nvd:(s + 1) * nvd] = loc[np.argsort(cell_dofs[c, loc])]
        self.vertex_rows = rows
        self.interior_rows = np.asarray(interior_dofs)
        # position of every vertex DOF in the condensed matrix: chain vertex p, then DOF order
        self.position: dict[int, int] = {}
        for p, c in enumerate(self.order):
            for j, r in enumerate(rows[p]):
                self.position[int(cell_dofs[c, r])] = p * nvd + j
        self.size = nv * nvd
        self.kd = 2 * nvd - 1
        self._constraint_cache: dict[Any, tuple[np.ndarray, np.ndarray]] = {}
        self._schur_pattern: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._cell_dofs = cell_dofs
        self._solve_maps: tuple[np.ndarray, np.ndarray] | None = None  # ``factor``'s
        self._order = np.ascontiguousarray(self.order, dtype=np.intc)
        self._irow = np.ascontiguousarray(np.tile(self.interior_rows, (ncells, 1)), dtype=np.intc)
        self._vrow = np.ascontiguousarray(rows, dtype=np.intc)
        self._lanes: np.ndarray | None = None  # ``definite``'s work space

    def constraint_indices(self, dofs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Band positions of the rows and columns of constrained DOFs, and of their diagonal."""
        key = dofs.tobytes()
        if key not in self._constraint_cache:
            try:
                pos = np.array(sorted(self.position[int(d)] for d in dofs), dtype=np.int64)
            except KeyError as e:
                raise ValueError("a constrained DOF is not on a vertex") from e
            kd1 = self.kd + 1
            flat = []
            for q in pos:
                for off in range(self.kd + 1):  # column q: rows q..q+kd; row q: cols q-kd..q
                    if q + off < self.size:
                        flat.append(off + q * kd1)
                    if q - off >= 0:
                        flat.append(off + (q - off) * kd1)
            self._constraint_cache[key] = (np.unique(np.asarray(flat, dtype=np.int64)),
                                           pos * kd1)
        return self._constraint_cache[key]

    def definite(self, E: np.ndarray, powers: np.ndarray, own: list[int],
                 constrained: list[np.ndarray], margin: float) -> list[bool]:
        """For each block b: is the matrix assembled from the element matrices
        A_b = E[own[b]] (own[b] ≥ 0) or Σ_k powers[b, k] E[k] (E: forms x cells x n x n),
        with the DOFs ``constrained[b]`` set to unit rows and columns, such that H - margin
        diag(H) has a Cholesky factor? (Then H is positive definite; NaN or a non-positive
        pivot: False.) The condensation, the constraints and the banded Cholesky (the
        left-looking algorithm of LAPACK's ``dpbtrf``) of every block in one C call
        (``definite_chain``: four or eight blocks in lockstep, one per SIMD lane, each with
        the arithmetic it would have alone)."""
        if len(powers) != len(own) or len(own) != len(constrained):
            raise ValueError("inconsistent blocks")
        if len(own) == 0:
            return []
        nb = len(own)
        E = np.ascontiguousarray(E, dtype=np.float64)
        weights = _weights(E, powers, own)
        nf = len(E)
        lib = library()
        ffi = lib.ffi
        ptr = lambda a, t: ffi.cast(t, ffi.from_buffer(a))  # noqa: E731
        zs, ds = [], []
        for b in range(nb):
            zero, diagonal = self.constraint_indices(np.asarray(constrained[b]))
            zs.append(zero)
            ds.append(diagonal)
        zero = np.ascontiguousarray(np.concatenate(zs), dtype=np.int64)
        diag = np.ascontiguousarray(np.concatenate(ds), dtype=np.int64)
        zero_start = np.ascontiguousarray(np.cumsum([0] + [len(z) for z in zs]), dtype=np.int64)
        diag_start = np.ascontiguousarray(np.cumsum([0] + [len(d) for d in ds]), dtype=np.int64)
        if self._lanes is None:
            self._lanes = np.empty((self.kd + 1) * self.size * max(_WIDTHS))
        ok = np.zeros(nb, dtype=np.intc)
        test = getattr(lib.lib, f"definite_chain_l{_lanes_for(nb)}")
        test(nb, E.shape[1], E.shape[2], nf, ptr(E, "double*"),
             ptr(weights, "double*"), ptr(self._order, "int*"),
             self._irow.shape[1], ptr(self._irow, "int*"),
             self._vrow.shape[1], ptr(self._vrow, "int*"), 1.0 - margin,
             self.size, ptr(self._lanes, "double*"), ptr(zero, "long*"),
             ptr(zero_start, "long*"), ptr(diag, "long*"),
             ptr(diag_start, "long*"), ptr(ok, "int*"))
        return [bool(v) for v in ok]

    def _condense(self, E: np.ndarray, powers: np.ndarray, own: list[int], scale: float,
                  keep: tuple[np.ndarray, np.ndarray] | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
        """C ``condense_chain`` for the blocks A_b = E[own[b]] (own[b] ≥ 0) or
        Σ_k powers[b, k] E[k], their diagonals scaled by ``scale``: their Schur complements
        (blocks x lower band storage, no conditions applied) and which failed (an interior
        block not positive definite). ``keep`` (one block only): arrays (cells x ni x ni,
        cells x ni x nv) that receive the cells' interior factors."""
        lib = library()
        ffi = lib.ffi
        E = np.ascontiguousarray(E, dtype=np.float64)
        ncells, n = E.shape[1], E.shape[2]
        weights = _weights(E, powers, own)
        nb = len(weights)
        if keep is not None and nb != 1:
            raise ValueError("inconsistent blocks")
        ab = np.empty((nb, (self.kd + 1) * self.size))
        failed = np.zeros(nb, dtype=np.intc)
        ptr = lambda a, t: ffi.cast(t, ffi.from_buffer(a))  # noqa: E731
        kl, ky = ((ptr(keep[0], "double*"), ptr(keep[1], "double*")) if keep is not None
                  else (ffi.NULL, ffi.NULL))
        condense = getattr(lib.lib, f"condense_chain_l{_lanes_for(nb)}")
        condense(nb, ncells, n, len(E), ptr(E, "double*"),
                 ptr(weights, "double*"), ptr(self._order, "int*"),
                 self._irow.shape[1], ptr(self._irow, "int*"),
                 self._vrow.shape[1], ptr(self._vrow, "int*"), scale,
                 ptr(ab, "double*"), self.size, ptr(failed, "int*"), kl, ky)
        return ab, failed

    def _condensed(self, E: np.ndarray, powers: np.ndarray, own: int, constrained: np.ndarray,
                   keep: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray | None:
        """One block's Schur complement on the vertex DOFs (no margin), with its conditions, in
        lower band storage; None if an interior block is not positive definite. ``keep``:
        arrays (cells x ni x ni, cells x ni x nv) that receive the cells' interior factors."""
        return self._condensed_blocks(E, powers, [own], [constrained], keep)[0]

    def _condensed_blocks(self, E: np.ndarray, powers: np.ndarray, own: list[int],
                          constrained: list[np.ndarray],
                          keep: tuple[np.ndarray, np.ndarray] | None = None
                          ) -> list[np.ndarray | None]:
        """``_condensed`` of several blocks (``powers`` one row per block; ``keep``: one block
        only), condensed in one C call."""
        ab, failed = self._condense(E, powers, list(own), 1.0, keep)
        out: list[np.ndarray | None] = []
        for b, band in enumerate(ab):
            if failed[b] or not np.isfinite(band).all():
                out.append(None)
                continue
            zero, diagonal = self.constraint_indices(np.asarray(constrained[b]))
            band[zero] = 0.0
            band[diagonal] = 1.0
            out.append(band)
        return out

    def eliminated(self) -> int:
        """How many interior DOFs the condensation eliminates."""
        return len(self.interior_rows) * len(self.order)

    def schur(self, E: np.ndarray, powers: np.ndarray, own: int, constrained: np.ndarray
              ) -> tuple[np.ndarray, int] | None:
        """The Schur complement S of one block (element matrices as in ``definite``, no margin)
        on the vertex DOFs, with the block's conditions, as CSR values in the pattern
        ``schur_pattern``, and the number of eliminated interior DOFs; None if an interior
        block is not positive definite. Haynsworth: the block's inertia is S's with that many
        more positive eigenvalues."""
        ab = self._condensed(E, powers, own, constrained)
        if ab is None:
            return None
        _, _, source = self.schur_pattern()
        return ab[source], self.eliminated()

    def inertia(self, E: np.ndarray, powers: np.ndarray, own: int, constrained: np.ndarray,
                growth: float) -> tuple[int, int, int] | None:
        """(negative, zero, positive) eigenvalue counts of one block (as in ``schur``): the
        Schur complement's by its LDLᵀ without pivoting (C ``band_ldlt``), plus the eliminated
        DOFs' positive ones (Haynsworth). None where that factorisation cannot vouch for the
        count (a zero pivot, or a diagonal of |L||D||Lᵀ| above ``growth`` times the matrix's:
        then its backward error may exceed (kd + 1) ε ``growth`` of the diagonally scaled
        matrix), or an interior block is not positive definite: the caller then asks MUMPS."""
        return self.inertias(E, powers, [own], [constrained], growth)[0]

    def inertias(self, E: np.ndarray, powers: np.ndarray, own: list[int],
                 constrained: list[np.ndarray], growth: float
                 ) -> list[tuple[int, int, int] | None]:
        """``inertia`` of several blocks (``powers`` one row per block), their condensations in
        one C call, four or eight blocks in lockstep with the arithmetic each has alone (the
        same counts as one at a time, at a fraction of the cost)."""
        if len(powers) != len(own) or len(own) != len(constrained):
            raise ValueError("inconsistent blocks")
        if not own:
            return []
        lib = library()
        ffi = lib.ffi
        out: list[tuple[int, int, int] | None] = []
        for band in self._condensed_blocks(E, powers, own, constrained):
            if band is None:
                out.append(None)
                continue
            counts = np.zeros(2, dtype=np.intc)
            status = lib.lib.band_ldlt(ffi.cast("double*", ffi.from_buffer(band)), self.size,
                                       self.kd, float(growth),
                                       ffi.cast("int*", ffi.from_buffer(counts)))
            out.append(None if status != 0 else
                       (int(counts[0]), 0, int(counts[1]) + self.eliminated()))
        return out

    def factor(self, E: np.ndarray, powers: np.ndarray, own: int, constrained: np.ndarray
               ) -> ChainLU | None:
        """A factorisation of one block (as in ``schur``) for solves (``ChainLU``); None if an
        interior block is not positive definite or the condensed matrix is singular."""
        ncells, ni, nv = len(self.order), len(self.interior_rows), 2 * self.nvd
        keep = (np.empty((ncells, ni, ni)), np.empty((ncells, ni, nv)))
        ab = self._condensed(E, powers, own, constrained, keep)
        if ab is None:
            return None
        if self._solve_maps is None:
            dofs = self._cell_dofs[self.order]
            idof = np.ascontiguousarray(dofs[:, self.interior_rows], dtype=np.intc)
            vdof = np.empty(self.size, dtype=np.intc)
            for d, q in self.position.items():
                vdof[q] = d
            self._solve_maps = (idof, vdof)
        fixed = np.zeros(self.size, dtype=np.int8)
        fixed[[self.position[int(d)] for d in constrained]] = 1
        return ChainLU(self, ab, keep, fixed)

    def schur_pattern(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """CSR (indptr, indices) of the band's full symmetric storage, and for each entry its
        position in the lower band storage."""
        if self._schur_pattern is None:
            kd, kd1, size = self.kd, self.kd + 1, self.size
            rows = np.arange(size)
            first = np.maximum(0, rows - kd)  # row i holds columns first[i] .. last[i] - 1
            counts = np.minimum(size, rows + kd + 1) - first
            indptr = np.concatenate([[0], np.cumsum(counts)])
            i = np.repeat(rows, counts)
            j = np.arange(indptr[-1]) - np.repeat(indptr[:-1] - first, counts)
            source = np.where(i >= j, (i - j) + j * kd1, (j - i) + i * kd1)
            self._schur_pattern = (indptr.astype(np.int32), j.astype(np.int32),
                                   source.astype(np.int64))
        return self._schur_pattern


class ChainLU:
    """Solves with one block factored on the chain (``ChainCholesky.factor``): each cell's
    interior DOFs by their Cholesky factor, the vertex Schur complement by LAPACK's banded LU
    with partial pivoting (``dgbtrf``, half-bandwidth 11 for the 1D model's Fourier blocks):
    H x = b to the accuracy of a backward stable factorisation, faster than MUMPS on the
    assembled block (the shift-invert eigensolves' operator; docs/model.md, "Stability and
    critical points")."""

    def __init__(self, chain: ChainCholesky, ab: np.ndarray,
                 keep: tuple[np.ndarray, np.ndarray], fixed: np.ndarray) -> None:
        kd, size = chain.kd, chain.size
        lower = ab.reshape(size, kd + 1).T  # lower[i - j, j] = A[i, j], i >= j
        # general band storage for dgbtrf, column-major (column j = row j of g here): A[i, j]
        # at row 2 kd + i - j (kl = ku = kd, plus kd rows of fill-in above). Not scipy's
        # wrapper: importing scipy.linalg is a noticeable share of a short 1D run
        # (docs/design-notes.md, "The 1D model's assembly")
        g = np.zeros((size, 3 * kd + 1))
        for d in range(kd + 1):
            g[: size - d, 2 * kd + d] = lower[d, : size - d]  # below the diagonal: A[j + d, j]
            g[d:, 2 * kd - d] = lower[d, : size - d]  # above: A[j, j + d] = A[j + d, j]
        lib = library()
        piv = np.zeros(size, dtype=np.intc)
        info = lib.lib.band_lu(lib.ffi.cast("double*", lib.ffi.from_buffer(g)), size, kd,
                               lib.ffi.cast("int*", lib.ffi.from_buffer(piv)))
        self.ok = int(info) == 0 and bool(np.isfinite(g).all())
        self._lu = g  # LAPACK's column-major storage, row by row
        self._piv = piv  # 1-based
        lf, y = keep
        self._z = np.empty(lf.shape[0] * lf.shape[1])
        self._bv = np.empty(size)
        ffi = lib.ffi
        ptr = lambda a, t: ffi.cast(t, ffi.from_buffer(a))  # noqa: E731
        idof, vdof = chain._solve_maps
        self._keep = (lf, y, fixed, idof, vdof)  # alive as long as the pointers below
        self._args = (lf.shape[0], lf.shape[1], y.shape[2], ptr(lf, "double*"), ptr(y, "double*"),
                      ptr(idof, "int*"), ptr(vdof, "int*"), ptr(fixed, "char*"), size,
                      ptr(self._lu, "double*"), ptr(self._piv, "int*"))
        self._work = (ptr(self._z, "double*"), ptr(self._bv, "double*"))

    def solve(self, b: np.ndarray, x: np.ndarray) -> None:
        """x = H^-1 b (arrays of the block's local DOFs, one process; x C-contiguous)."""
        lib = library()
        ffi = lib.ffi
        b = np.ascontiguousarray(b, dtype=np.float64)
        if not (x.flags.c_contiguous and x.dtype == np.float64 and x.shape == b.shape):
            raise ValueError("x must be a contiguous float64 array like b")
        lib.lib.chain_solve(*self._args, ffi.cast("double*", ffi.from_buffer(b)),
                            *self._work, ffi.cast("double*", ffi.from_buffer(x)))
