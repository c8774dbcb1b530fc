"""Fig. 2: the phase diagram of open caps
======================================

The paper summarises the instabilities of open caps in the plane (θ̄, κR):

- **κ < 0**: every cap loses its rotational symmetry (m = 2) at κ_b R, Eq. (4):
  κ_b R = −a/θ̄² + 1 + b/(θ̄ − π√(R/h)) + c, with a = √(10 + 7√2) from the plate limit and
  the paper's fit b = 3.6, c = −0.98;
- **κ > 0**: caps deeper than θ̄_s ≈ 2.09 snap through at a fold, κ_s R = β θ̄ − α
  (β = 0.85, α = 0.67), shallower ones invert smoothly; after inversion symmetry is lost
  again on the mirrored line 2 − κ_b R; the two lines cross at the triple point
  θ̄_c ≈ 3.85.

``shells.phase_diagram`` computes the first instability of each cap in both directions on
the 1D model (one cap per MPI process: ``mpirun -n 2 python3 demos/fig2_phase_diagram.py``),
fits the paper's laws and draws the figure.

The quick mode computes 2 caps at h/R = 0.04, one either side of θ̄_s (one per process on
2 processes); the full mode the paper's two thicknesses,
h/R = 0.01 and 0.04, at 31 depths θ̄ from 1 to 20 and bisects θ̄_s (about a minute on
2 processes), and reproduces the fits of the validation page.
"""

# %%
import os
import sys
from pathlib import Path

import matplotlib.image as mpimg
import matplotlib.pyplot as plt
from mpi4py import MPI

import shells

QUICK = os.environ.get("SHELLS_DEMO_QUICK") == "1" or "--quick" in sys.argv
OUT = Path(os.environ.get("SHELLS_DEMO_OUT", "results/demos")) / "fig2_phase_diagram"
rank0 = MPI.COMM_WORLD.rank == 0

# %% [markdown]
# The run
# -------
#
# ``m_max`` is the highest Fourier mode whose stability is checked (the first instabilities
# of caps up to θ̄ = 20 have m ≤ 8, those of the quick mode's shallow caps m ≤ 2); ``refine``
# the bisection steps for θ̄_s. A rerun in the same
# folder reuses the points already computed (``points.jsonl``).

# %%
if QUICK:
    res = shells.phase_diagram([0.04], (1.5, 3.5), 2, refine=0, m_max=4, outdir=OUT)
else:
    res = shells.phase_diagram([0.01, 0.04], (1.0, 20.0), 31, refine=3, m_max=12, outdir=OUT)

# %% [markdown]
# The points and the fits
# -----------------------
#
# Each point holds the first instability going up (``up_kind``: ``snap`` at a fold,
# ``bifurcation`` with its mode ``mode_up``, or ``inversion``: a smooth inversion, then the
# loss of symmetry of the inverted cap) and going down, as κR.

# %%
table = res.to_dataframe()
cols = [c for c in ("h_over_R", "thetabar", "up_kind", "kappa_up_R", "mode_up",
                    "kappa_down_R", "mode_down") if c in table]
if rank0:
    print(table[cols].to_string(index=False))
    print({k: v for k, v in res.fits.items() if not k.endswith("_err")})

# %% [markdown]
# The figure ``phase_diagram.png`` the analysis writes (computed points, fitted laws and the
# paper's lines):

# %%
fig, ax = plt.subplots(figsize=(7, 5))
ax.imshow(mpimg.imread(OUT / "phase_diagram.png"))
ax.set_axis_off()

# %% [markdown]
# The full run's figure, from the stored results of ``benchmarks/phase_diagram.py``:
#
# .. image:: /phase-diagram.png
#    :width: 80%
#    :alt: the phase diagram of open caps
#
# Checks
# ------
#
# Going down, every cap buckles into m = 2. Going up, the caps shallower than θ̄_s invert
# smoothly and then lose their symmetry on the mirrored line 2 − κ_b R (the inverted cap is
# the mirror image of the cap under −κ + 2/R: an identity of the model, met to the location
# tolerance), the caps deeper than θ̄_s snap at a fold close to the paper's line
# 0.85 θ̄ − 0.67 (ours lie about 6 % below it; the validation page explains why). θ̄_s lies
# between the deepest inverting and the shallowest snapping cap.

# %%
pts = res.points
assert all(p["mode_down"] == 2 for p in pts if p.get("kappa_down_R") is not None)
shallow = [p for p in pts if p["thetabar"] < 2.0]
assert shallow and all(p["up_kind"] == "inversion" for p in shallow)
for p in shallow:
    assert abs(p["kappa_up_R"] - (2 - p["kappa_down_R"])) < 1e-3
deep = [p for p in pts if 2.5 < p["thetabar"] < 4.5]
assert deep and all(p["up_kind"] == "snap" for p in deep)
for p in deep:
    assert abs(p["kappa_up_R"] / (0.85 * p["thetabar"] - 0.67) - 1) < 0.12
assert max(p["thetabar"] for p in shallow) <= res.fits["thetabar_s"] <= min(
    p["thetabar"] for p in deep)
if not QUICK:
    assert abs(res.fits["beta"] - 0.845) < 0.01 and abs(res.fits["thetabar_s"] - 2.09) < 0.1
    assert abs(res.fits["thetabar_c"] - 3.95) < 0.2
