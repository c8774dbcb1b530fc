"""A natural-curvature field
=========================

The paper imposes one uniform natural curvature, b̄ = b° + κ a°. Patterned bilayers impose
a field: ``shells`` takes b̄ = b° + κ f(x) (f1 e1⊗e1 + f2 e2⊗e2), with f a scalar field of
the reference position and (f1, f2) an anisotropy along the meridian (e1) and the parallel
(e2). f = 1, (f1, f2) = (1, 1) is the paper's stimulus.

Here a 45° cap (h/R = 0.04) is patterned in two ways: a ring at its rim only (the
boundary layer, where the stimulus acts as a torque) and a patch at the pole only (the
bulk, where it acts as a pressure). Under the uniform stimulus the cap snaps at a fold;
each pattern alone needs a larger κ, and the ring changes the kind of instability: the
rim, bent alone, buckles around the axis before the cap can snap.
"""

# %%
import math
import os
import sys

import matplotlib.pyplot as plt
import numpy as np
from mpi4py import MPI

import shells
from shells.geometry.stimulus import CurvatureField

QUICK = os.environ.get("SHELLS_DEMO_QUICK") == "1" or "--quick" in sys.argv
rank0 = MPI.COMM_WORLD.rank == 0

# %% [markdown]
# The fields
# ----------
#
# An expression of the reference coordinates (``theta``: the polar angle from the pole;
# ``step(s, w)`` = (1 + tanh(s/w))/2, a smooth step of width w). The text is parsed into a
# small expression tree, never executed. Tables of values (rows ``theta f``, or ``x y z f``
# at points of the surface) are read with ``CurvatureField.from_file``.

# %%
theta = math.radians(45)
fields = {
    "uniform": None,
    "rim ring": CurvatureField("step(theta - 0.55, 0.04)"),
    "pole patch": CurvatureField("step(0.4 - theta, 0.04)"),
}
t = np.linspace(0, theta, 200)
fig, ax = plt.subplots(figsize=(5.5, 3.2))
for name, f in fields.items():
    values = np.ones_like(t) if f is None else f.meridian_values(np.sin(t), np.cos(t))
    ax.plot(np.degrees(t), values, label=name)
ax.set_xlabel("angle from the pole (°)")
ax.set_ylabel("f")
ax.legend()
ax.set_title("the natural-curvature patterns on a 45° cap")

# %% [markdown]
# The first instability going up, for each pattern
# ------------------------------------------------
#
# An axisymmetric field keeps the 1D model; a field that varies around the axis (e.g.
# ``where(sin(3*phi) > 0, 1, -1)``) needs the surface model, which ``critical`` then picks.
# The three 1D runs are independent: ``shells.sweep`` spreads them over the MPI processes
# (``mpirun -n 3`` runs one each) and gives every process all the results. The range
# κR ≤ 12 covers the patterns, which need a larger κ than the uniform cap.

# %%
caps = [shells.Shell(shells.cap(theta=theta), h_over_r=0.04, kappa_field=f)
        for f in fields.values()]
results = shells.sweep(caps, "critical", direction="up", first_only=True, kappa_R_max=12.0)
found = dict(zip(fields, results, strict=True))
if rank0:
    for name, r in found.items():
        print(f"{name:10}: {r.kind} m = {r.mode_m} at kappa R = {r.kappa_R}")

# %% [markdown]
# Checks
# ------
#
# The uniform cap snaps at κR = 2.51; the pole patch snaps too, at a larger κ; the rim ring
# loses its rotational symmetry (a bifurcation, m > 2) at a κ several times larger.

# %%
uni, ring, pole = found["uniform"], found["rim ring"], found["pole patch"]
assert uni.kind == "fold" and abs(uni.kappa_R - 2.511) < 1e-2
assert pole.kind == "fold" and uni.kappa_R < pole.kappa_R < 2 * uni.kappa_R
assert ring.kind == "bifurcation" and ring.mode_m > 2 and ring.kappa_R > 3 * uni.kappa_R
