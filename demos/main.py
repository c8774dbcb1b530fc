"""Main demo: mesh a spherical cap with its rim boundary layer, check it, render it to PNG.

    scripts/in-env python3 demos/main.py [OUTDIR]

(The physics demos replace this as the model lands; this one shows the geometry layer.)
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

from mpi4py import MPI

from shells.geometry import SphericalCap
from shells.mesh import MeshSpec, generate
from shells.render import render_mesh


def run(outdir: str | Path = "results/demo") -> dict:
    outdir = Path(outdir)
    h_over_r, theta_deg = 0.01, 60.0
    spec = MeshSpec(SphericalCap(1.0, math.radians(theta_deg)), h=h_over_r, size=0.1,
                    layer_elements=4)
    sm = generate(spec, MPI.COMM_WORLD, msh_path=outdir / "cap.msh")
    s = sm.summary()
    render_mesh(sm, outdir / "cap.png", title=f"cap theta = {theta_deg:g} deg, h/R = {h_over_r}")
    if MPI.COMM_WORLD.rank == 0:
        print(f"cap theta = {theta_deg:g} deg, h/R = {h_over_r}: {s['cells']} cells")
        print(f"  boundary layer sqrt(R h) = {spec.layer_width:.3f} R, "
              f"rim elements {spec.layer_size:.4f} R, bulk {spec.bulk_size:.3f} R")
        print(f"  area rel. error {s['area_rel_error']:.1e}, rim rel. error {s['rim_rel_error']:.1e}")
        print(f"  wrote {outdir / 'cap.msh'} and {outdir / 'cap.png'}")
        assert (outdir / "cap.png").stat().st_size > 10_000
    assert s["area_rel_error"] < 1e-5 and s["rim_rel_error"] < 1e-7
    return s


if __name__ == "__main__":
    run(*sys.argv[1:2])
