"""Tiny algebraic problems with exact answers, for testing the algorithm layer in milliseconds
(problem layer; implements ``shells.problem.interface.Problem``).

Both are gradient systems, R = ∂E/∂w, so their Jacobians are symmetric Hessians whose inertia
decides stability exactly as for the shell models. The state is a PETSc vector on ``comm``
(default MPI.COMM_SELF: every rank solves its own copy in milliseconds; a communicator of
several ranks distributes the few unknowns, which exercises the algorithms' reductions, at the
price of a parallel factorisation per solve).

* ``FoldProblem`` (a limit point): E = x³/3 + (s λ - 1) x + (k/2) Σ_i (y_i - x)², i.e.
  R_x = x² + s λ - 1 - k Σ (y_i - x), R_yi = k (y_i - x). Branch: y_i = x, x² = 1 - s λ; from
  x = 1 at λ = 0 the stable half (x > 0, Hessian Schur complement 2x) turns at the fold
  λ = s (x = 0) onto the unstable half. ``sign`` s = +1 puts the fold at κ = +1, s = -1 at
  κ = -1.
* ``PitchforkProblem`` (a supercritical pitchfork): E = ½ (y - λ)² + ½ (1 - y) x² + ¼ x⁴ +
  Σ_i [½ (c_i - y) z_i² + ¼ z_i⁴]. Fundamental branch x = z = 0, y = λ, stable below λ = 1,
  where the x-direction loses stability (the z_i at λ = c_i). The bifurcated branch
  x² = 2 (λ - 1), y = 2λ - 1 is stable (Hessian [[1, -x], [-x, 2x²]] for λ < (c_1 + 1)/2) and
  lies below the fundamental one, E = -(λ - 1)²/2.

* ``SubcriticalPitchforkProblem``: the pitchfork with x's quartic term negative and a sextic
  one, ½ (1 - y) x² - ¼ x⁴ + ⅙ x⁶: the bifurcated branch y = κ + x²/2,
  κ = 1 - 3x²/2 + x⁴ goes down from κ = 1, unstable (Hessian Schur complement x² (4x² - 3)),
  to a fold at x² = 3/4, κ = 7/16, and up again stable: a branch that a parameter of the state
  (x) follows through the fold in κ.

* ``FoldPitchforkProblem`` (two stability blocks, like the Fourier blocks of the axisymmetric
  model): E = x³/3 + (λ - 1) x + ½ (c - λ) z² + ¼ z⁴. Branch z = 0, x = sqrt(1 - λ): block 0
  (x) has its fold at λ = 1, block 1 (z) a pitchfork at λ = c < 1 just before it, so that
  both fall in one continuation step.

* ``RingValleyProblem`` (a neutral orbit that a discretisation pins weakly, like a pattern's
  rotation about a shell's axis on a mesh): E = ¼ (r² - (1 + λ)²)² + ε (x⁴ - 6 x²y² + y⁴) +
  ½ c (z - r²)², r² = x² + y². At ε = 0 every state turned about the origin has the same
  energy, and the minima form the circle r = 1 + λ, z = r²; ε > 0 pins the angle φ weakly
  (ε r⁴ cos 4φ: minima at φ = π/4 + kπ/2), c ≫ 1 is a stiff unknown. Orbit tangent
  (-y, x, 0) (``OrbitTangents``); along it the gradient is -4 ε r⁴ sin 4φ / r per unit
  length.

L = 1 and the state scale is 1, so κ = λ.
"""

from __future__ import annotations

import math
from collections.abc import Hashable
from typing import Any

import numpy as np

from shells.problem.interface import ModeInfo

__all__ = ["AlgebraicProblem", "FoldProblem", "FoldPitchforkProblem", "PitchforkProblem",
           "RingValleyProblem", "SubcriticalPitchforkProblem"]


class AlgebraicProblem:
    """A gradient system E(w, κ) of a few unknowns on PETSc objects (``shells.problem.interface``).

    Subclasses give ``energy(w, k)``, ``gradient(w, k)``, ``hessian(w, k)`` and
    ``dgradient_dkappa(w, k)`` on the full (gathered) state, as numpy arrays; the owned rows
    are set on each rank. One stability block (``None``); mode m: the index of the largest
    component of the mode among ``mode_unknowns``.
    """

    mode_unknowns: tuple[int, ...] = ()
    #: stability blocks (Fourier-like): label -> the unknowns whose Hessian block it is;
    #: empty: one block, ``None``, the whole Hessian
    block_unknowns: dict[int, tuple[int, ...]] = {}

    def __init__(self, n: int, initial: np.ndarray, comm: Any = None) -> None:
        from mpi4py import MPI
        from petsc4py import PETSc

        self.comm = MPI.COMM_SELF if comm is None else comm
        self.n = n
        self._state = PETSc.Vec().createMPI(n, comm=self.comm)
        self.lo, self.hi = self._state.getOwnershipRange()
        self._state.array_w[:] = initial[self.lo:self.hi]
        self._kappa = 0.0
        self._scatter, self._full = PETSc.Scatter.toAll(self._state)

    # -- state and parameter ---------------------------------------------------------------------
    @property
    def state(self) -> Any:
        return self._state

    def sync(self) -> None:
        pass  # no ghosts

    def get_kappa(self) -> float:
        return self._kappa

    def set_kappa(self, kappa: float) -> None:
        self._kappa = float(kappa)

    def length_scale(self) -> float:
        return 1.0

    def state_scale(self) -> float:
        return 1.0

    def num_dofs(self) -> int:
        return self.n

    def gathered(self, v: Any = None) -> np.ndarray:
        """The whole vector (default: the state) on every rank."""
        from petsc4py import PETSc

        self._scatter.scatter(self._state if v is None else v, self._full,
                              addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        return self._full.array_r.copy()

    # -- assembly --------------------------------------------------------------------------------
    def create_vector(self) -> Any:
        return self._state.duplicate()

    def create_jacobian(self) -> Any:
        from petsc4py import PETSc

        A = PETSc.Mat().createAIJ(((self.hi - self.lo, self.n), (self.hi - self.lo, self.n)),
                                  nnz=(self.n, self.n), comm=self.comm)
        A.setUp()
        return A

    def _set_rows(self, b: Any, full: np.ndarray) -> None:
        b.array_w[:] = full[self.lo:self.hi]

    def assemble_residual(self, b: Any) -> None:
        self._set_rows(b, self.gradient(self.gathered(), self._kappa))

    def assemble_dkappa(self, b: Any) -> None:
        self._set_rows(b, self.dgradient_dkappa(self.gathered(), self._kappa))

    def assemble_jacobian(self, A: Any) -> None:
        self._set_matrix(A, self.hessian(self.gathered(), self._kappa))

    def _set_matrix(self, A: Any, dense: np.ndarray) -> None:
        from petsc4py import PETSc

        A.zeroEntries()
        rows = np.arange(self.lo, self.hi, dtype=PETSc.IntType)
        cols = np.arange(self.n, dtype=PETSc.IntType)
        A.setValues(rows, cols, dense[self.lo:self.hi], addv=PETSc.InsertMode.INSERT_VALUES)
        A.assemble()

    def zero_constrained(self, v: Any) -> None:
        pass  # no gauge

    # -- scalars and stability -------------------------------------------------------------------
    def total_energy(self) -> float:
        """E at the current state (``shells.problem.interface.Energy``)."""
        return float(self.energy(self.gathered(), self._kappa))

    def scalars(self) -> dict[str, float]:
        w = self.gathered()
        out = {"energy": float(self.energy(w, self._kappa))}
        out.update({f"w{i}": float(v) for i, v in enumerate(w)})
        return out

    def stability_blocks(self) -> tuple[Hashable, ...]:
        return tuple(self.block_unknowns) if self.block_unknowns else (None,)

    def block_layout(self, block: Hashable) -> Hashable:
        return block

    def _block_matrix(self, block: Hashable) -> Any:
        from petsc4py import PETSc

        if block is None:
            return self.create_jacobian()
        m = len(self.block_unknowns[block])
        A = PETSc.Mat().createAIJ(((PETSc.DECIDE, m), (PETSc.DECIDE, m)), nnz=(m, m),
                                  comm=self.comm)
        A.setUp()
        return A

    def _set_block(self, A: Any, block: Hashable, dense: np.ndarray) -> None:
        from petsc4py import PETSc

        if block is None:
            self._set_matrix(A, dense)
            return
        idx = np.asarray(self.block_unknowns[block])
        sub = dense[np.ix_(idx, idx)]
        lo, hi = A.getOwnershipRange()
        A.zeroEntries()
        A.setValues(np.arange(lo, hi, dtype=PETSc.IntType),
                    np.arange(idx.size, dtype=PETSc.IntType), sub[lo:hi],
                    addv=PETSc.InsertMode.INSERT_VALUES)
        A.assemble()

    def create_hessian(self, block: Hashable) -> Any:
        return self._block_matrix(block)

    def assemble_hessian(self, block: Hashable, H: Any) -> None:
        self._set_block(H, block, self.hessian(self.gathered(), self._kappa))
        H.setOption(H.Option.SYMMETRIC, True)

    def assemble_mass(self, block: Hashable) -> Any:
        M = self._block_matrix(block)
        self._set_block(M, block, np.eye(self.n))
        return M

    def assemble_kinetic_mass(self, block: Hashable) -> Any:
        """The identity: a unit mass on every unknown (``KineticMass``)."""
        return self.assemble_mass(block)

    def free_motion(self, block: Hashable, v: Any) -> Any:
        """No gauge, no rigid motion: a copy of v (``KineticMass``)."""
        return v.copy()

    def classify_mode(self, vec: Any, block: Hashable) -> ModeInfo:
        if block is not None:
            return ModeInfo(m=int(block))
        v = np.abs(self.gathered(vec))
        if not self.mode_unknowns:
            return ModeInfo()
        k = max(range(len(self.mode_unknowns)), key=lambda i: v[self.mode_unknowns[i]])
        return ModeInfo(m=k + 1, n=None, rayleigh={"share": float(
            v[self.mode_unknowns[k]] ** 2 / max(float(v @ v), 1e-300))})

    # -- the system ------------------------------------------------------------------------------
    def energy(self, w: np.ndarray, k: float) -> float:
        raise NotImplementedError

    def gradient(self, w: np.ndarray, k: float) -> np.ndarray:
        raise NotImplementedError

    def hessian(self, w: np.ndarray, k: float) -> np.ndarray:
        raise NotImplementedError

    def dgradient_dkappa(self, w: np.ndarray, k: float) -> np.ndarray:
        raise NotImplementedError


class FoldProblem(AlgebraicProblem):
    """x² + s κ - 1 = 0 with ``springs`` unknowns y_i tied to x (see the module docstring)."""

    def __init__(self, sign: float = 1.0, springs: int = 2, stiffness: float = 3.0,
                 comm: Any = None) -> None:
        self.s = 1.0 if sign >= 0 else -1.0
        self.k = stiffness
        super().__init__(1 + springs, np.ones(1 + springs), comm)

    def fold_kappa(self) -> float:
        return self.s

    def energy(self, w: np.ndarray, k: float) -> float:
        x, y = w[0], w[1:]
        return x**3 / 3 + (self.s * k - 1) * x + 0.5 * self.k * float(np.sum((y - x) ** 2))

    def gradient(self, w: np.ndarray, k: float) -> np.ndarray:
        x, y = w[0], w[1:]
        g = np.empty_like(w)
        g[0] = x * x + self.s * k - 1 - self.k * float(np.sum(y - x))
        g[1:] = self.k * (y - x)
        return g

    def hessian(self, w: np.ndarray, k: float) -> np.ndarray:
        n = w.size
        H = np.zeros((n, n))
        H[0, 0] = 2 * w[0] + self.k * (n - 1)
        H[0, 1:] = H[1:, 0] = -self.k
        H[np.arange(1, n), np.arange(1, n)] = self.k
        return H

    def dgradient_dkappa(self, w: np.ndarray, k: float) -> np.ndarray:
        d = np.zeros_like(w)
        d[0] = self.s
        return d

    def exact_x(self, kappa: float) -> float:
        """x on the stable half of the branch."""
        return math.sqrt(max(1.0 - self.s * kappa, 0.0))


class PitchforkProblem(AlgebraicProblem):
    """Unknowns (y, x, z_1 ... z_k): a supercritical pitchfork at κ = 1 in x, further
    bifurcations at κ = c_i in z_i (see the module docstring)."""

    def __init__(self, c: tuple[float, ...] = (2.0, 3.0), comm: Any = None) -> None:
        self.c = np.asarray(c, dtype=float)
        self.mode_unknowns = tuple(range(1, 2 + len(c)))
        super().__init__(2 + len(c), np.zeros(2 + len(c)), comm)

    kappa_c = 1.0

    def energy(self, w: np.ndarray, k: float) -> float:
        y, x, z = w[0], w[1], w[2:]
        return float(0.5 * (y - k) ** 2 + 0.5 * (1 - y) * x * x + 0.25 * x**4
                     + np.sum(0.5 * (self.c - y) * z * z + 0.25 * z**4))

    def gradient(self, w: np.ndarray, k: float) -> np.ndarray:
        y, x, z = w[0], w[1], w[2:]
        g = np.empty_like(w)
        g[0] = (y - k) - 0.5 * x * x - 0.5 * float(np.sum(z * z))
        g[1] = (1 - y) * x + x**3
        g[2:] = (self.c - y) * z + z**3
        return g

    def hessian(self, w: np.ndarray, k: float) -> np.ndarray:
        y, x, z = w[0], w[1], w[2:]
        n = w.size
        H = np.zeros((n, n))
        H[0, 0] = 1.0
        H[0, 1] = H[1, 0] = -x
        H[0, 2:] = H[2:, 0] = -z
        H[1, 1] = 1 - y + 3 * x * x
        H[np.arange(2, n), np.arange(2, n)] = self.c - y + 3 * z * z
        return H

    def dgradient_dkappa(self, w: np.ndarray, k: float) -> np.ndarray:
        d = np.zeros_like(w)
        d[0] = -1.0
        return d


class SubcriticalPitchforkProblem(PitchforkProblem):
    """``PitchforkProblem`` with the x-terms ½ (1 - y) x² - ¼ x⁴ + ⅙ x⁶: a subcritical
    pitchfork at κ = 1 whose branch κ = 1 - 3x²/2 + x⁴ turns at the fold x² = 3/4, κ = 7/16
    (see the module docstring)."""

    def energy(self, w: np.ndarray, k: float) -> float:
        x = w[1]
        return super().energy(w, k) - 0.5 * x**4 + x**6 / 6

    def gradient(self, w: np.ndarray, k: float) -> np.ndarray:
        g = super().gradient(w, k)
        x = w[1]
        g[1] += -2 * x**3 + x**5
        return g

    def hessian(self, w: np.ndarray, k: float) -> np.ndarray:
        H = super().hessian(w, k)
        x = w[1]
        H[1, 1] += -6 * x * x + 5 * x**4
        return H


class FoldPitchforkProblem(AlgebraicProblem):
    """Unknowns (x, z), blocks 0 = {x} and 1 = {z}: a pitchfork in z at κ = c, then the fold of
    x² = 1 - κ at κ = 1 (see the module docstring)."""

    block_unknowns = {0: (0,), 1: (1,)}

    def __init__(self, c: float = 0.995, comm: Any = None) -> None:
        self.c = float(c)
        super().__init__(2, np.array([1.0, 0.0]), comm)

    def energy(self, w: np.ndarray, k: float) -> float:
        x, z = w
        return float(x**3 / 3 + (k - 1) * x + 0.5 * (self.c - k) * z * z + 0.25 * z**4)

    def gradient(self, w: np.ndarray, k: float) -> np.ndarray:
        x, z = w
        return np.array([x * x + k - 1, (self.c - k) * z + z**3])

    def hessian(self, w: np.ndarray, k: float) -> np.ndarray:
        x, z = w
        return np.array([[2 * x, 0.0], [0.0, self.c - k + 3 * z * z]])

    def dgradient_dkappa(self, w: np.ndarray, k: float) -> np.ndarray:
        return np.array([1.0, -w[1]])


class RingValleyProblem(AlgebraicProblem):
    """The ring valley of the module docstring: unknowns (x, y, z).

    Args:
        eps: the pinning ε (0: an exactly neutral orbit).
        c: the stiff unknown's stiffness.
        initial: the start (x, y, z).
        comm: the communicator.
    """

    def __init__(self, eps: float = 1.0e-6, c: float = 1.0e4,
                 initial: tuple[float, float, float] = (1.3, 0.4, 1.0), comm: Any = None) -> None:
        self.eps, self.c = float(eps), float(c)
        super().__init__(3, np.asarray(initial, dtype=float), comm)

    def energy(self, w: np.ndarray, k: float) -> float:
        x, y, z = w
        s = x * x + y * y
        return (0.25 * (s - (1 + k) ** 2) ** 2 + self.eps * (x**4 - 6 * x * x * y * y + y**4)
                + 0.5 * self.c * (z - s) ** 2)

    def gradient(self, w: np.ndarray, k: float) -> np.ndarray:
        x, y, z = w
        s = x * x + y * y
        a, e, c = s - (1 + k) ** 2, self.eps, self.c
        return np.array([a * x + e * (4 * x**3 - 12 * x * y * y) - 2 * c * x * (z - s),
                         a * y + e * (4 * y**3 - 12 * x * x * y) - 2 * c * y * (z - s),
                         c * (z - s)])

    def hessian(self, w: np.ndarray, k: float) -> np.ndarray:
        x, y, z = w
        s = x * x + y * y
        a, e, c = s - (1 + k) ** 2, self.eps, self.c
        hxx = 2 * x * x + a + e * (12 * x * x - 12 * y * y) + 4 * c * x * x - 2 * c * (z - s)
        hyy = 2 * y * y + a + e * (12 * y * y - 12 * x * x) + 4 * c * y * y - 2 * c * (z - s)
        hxy = 2 * x * y - 24 * e * x * y + 4 * c * x * y
        return np.array([[hxx, hxy, -2 * c * x], [hxy, hyy, -2 * c * y],
                         [-2 * c * x, -2 * c * y, c]])

    def dgradient_dkappa(self, w: np.ndarray, k: float) -> np.ndarray:
        x, y, _ = w
        return np.array([-2 * (1 + k) * x, -2 * (1 + k) * y, 0.0])

    def orbit_tangents(self) -> list[Any]:
        """[(-y, x, 0)]: the state turned about the origin (``OrbitTangents``); [] at r = 0."""
        x, y, _ = self.gathered()
        if x == 0 and y == 0:
            return []
        t = self.create_vector()
        self._set_rows(t, np.array([-y, x, 0.0]))
        return [t]

    def classify_mode(self, vec: Any, block: Hashable) -> ModeInfo:
        """m = None; ``rayleigh["orbit"]``: the mode's |cos| with the orbit tangent."""
        v = self.gathered(vec)
        x, y, _ = self.gathered()
        t = np.array([-y, x, 0.0])
        cos = abs(float(v @ t)) / max(float(np.linalg.norm(v) * np.linalg.norm(t)), 1e-300)
        return ModeInfo(rayleigh={"orbit": cos})
