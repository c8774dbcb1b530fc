"""Fig. 3: the closed sphere and its post-buckling
===============================================

A closed sphere has no rim and so no nearly isometric deformation: its characteristic
curvature is 1/h, not 1/R. Under a natural curvature κ > 0 it shrinks uniformly, the pole
moving inwards by Ψ3/h = −κh/12 (Ψ3: the normal displacement), until it buckles at

    κ_b h = 4 √(3(1−ν)/((1+ν)(5+4ν))) = 4/√7 ≈ 1.512   (ν = ½, the thin-shell limit)

into a spherical harmonic of degree n ≈ √(x), x = n(n+1) ∝ R/h. The bifurcation is
subcritical: the branch with a dimple at the pole, followed with rotational symmetry
enforced, falls back in κ as the dimple deepens (the paper's Fig. 3), as in the pressure
buckling of spheres.

The 1D model gives the buckling point, the n of its mode and the axisymmetric post-buckled
branch (``shells.postbuckle``). The quick mode follows 6 points of the dimpled side of the
branch at h/R = 0.01; the full mode both sides at the paper's h/R = 0.001, 0.01 and 0.1,
80 points each.
"""

# %%
import os
import sys
from pathlib import Path

import matplotlib.pyplot as plt
from mpi4py import MPI

import shells
from shells import theory

QUICK = os.environ.get("SHELLS_DEMO_QUICK") == "1" or "--quick" in sys.argv
OUT = Path(os.environ.get("SHELLS_DEMO_OUT", "results/demos")) / "fig3_sphere"
rank0 = MPI.COMM_WORLD.rank == 0

# %% [markdown]
# The buckling point
# ------------------

# %%
sphere = shells.Shell(shells.sphere(), h_over_r=0.01, nu=0.5)
crit = shells.critical(sphere, direction="up", first_only=True)
if rank0:
    print(f"h/R = 0.01: {crit.kind} at kappa_b h = {crit.kappa_h:.5f} into degree n = "
          f"{crit.mode_n} (thin limit 4/sqrt(7) = {theory.sphere_kappa_b_h():.5f}, "
          f"n from the dispersion relation {theory.sphere_mode_n(0.01):.1f})")

# %% [markdown]
# The post-buckled branch
# -----------------------
#
# ``postbuckle`` locates the bifurcation again, switches onto the bifurcated branch (here:
# the axisymmetric dimple, m = 0) and follows it by arclength, with the stability of every
# point; ``sides=(-1,)`` follows only the side that pushes the pole in (the dimple; side +1
# bulges it out). Ψ3(pole)/h against κ/κ_b, beside the linear theory −κh/12 of the
# fundamental branch:

# %%
thicknesses = (0.01,) if QUICK else (0.001, 0.01, 0.1)
fig, ax = plt.subplots(figsize=(6, 4.2))
branches = {}
for h in thicknesses:
    post = shells.postbuckle(shells.Shell(shells.sphere(), h_over_r=h), direction="up",
                             max_points=6 if QUICK else 80, sides=(-1,) if QUICK else (1, -1))
    kb = post.critical_point["kappa_h"]
    pts = [p for p in post.points if p["branch"] == "bifurcated"]
    branches[h] = (kb, pts)
    fund = [p for p in post.points if p["branch"] != "bifurcated"]
    ax.plot([p["kappa_h"] / kb for p in fund], [p["psi3_pole_over_h"] for p in fund],
            color="k", lw=1)
    ax.plot([p["kappa_h"] / kb for p in pts], [p["psi3_pole_over_h"] for p in pts], "o-",
            ms=3, label=f"h/R = {h:g} (κ_b h = {kb:.4f})")
ax.plot([0, 1], [0, -kb / 12], "k--", lw=1, label="theory −κh/12")
ax.set_xlabel("κ/κ_b")
ax.set_ylabel("Ψ3(pole)/h")
ax.legend()
ax.set_title("closed sphere: buckling and the dimpled branch")
if rank0:
    OUT.mkdir(parents=True, exist_ok=True)
    fig.savefig(OUT / "sphere_postbuckling.png", dpi=150)

# %% [markdown]
# The full run of ``benchmarks/sphere_postbuckling.py`` (stored), and the post-buckled shape
# on the surface model, where no symmetry is imposed (``benchmarks/dimple_2d.py``):
#
# .. image:: /../benchmarks/results/sphere_postbuckling.png
#    :width: 70%
#    :alt: the sphere's post-buckling branches at three thicknesses
#
# The dimpled sphere at h/R = 0.01, κ = 0.74 κ_b on that branch (stored; cut open to show
# the dimple's profile, the grey line the sphere it came from):
#
# .. image:: /../benchmarks/results/sphere_postbuckled_3d.png
#    :width: 60%
#    :alt: the closed sphere with a dimple at its pole, cut open
#
# Checks
# ------
#
# κ_b h is within 0.4 % of the thin limit at h/R = 0.01 (the O(h/R) correction), the mode's
# degree is n = 19, within 1 of the dispersion relation's n, and the bifurcated branch is
# subcritical and unstable: κ falls as the dimple deepens.

# %%
assert crit.kind == "bifurcation" and crit.mode_n == 19
assert abs(crit.mode_n - theory.sphere_mode_n(0.01)) < 1
assert abs(crit.kappa_h / theory.sphere_kappa_b_h() - 1) < 0.004
assert abs(crit.kappa_h - 1.5062) < 2e-4
kb, pts = branches[0.01]
assert abs(kb - crit.kappa_h) < 1e-4
deeper = [p for p in pts if p["psi3_pole_over_h"] < -1.0]
assert deeper and all(p["kappa_h"] < kb for p in deeper)
assert not any(p["stable"] for p in deeper)
