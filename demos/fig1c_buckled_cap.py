"""Fig. 1 (c): a cap that loses its rotational symmetry
====================================================

A spherical cap of radius R, thickness h and half opening angle θ is described by its
depth θ̄ = θ/√(h/R): θ measured in widths of the rim's boundary layer, √(h/R). The paper's
Fig. 1 (c) shows a cap with θ̄ = 5 and h/R = 0.04 (θ = 57.3°) under a *negative* natural
curvature κ: the bilayer wants to curve less than the cap. The cap first flattens
axisymmetrically; at a critical κ_b R it buckles into a saddle, the Fourier mode m = 2
around its axis (two lobes up, two down), and the buckled shape is stable (a supercritical
bifurcation).

The paper's Eq. (4) interpolates this threshold between the plate limit and the closed
sphere. Here the 1D model (the meridian of the shell of revolution, with the stability of
every Fourier mode m) locates the bifurcation exactly; the full mode also follows the m = 2
branch on the surface model and writes the buckled shape for ParaView.

Run it with ``python3 demos/fig1c_buckled_cap.py`` (``--quick``: the 1D model only).
"""

# %%
import math
import os
import sys
from pathlib import Path

from mpi4py import MPI

import shells
from shells import theory

QUICK = os.environ.get("SHELLS_DEMO_QUICK") == "1" or "--quick" in sys.argv
OUT = Path(os.environ.get("SHELLS_DEMO_OUT", "results/demos")) / "fig1c_buckled_cap"
rank0 = MPI.COMM_WORLD.rank == 0

# %% [markdown]
# The shell
# ---------
#
# θ̄ = 5 at h/R = 0.04 gives θ = 5 √0.04 = 1 rad. Lengths are dimensionless (units of R)
# unless given with units; Poisson's ratio is ½ (the paper's elastomer) by default.

# %%
h_over_r, thetabar = 0.04, 5.0
cap = shells.cap(theta=thetabar * math.sqrt(h_over_r))
shell = shells.Shell(cap, h_over_r=h_over_r, nu=0.5)

# %% [markdown]
# The first instability going down
# --------------------------------
#
# ``shells.critical`` follows the fundamental (axisymmetric) branch from κ = 0 in the given
# direction and locates its critical points: folds (snap-through) and bifurcations (a
# Fourier mode m ≥ 1 going unstable: loss of rotational symmetry).

# %%
res = shells.critical(shell, direction="down", first_only=True)
eq4 = theory.buckling_kappa_R(thetabar, h_over_r)
if rank0:
    print(f"{res.kind} into m = {res.mode_m} at kappa R = {res.kappa_R:.5f} "
          f"(the paper's Eq. (4): {eq4:.3f})")

# %% [markdown]
# The fundamental branch up to the bifurcation: the pole's normal displacement Ψ3/h (the
# branch parameter of the paper's figures) against κR. ``Result.plot`` draws any branch.

# %%
branch = shells.branch(shell, kappa_R_max=res.kappa_R, model="axisym",
                       outdir=OUT / "branch")
fig = branch.plot(x="kappa_R")
ax = fig.axes[0]
ax.axvline(res.kappa_R, color="C3", lw=1, label=f"m = {res.mode_m} bifurcation")
ax.axvline(eq4, color="grey", ls="--", lw=1, label="Eq. (4)")
ax.legend()
ax.set_title(f"cap θ̄ = {thetabar:g}, h/R = {h_over_r:g}: fundamental branch")

# %% [markdown]
# The buckled shell
# -----------------
#
# The full mode switches onto the m = 2 branch at the located bifurcation on the surface
# model (a 3D mesh of the whole cap, no symmetry imposed), follows it to κR = −0.94 and
# writes the shape to ``fields_side+1.bp`` (ParaView: ADIOS2 VTX Reader, Warp By Vector on
# ``displacement``). A render of that run, coloured by the bending energy density:
#
# .. image:: /../benchmarks/results/shapes_3d/cap_buckled_buckled.png
#    :width: 60%
#    :alt: the buckled cap, a saddle
#
# (stored from ``benchmarks/shapes_3d.py``; the surface model needs minutes here, so the
# quick mode skips it).

# %%
if not QUICK:
    post = shells.postbuckle(shell, direction="down", model="surface", kappa_R_max=-0.94,
                             sides=(1,), outdir=OUT / "postbuckle", fields="last")
    last = [p for p in post.points if p["branch"] == "bifurcated"][-1]
    if rank0:
        print(f"surface model: m = {post.critical_point['mode_m']} at kappa R = "
              f"{post.critical_point['kappa_R']:.5f}; on the buckled branch at kappa R = "
              f"{last['kappa_R']:.3f}, stable: {last['stable']}")
    assert post.critical_point["mode_m"] == 2 and last["stable"]
    assert abs(post.critical_point["kappa_R"] - res.kappa_R) < 1e-3

# %% [markdown]
# Checks
# ------
#
# The loss of symmetry is the m = 2 saddle, at κR = −0.5085 (the paper's Eq. (4), a fit
# across caps, gives −0.50 here).

# %%
assert res.kind == "bifurcation" and res.mode_m == 2
assert abs(res.kappa_R - (-0.5085)) < 2e-3
assert abs(res.kappa_R - eq4) / abs(eq4) < 0.1
