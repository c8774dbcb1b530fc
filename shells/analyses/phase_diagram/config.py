"""The phase diagram's configuration and tasks (driver layer): ``PhaseDiagramConfig`` (validated;
its ``numerics`` are the rerun key), ``Discretisation`` (how finely every branch is resolved: it
builds the per-task ``AxisymParameters``, continuation settings and ``MeshSpec``), ``Task`` (one
branch: h/R, θ̄, direction) and ``tasks_of``."""

from __future__ import annotations

import hashlib
import json
import logging
import math
from dataclasses import asdict, dataclass, field, fields
from typing import TYPE_CHECKING, Any

import numpy as np

from shells.analyses.axisym_runs import default_settings
from shells.axisym.model import AxisymParameters
from shells.errors import InputError
from shells.geometry.shapes import Shape, SphericalCap
from shells.parameters import check_h_over_r, check_model, check_nu
from shells.surface.mesh import MeshSpec

if TYPE_CHECKING:
    from shells.algorithms.settings import ContinuationSettings

__all__ = ["SNAP_FIT_THETA_MAX_DEG", "THETA_MAX", "Discretisation", "PhaseDiagramConfig", "Task",
           "tasks_of"]

log = logging.getLogger("shells")

#: Caps closer to a closed sphere than this (θ > THETA_MAX) are left out of a diagram.
THETA_MAX = 0.9 * math.pi
#: The snapping line is fitted over caps up to a hemisphere: the paper derives it for θ ≤ π/2
#: (the rim's tangent plane horizontal at the snap); deeper caps bend the fold curve upwards.
SNAP_FIT_THETA_MAX_DEG = 90.0


# ------------------------------------------------------------------------------------------------
# configuration
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Discretisation:
    """How finely every branch of a diagram is resolved (validated on construction).

    The per-task objects that take these settings are built here and nowhere else
    (``axisym_parameters``, ``continuation_settings``, ``mesh_spec``), and the settings are
    validated by building them: the ranges are those classes' own rules, stated once there.

    Attributes:
        cells, layer_cells: axisymmetric mesh (bulk cells, cells per √(Rh) at the rim;
            ``AxisymParameters``, whose defaults these are).
        ds_max: largest continuation step (axisym: the weighted arclength of
            ``shells.algorithms.continuation``; the default is ``default_settings``' for an open
            cap, and it may not be below that function's first step).
        size, layer_elements: surface-model mesh (``MeshSpec``, whose defaults these are).
    """

    cells: int = AxisymParameters.cells
    layer_cells: float = AxisymParameters.layer_cells
    ds_max: float = 0.2
    size: float = MeshSpec.size
    layer_elements: float = MeshSpec.layer_elements

    def __post_init__(self) -> None:
        # the classes below test ranges with math.isfinite, a TypeError (not an InputError, the
        # CLI's exit status 2) on a non-number, and not every bound is finite; the values go
        # into the rerun key, which is JSON
        for f in fields(self):
            v = getattr(self, f.name)
            if not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)):
                raise InputError(f"{f.name} must be a finite number, got {v!r}")
        # the rules these settings are checked against depend neither on the cap (as long as it
        # is open: default_settings scales its steps for closed shapes only) nor on h/R
        cap, h = SphericalCap(1.0, 0.5), 0.01
        self.axisym_parameters(h, 0.5)
        self.continuation_settings(cap, h)
        self.mesh_spec(cap, h)

    def axisym_parameters(self, h_over_r: float, nu: float) -> AxisymParameters:
        """The axisymmetric model's parameters of one task (a cap of radius 1: h = h/R)."""
        return AxisymParameters(h=h_over_r, nu=nu, cells=self.cells,
                                layer_cells=self.layer_cells)

    def continuation_settings(self, shape: Shape, h_over_r: float) -> ContinuationSettings:
        """The axisymmetric branch's continuation settings (at most 3000 points a branch)."""
        return default_settings(shape, h_over_r, ds_max=self.ds_max, max_steps=3000)

    def mesh_spec(self, shape: Shape, h_over_r: float) -> MeshSpec:
        """The surface model's mesh of one task."""
        return MeshSpec(shape, h=h_over_r, size=self.size, layer_elements=self.layer_elements)


@dataclass(frozen=True)
class PhaseDiagramConfig:
    """One phase diagram (validated on construction).

    Attributes:
        h_over_r: thicknesses h/R.
        thetabar_range: (A, B), the θ̄ interval; ``points`` values evenly spaced in it per h/R
            (values with θ = θ̄ √(h/R) > 0.9 π are left out and listed as skipped).
        points: number of θ̄ values per h/R (1: θ̄ = A only).
        nu: Poisson ratio.
        model: "axisym" (default) or "surface" (2D, for spot checks).
        m_max: Fourier modes 0..m_max are checked (axisym).
        rel_tol: location accuracy of folds and bifurcations, relative in κ.
        refine: bisection steps in θ̄ for θ̄_s per h/R (0: the bracket only).
        discretisation: meshes and continuation step (``Discretisation``).
    """

    h_over_r: tuple[float, ...]
    thetabar_range: tuple[float, float]
    points: int
    nu: float = 0.5
    model: str = "axisym"
    m_max: int = 12
    rel_tol: float = 1.0e-3
    refine: int = 3
    discretisation: Discretisation = field(default_factory=Discretisation)

    def __post_init__(self) -> None:
        hs = tuple(self.h_over_r)
        if not hs:
            raise InputError("give at least one h/R")
        for h in hs:
            check_h_over_r(h)
        object.__setattr__(self, "h_over_r", tuple(float(h) for h in hs))
        rng = tuple(self.thetabar_range)
        if len(rng) != 2 or not all(isinstance(v, (int, float)) and math.isfinite(v)
                                    for v in rng):
            raise InputError(f"the theta-bar range must be two numbers, got {rng!r}")
        a, b = (float(v) for v in rng)
        if not (0 < a <= b):
            raise InputError(f"the theta-bar range must satisfy 0 < A <= B, got {a:g} {b:g}")
        object.__setattr__(self, "thetabar_range", (a, b))
        if not (isinstance(self.points, int) and 1 <= self.points <= 10000):
            raise InputError(f"points must be an integer in [1, 10000], got {self.points!r}")
        if a == b and self.points != 1:
            raise InputError("a single theta-bar value (A = B) needs --points 1")
        check_nu(self.nu)
        check_model(self.model)
        if not (isinstance(self.m_max, int) and 1 <= self.m_max <= 200):
            raise InputError(f"m_max must be an integer in [1, 200], got {self.m_max!r}")
        if not (0 < self.rel_tol < 0.1):
            raise InputError(f"rel_tol must lie in (0, 0.1), got {self.rel_tol!r}")
        if not isinstance(self.discretisation, Discretisation):
            raise InputError(f"discretisation must be a Discretisation, got "
                             f"{self.discretisation!r}")
        if not (isinstance(self.refine, int) and 0 <= self.refine <= 20):
            raise InputError(f"refine must be an integer in [0, 20], got {self.refine!r}")
        if any(t > THETA_MAX for h in self.h_over_r for t in [a * math.sqrt(h)]):
            raise InputError(f"theta-bar {a:g} gives an opening angle above 0.9 pi for some h/R: "
                             "lower A")

    def thetabars(self) -> list[float]:
        a, b = self.thetabar_range
        return [float(v) for v in np.linspace(a, b, self.points)]

    def numerics(self) -> dict[str, Any]:
        """What a computed task depends on besides (h/R, θ̄, direction): the rerun key."""
        d = self.discretisation
        if self.model == "axisym":
            return {"model": "axisym", "nu": self.nu, "m_max": self.m_max,
                    "rel_tol": self.rel_tol, "cells": d.cells,
                    "layer_cells": d.layer_cells, "ds_max": d.ds_max,
                    # the inertia is computed at every branch point (the key stays, so that
                    # the points files already written keep their key)
                    "check_every": 1, "locator": "critical.follow"}
        return {"model": "surface", "nu": self.nu, "rel_tol": self.rel_tol, "size": d.size,
                "layer_elements": d.layer_elements}

    def signature(self) -> str:
        return hashlib.sha1(json.dumps(self.numerics(), sort_keys=True).encode()).hexdigest()[:12]

    def describe(self) -> dict[str, Any]:
        d = asdict(self)
        # the discretisation's settings stay top-level keys of the JSON output (its contract)
        d.update(d.pop("discretisation"))
        d["signature"] = self.signature()
        return d


@dataclass(frozen=True)
class Task:
    """One branch to follow: (h/R, θ̄, direction)."""

    h_over_r: float
    thetabar: float
    direction: str
    tag: str = "grid"

    def __post_init__(self) -> None:
        if self.direction not in ("up", "down"):
            raise InputError(f"direction must be 'up' or 'down', got {self.direction!r}")

    @property
    def theta(self) -> float:
        return self.thetabar * math.sqrt(self.h_over_r)

    def key(self, signature: str) -> str:
        return f"{signature}|h={self.h_over_r:.8g}|tb={self.thetabar:.8g}|{self.direction}"

    def cost(self) -> float:
        """A rough cost estimate (deep caps going up are the expensive ones)."""
        return (2.0 + self.thetabar) if self.direction == "up" else 1.0 + 0.2 * self.thetabar


def tasks_of(cfg: PhaseDiagramConfig) -> tuple[list[Task], list[dict[str, float]]]:
    """The grid's tasks.

    Args:
        cfg: the diagram.

    Returns:
        (the tasks, most expensive first, an up and a down branch per point; the skipped
        points {"h_over_R", "thetabar"}, those with θ > 0.9 π).
    """
    tasks, skipped = [], []
    for h in cfg.h_over_r:
        for tb in cfg.thetabars():
            if tb * math.sqrt(h) > THETA_MAX:
                skipped.append({"h_over_R": h, "thetabar": tb})
                continue
            tasks += [Task(h, tb, "up"), Task(h, tb, "down")]
    tasks.sort(key=lambda t: -t.cost())
    return tasks, skipped
