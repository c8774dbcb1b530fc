"""Fig. S5: ellipsoidal caps
=========================

The supplement's last figure applies the same energy to a shell whose reference curvature is
not uniform: the half ellipsoid with semi-axes (R, R, r3), r3 = 3/2 R, h/R = 0.04, open at
θ = 90° (its equator). Under κ < 0 it buckles into a spindle-like shape, as a spherical cap
does; under κ > 0 it snaps, the deformation concentrated in the boundary layer at the rim.

An ellipsoid of revolution is a shell of revolution, so the 1D model locates both
instabilities; the full mode also computes them on the surface model, whose
mesh of the whole shell imposes no symmetry (several minutes on 2 processes).
"""

# %%
import os
import sys

import matplotlib.pyplot as plt
import numpy as np
from mpi4py import MPI

import shells

QUICK = os.environ.get("SHELLS_DEMO_QUICK") == "1" or "--quick" in sys.argv
rank0 = MPI.COMM_WORLD.rank == 0

# %% [markdown]
# The shell: ``shells.ellipsoid`` takes the equatorial radius R, the polar semi-axis r3
# (default 1.5 R) and the opening angle from the pole (default 90°).

# %%
shell = shells.Shell(shells.ellipsoid(radius=1.0, r3=1.5, theta_deg=90), h_over_r=0.04)
t = np.linspace(0, np.pi / 2, 100)
fig, ax = plt.subplots(figsize=(4, 4))
ax.plot(np.sin(t), 1.5 * np.cos(t), "k")
ax.plot(-np.sin(t), 1.5 * np.cos(t), "k")
ax.set_aspect("equal")
ax.set_xlabel("r / R")
ax.set_ylabel("z / R")
ax.set_title("the ellipsoidal cap's meridian")

# %% [markdown]
# Both directions
# ---------------

# %%
down = shells.critical(shell, direction="down", first_only=True)
up = shells.critical(shell, direction="up", first_only=True)
if rank0:
    for name, r in (("down", down), ("up", up)):
        print(f"{name:4}: {r.kind} m = {r.mode_m} at kappa R = {r.kappa_R:.5f} ({r.model})")

# %% [markdown]
# Going down the shell loses its symmetry into m = 2 (the spindle); going up into m = 3 just
# before the snap-through fold: the snapping ellipsoid leaves the rotational symmetry as it
# snaps, like the deep spherical caps of the phase diagram. Renders of the surface model's
# full runs (``benchmarks/shapes_3d.py``; colour: the bending energy density):
#
# .. image:: /../benchmarks/results/shapes_3d/ellipsoid_down_buckled.png
#    :width: 45%
#    :alt: the buckled ellipsoid
#
# .. image:: /../benchmarks/results/shapes_3d/ellipsoid_up_everted.png
#    :width: 45%
#    :alt: the snapped ellipsoid

# %%
if not QUICK:
    for name, r in (("down", down), ("up", up)):
        s = shells.critical(shell, direction=name, model="surface", first_only=True)
        if rank0:
            print(f"surface model, {name}: {s.kind} m = {s.mode_m} at kappa R = "
                  f"{s.kappa_R:.5f} ({s.kappa_R / r.kappa_R - 1:+.1e} from the 1D model)")
        assert abs(s.kappa_R / r.kappa_R - 1) < 2e-3

# %% [markdown]
# Checks
# ------

# %%
assert down.kind == "bifurcation" and down.mode_m == 2 and abs(down.kappa_R + 0.5739) < 1e-3
assert up.kind == "bifurcation" and up.mode_m == 3 and abs(up.kappa_R - 5.5272) < 1e-3
