"""Natural frequencies of a shell about an equilibrium (algorithm layer): ``natural_frequencies``.

The small vibrations about an equilibrium w at κ solve H v = ω² M v per stability block, H the
block's Hessian (``Problem.assemble_hessian``) and M its kinetic mass
(``shells.problem.interface.KineticMass``): ω² in units of E/(ρ L²), L = ``length_scale()``,
i.e. ω in units of √(E/ρ)/L. The eigenpairs come from ``shells.algorithms.stability.Stability``
with the kinetic mass in place of the L² mass (the same shift-invert about 0, the same
Rayleigh-quotient refinement by quadrature): about a stable equilibrium the lowest ω².

The free shell's rigid motions. The static gauge fixes a few point values (the rigid-motion
gauge of each model), and the kinetic mass is that of the free shell's motion relative to its
centre of mass (``shells.problem.kinetic``): the six zero frequencies of the rigid motions are
removed and the elastic ones are those of the free shell, not of a shell held at its gauge
points. That needs the gauge to be neutral for the energy only (rigid motions cost no energy,
true of both models at an equilibrium), not for the motion: with the gauged L² mass instead,
a mode that moves a gauge point (the sphere's breathing mode moves its pole) would carry the
rigid motion that brings the point back, and its frequency would fall (by a factor √(1 -
M_rigid / M_total) for a breathing sphere pinned at its pole).

Followed along κ, ω² of a block falls to zero where the block loses stability (a fold or a
bifurcation): the frequencies measure the distance to a critical point (the
vibration-correlation technique). A negative ω² (an unstable equilibrium) is reported as a
negative ``omega`` = -√|ω²|.
"""

from __future__ import annotations

import math
from collections.abc import Hashable, Iterable
from dataclasses import asdict, dataclass
from typing import Any

from shells.algorithms.stability import Stability
from shells.errors import InputError
from shells.problem.interface import KineticMass

__all__ = ["Frequency", "KineticStability", "natural_frequencies"]


@dataclass(frozen=True)
class Frequency:
    """One natural frequency.

    Attributes:
        omega2: ω² in units of E/(ρ L²).
        omega: √ω² in units of √(E/ρ)/L (negative: -√|ω²|, an unstable direction).
        block: the stability block.
        mode_m: the mode's azimuthal wavenumber (None where undefined: a closed sphere's
            surface model, a surface not of revolution).
        mode_n: the spherical-harmonic degree on a closed sphere (else None).
    """

    omega2: float
    omega: float
    block: Hashable
    mode_m: int | None
    mode_n: int | None

    def as_dict(self) -> dict[str, Any]:
        """The fields as plain data."""
        return asdict(self)


class KineticStability(Stability):
    """``Stability`` whose eigenproblems take the problem's kinetic mass
    (``assemble_kinetic_mass``): eigenvalues ω²."""

    def mass(self, block: Hashable = None) -> Any:
        """The block's kinetic mass (assembled once per object, at the state it is first
        asked at)."""
        b = self.block_solvers(block)
        if block not in b.M:
            b.M[block] = self.problem.assemble_kinetic_mass(block)
        return b.M[block]


def natural_frequencies(problem: Any, count: int = 6, blocks: Iterable[Hashable] | None = None
                        ) -> list[Frequency]:
    """The lowest natural frequencies of each block about the problem's current state.

    Args:
        problem: a ``Problem`` with ``KineticMass``, at an equilibrium (collective).
        count: how many per block (the lowest ω², nearest 0 about a stable state).
        blocks: the blocks (default: all of the problem's).

    Returns:
        The frequencies, by block in the given order, ascending in each.

    Raises:
        InputError: a problem without a kinetic mass, or ``count`` < 1.
    """
    if not isinstance(problem, KineticMass):
        raise InputError("this problem has no kinetic mass (assemble_kinetic_mass)")
    if not (isinstance(count, int) and count >= 1):
        raise InputError(f"count must be a positive integer, got {count!r}")
    stab = KineticStability(problem)
    out = []
    try:
        for block in (stab.blocks() if blocks is None else tuple(blocks)):
            vals, vecs = stab.eigenpairs(count, modes=True, block=block)
            for w2, v in zip(vals, vecs, strict=True):
                free = problem.free_motion(block, v)  # the mode without its rigid part
                info = problem.classify_mode(free, block)
                free.destroy()
                v.destroy()
                out.append(Frequency(omega2=float(w2),
                                     omega=math.copysign(math.sqrt(abs(w2)), w2),
                                     block=block, mode_m=info.m, mode_n=info.n))
    finally:
        stab.destroy()
    return out
