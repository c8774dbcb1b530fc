"""Your own cap, from Python
=========================

A researcher's cap as measured: a bilayer shell of radius 25 mm, two layers of 0.5 mm with
Young's moduli 1 and 2 MPa, cut at a half opening angle of 40°. The layers' mismatch strain
(differential swelling) sets the natural curvature; ``shells`` answers: at which natural
curvature does this cap snap, at which does it buckle, and what mismatch gets there?

The API takes lengths and moduli with units (strings such as ``"25 mm"`` or pint
quantities) and reports dimensionless numbers (κR, κh) beside κ in 1/m.
"""

# %%
import os
import sys
from pathlib import Path

from mpi4py import MPI

import shells

QUICK = os.environ.get("SHELLS_DEMO_QUICK") == "1" or "--quick" in sys.argv
OUT = Path(os.environ.get("SHELLS_DEMO_OUT", "results/demos")) / "own_cap_python"
rank0 = MPI.COMM_WORLD.rank == 0

# %% [markdown]
# The bilayer
# -----------
#
# ``shells.bilayer`` gives the natural curvature of two bonded layers whose outer layer
# expands by the mismatch strain Δε relative to the inner one (Timoshenko's bimetal formula
# with the plate correction for an equal-biaxial mismatch). Equal layers give κh = 1.5 Δε
# (for ν = 0; the plate factor 1 + ν multiplies it). Here the inner layer swells by 1 %
# more than the outer one (Δε = −0.01): the shell wants to curve more than it is, κ > 0.

# %%
MISMATCH = -0.01
layers = shells.bilayer(h=("0.5 mm", "0.5 mm"), E=("1 MPa", "2 MPa"), mismatch=MISMATCH, nu=0.5)
if rank0:
    print(f"bilayer: kappa = {layers.kappa:.2f} 1/m, thickness {layers.thickness * 1e3:.2f} mm,"
          f" effective modulus {layers.modulus / 1e6:.3f} MPa")

# %% [markdown]
# The shell and its instabilities
# -------------------------------
#
# ``Shell(geometry, layers=...)`` takes its thickness and Poisson ratio from the bilayer.
# ``critical`` in each direction gives the first instability: the model is chosen for the
# shell (the 1D model for a shell of revolution; ``res.model`` says which).

# %%
geometry = shells.cap(theta_deg=40, radius="25 mm")
shell = shells.Shell(geometry, layers=layers)
up = shells.critical(shell, direction="up", first_only=True)
down = shells.critical(shell, direction="down", first_only=True)
if rank0:
    print(f"h/R = {shell.h_over_r:.3f}; this bilayer's kappa R = "
          f"{shell.kappa_natural:.3f}")
    for name, r in (("up", up), ("down", down)):
        print(f"{name:4}: {r.kind:11} m = {r.mode_m} at kappa R = {r.kappa_R:+.4f} = "
              f"{r.kappa:.1f~P}  ({r.model} model)")

# %% [markdown]
# The mismatch that snaps the cap: κ is linear in Δε, so scale it.

# %%
mismatch_snap = MISMATCH * up.kappa_R / shell.kappa_natural
if rank0:
    print(f"the cap snaps at a mismatch strain of {mismatch_snap:.4f} "
              f"(this bilayer: {MISMATCH})")

# %% [markdown]
# Tables, files and plots
# -----------------------
#
# A result reads as the command line's JSON (keys as attributes), as a pandas table of its
# critical points, and as files: ``save`` writes ``result.json`` and ``table.csv``, which
# ``shells.load`` reads back.

# %%
full = shells.critical(shell, direction="up")
table = full.to_dataframe()
if rank0:
    print(table[["kind", "kappa_R", "mode_m"]].to_string(index=False))
    full.save(OUT)
MPI.COMM_WORLD.barrier()
again = shells.load(OUT)
fig = full.plot()

# %% [markdown]
# Checks
# ------
#
# The same cap given dimensionless (radius 1, h/R from the bilayer) gives the same κR.

# %%
plain = shells.critical(shells.Shell(shells.cap(theta_deg=40), h_over_r=shell.h_over_r,
                                     nu=shell.nu), direction="up", first_only=True)
assert abs(plain.kappa_R - up.kappa_R) < 1e-12
assert up.kind == "fold" and up.mode_m == 0 and shell.kappa_natural > 0
assert down.mode_m == 2 and down.kappa_R < 0 < up.kappa_R
assert again.kappa_R == full.kappa_R
