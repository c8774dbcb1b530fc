"""What the critical-point algorithms report and hand back (algorithm layer): a located
``CriticalPoint``, and the resume records of ``follow`` (``FollowResume``) and
``switch_branch`` (``SwitchResume``): everything a run needs to continue after a point as the
uninterrupted run would.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Hashable
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

log = logging.getLogger("shells")

__all__ = ["CriticalPoint", "FollowResume", "SwitchResume", "block_key"]


@dataclass
class CriticalPoint:
    """A located critical point (κ absolute; κL = κ times the shape's length scale).

    Attributes:
        kind: "fold" or "bifurcation".
        kappa, kappa_L: the located κ and κL.
        kappa_lo, kappa_hi: the final bracket in κ.
        negative_before, negative_after: the block's negative counts on either side.
        multiplicity: the change of the count over the step (several eigenvalues crossing
            in one step are one critical point).
        eigenvalue: the mode's eigenvalue at the state the mode was computed at.
        mode_m, mode_n: the mode's azimuthal wavenumber and (spheres) degree
            (``Problem.classify_mode``), None if unknown.
        mode_rayleigh: the classification's Rayleigh quotients and spectra.
        block: the stability block that changed (``None``: the Jacobian).
        evaluations: corrector solves spent locating it.
        accuracy: the estimated error of ``kappa``, relative.
        after_point: the index of the branch point before the critical point.
        wall_time: seconds spent locating it.
        state: this rank's owned values of the state next to the point (not exported).
        mode: this rank's owned values of the critical mode (not exported).
    """

    kind: str
    kappa: float
    kappa_L: float  # noqa: N815
    kappa_lo: float
    kappa_hi: float
    negative_before: int
    negative_after: int
    multiplicity: int
    eigenvalue: float
    mode_m: int | None = None
    mode_n: int | None = None
    mode_rayleigh: dict[str, float] = field(default_factory=dict)
    block: Any = None
    evaluations: int = 0
    accuracy: float = math.nan
    after_point: int = 0
    wall_time: float = 0.0
    state: np.ndarray | None = field(default=None, repr=False)
    mode: np.ndarray | None = field(default=None, repr=False)

    def as_dict(self) -> dict[str, Any]:
        """The scalars (JSON-ready); the state and mode arrays are left out."""
        return {k: v for k, v in asdict(self).items() if k not in ("state", "mode")}


@dataclass
class FollowResume:
    """Where ``follow`` stood after one of its points: what a resumed ``follow`` needs to
    continue after that point as the uninterrupted run did (a checkpoint).

    Attributes:
        index: the point's index.
        kappa, kappa_prev: κ at the point and at the one before it (the point's own κ at the
            first point): their secant orients the first tangent after a resume.
        dkappa_ds: the κ-component of the point's unit tangent (a fold: its sign changes).
        newton_its, step: the corrector's iterations and the arclength step to the point.
        ds: the next step, in arclength (``continuation.next_step``; the first step after
            the first point).
        tl0: the first point's ``dkappa_ds``, with which steps given in κL (``ds_unit``
            "kappa") were converted to arclength (``continuation.in_arclength``).
        counts: the negative count of each stability block at the point (blocks in a stable
            order: ``None`` first); the first step after a resume is searched for a change.
        found: critical points located up to the point.
        folds_only: inertia not computed any more (``folds_only_after_first``).
        ended: the run ended at the point (its stop rule, or ``kappa_end`` reached): a resumed
            ``follow`` yields nothing.
        state, state_prev: this rank's owned state values at the point and at the one before
            it (the point's own at the first point).
        tangent: the state part of the unit tangent at the point that the next step's
            predictor follows (owned values; its κ part is ``dkappa_ds``): the resumed run
            predicts with it (None: the Jacobian's tangent there, oriented by the secant).
    """

    index: int
    kappa: float
    kappa_prev: float
    dkappa_ds: float
    newton_its: int
    step: float
    ds: float
    tl0: float
    counts: dict[Hashable, int]
    found: int = 0
    folds_only: bool = False
    ended: bool = False
    state: np.ndarray = field(default=None, repr=False)
    state_prev: np.ndarray = field(default=None, repr=False)
    tangent: np.ndarray | None = field(default=None, repr=False)

    def scalars(self) -> dict[str, Any]:
        """The scalars (JSON-ready: ``counts`` as [[block, count], ...]); the arrays are
        left out."""
        d = {k: v for k, v in asdict(self).items()
             if k not in ("state", "state_prev", "tangent")}
        d["counts"] = [[b, int(c)] for b, c in sorted(self.counts.items(),
                                                      key=lambda bc: block_key(bc[0]))]
        return d

    @classmethod
    def from_scalars(cls, d: dict[str, Any], state: np.ndarray, state_prev: np.ndarray,
                     tangent: np.ndarray | None = None) -> FollowResume:
        """The inverse of ``scalars``, with the arrays."""
        d = dict(d)
        d["counts"] = {b: int(c) for b, c in d["counts"]}
        return cls(**d, state=state, state_prev=state_prev, tangent=tangent)


@dataclass
class SwitchResume:
    """Where ``switch_branch`` stood after one of its points: what a resumed ``switch_branch``
    needs to continue after that point as the uninterrupted run did (a checkpoint).

    Attributes:
        index: the point's index.
        lam, lam_prev: λ = κL of the point and of the one before it (λ_c before the first): the
            secant the next predictor follows.
        ds: the next step (the arclength loop's, ``continuation.next_step``).
        direction: the sign of the loop's direction in λ.
        first_amplitude, first_distance: the first point's mode amplitude a and distance from
            the fundamental branch, and ``distance`` the point's: what the return and jump
            tests measure against.
        state, state_prev: this rank's owned state values at the point and at the one before
            it (w_c before the first).
        by_arclength, ds_max, stretch_min: a branch followed with a ``control`` went on by
            arclength past a fold of the control (``switch_branch``), with this largest step;
            the smallest arclength per unit change of the control so far.
    """

    index: int
    lam: float
    lam_prev: float
    ds: float
    direction: float
    first_amplitude: float
    first_distance: float
    distance: float
    state: np.ndarray = field(repr=False)
    state_prev: np.ndarray = field(repr=False)
    by_arclength: bool = False
    ds_max: float = 0.0
    stretch_min: float = 0.0

    def scalars(self) -> dict[str, Any]:
        """The scalars (JSON-ready; the same on every rank); the arrays are left out."""
        return {k: v for k, v in asdict(self).items() if k not in ("state", "state_prev")}


def block_key(b: Hashable) -> tuple[int, Any]:
    """Sort key for stability blocks: ``None`` (the Jacobian) first, then by label.

    Args:
        b: a block label.

    Returns:
        A key that orders ``None`` before every label.
    """
    return (0, 0) if b is None else (1, b)
