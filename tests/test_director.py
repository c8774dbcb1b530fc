"""The surface model's director: rotations of any size, and a stability answer that does not
depend on the director's parametrisation (docs/model.md, "Director charts").

* A snapped (everted) cap turns its rim by about twice its opening angle: 120° for the 60° cap
  (180° for the 90° cap: benchmarks/everted_mirror.py). Its everted states are equilibria of
  the surface model, and the energy's
  mirror symmetry holds: the everted cap at κ has the energy, the negative count and the lowest
  Hessian eigenvalues of the original cap at 2/R - κ.
* At a stressed equilibrium (the 60° cap past its loss of symmetry), the free chart (rotations
  of any size) and the tangent chart (below 90°) give the same inertia and the same lowest
  eigenvalues, to the discretisation's accuracy.

On 1 and 2 ranks (every compared number is reduced over the communicator).
"""

import functools
import math

import numpy as np
import pytest
from mpi4py import MPI

from shells.algorithms.newton import NewtonSolver
from shells.algorithms.stability import Stability
from shells.geometry.shapes import SphericalCap
from shells.surface.mesh import MeshSpec, generate
from shells.surface.model import ModelParameters, ShellModel

H = 0.04


def _equilibrium(model: ShellModel, kappas: list[float], eigenvalues: bool = True) -> dict:
    """Newton through ``kappas`` from the model's current state; scalars, inertia and (with
    ``eigenvalues``) the three eigenvalues nearest 0."""
    ns = NewtonSolver(model)
    for k in kappas:
        model.kappa.value = k
        ok, _ = ns.solve()
        assert ok, f"Newton failed at kappa = {k}"
    ns.destroy()
    stab = Stability(model)
    neg = stab.inertia()[0]
    vals = np.sort(np.asarray(stab.eigenpairs(3)[0], dtype=float)) if eigenvalues else None
    stab.destroy()
    return {"scalars": model.scalars(), "negative": neg, "eigenvalues": vals}


@functools.cache
def _mesh(theta_deg: float):
    shape = SphericalCap(1.0, math.radians(theta_deg))
    return generate(MeshSpec(shape, h=H, size=0.2, layer_elements=3.0), MPI.COMM_WORLD)


@functools.cache
def _original(theta_deg: float, kappa_r: float, chart: str, eigenvalues: bool) -> dict:
    """The symmetric cap at κR from the reference state (computed once per module run; every
    rank asks in the same order)."""
    model = ShellModel(_mesh(theta_deg), ModelParameters(h=H, nu=0.5, director=chart))
    return _equilibrium(model, [kappa_r / 2, kappa_r], eigenvalues)


# the 90° cap (rim turned by 180°; at κR 1.5 it mirrors 0.5) is in benchmarks/everted_mirror.py,
# with the mesh sequence that takes its energy difference below 1e-6 (4.2e-6 on this mesh)
@pytest.mark.parametrize("theta_deg, kappa_r", [(60, 2.6)])
def test_everted_cap_is_the_mirror_image(theta_deg, kappa_r):
    """The 60° cap at κR = 2.6 mirrors the original at -0.6, past its m = 2 loss of symmetry
    (κ_b R ≈ -0.49): two negative eigenvalues on both sides."""
    # eigenvalues where there is an instability to compare (the 60° cap): SLEPc is the
    # dearest part of a point
    eig = theta_deg == 60
    orig = _original(theta_deg, round(2.0 - kappa_r, 12), "free", eig)
    model = ShellModel(_mesh(theta_deg), ModelParameters(h=H, nu=0.5))
    model.set_everted_guess()
    ever = _equilibrium(model, [2.0, (2.0 + kappa_r) / 2, kappa_r], eig)
    eo, ee = orig["scalars"]["energy"], ever["scalars"]["energy"]
    # measured 3.4e-6 (60°) and 4.2e-6 (90°): the P2 mesh's departure from the sphere in the
    # rim layer (b° = -a°/R to O(size³)); with b° = -a°/R imposed the two agree to 1e-12
    assert abs(ee - eo) <= 1e-5 * abs(eo), (ee, eo)
    # the rim has turned by twice the opening angle, give or take the original's rotation
    # (outwards at -0.6, inwards at 0.5): past 90°, the tangent chart's limit
    rot, rot0 = ever["scalars"]["rim_rotation_deg"], orig["scalars"]["rim_rotation_deg"]
    assert rot > 90 and 0 < rot0 < 10
    assert abs(rot - 2 * theta_deg) == pytest.approx(rot0, abs=0.05), (rot, rot0)
    assert ever["negative"] == orig["negative"] == (2 if theta_deg == 60 else 0)
    if eig:
        scale = np.max(np.abs(orig["eigenvalues"]))
        assert np.allclose(ever["eigenvalues"], orig["eigenvalues"], rtol=0,
                           atol=1e-4 * scale), (ever["eigenvalues"], orig["eigenvalues"])
    for r in (orig, ever):  # the same answer on every rank
        e = r["scalars"]["energy"]
        assert MPI.COMM_WORLD.allreduce(e, op=MPI.MAX) == MPI.COMM_WORLD.allreduce(e, op=MPI.MIN)


def test_stability_does_not_depend_on_the_director_chart():
    """The 60° cap at κR = -0.6, symmetric and past its m = 2 loss of symmetry: a stressed,
    unstable equilibrium with a rotated director, in the free and in the tangent chart. At an
    equilibrium the charts' Hessians are congruent but for terms proportional to the residual
    (docs/model.md), and the two are two discretisations of one energy (their discrete
    equilibria differ at the mesh's accuracy: the 30° cap's fold 2.4e-4 apart). The same
    negative count, and the lowest eigenvalues alike to that accuracy (measured: 0.6-0.8 %;
    these eigenvalues are 1e-3 of the Hessian's scale, next to a crossing)."""
    f, t = _original(60, -0.6, "free", True), _original(60, -0.6, "tangent", True)
    assert f["negative"] == t["negative"] == 2
    assert np.allclose(f["eigenvalues"], t["eigenvalues"], rtol=0.02, atol=0), (
        f["eigenvalues"], t["eigenvalues"])
    assert f["scalars"]["energy"] == pytest.approx(t["scalars"]["energy"], rel=1e-3)
