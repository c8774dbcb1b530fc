"""Edge and bulk works of Eqs. (2a, 2b) on open caps: ratio |W_edge/W_bulk| versus h/R.

The paper's scaling: |W_edge / W_bulk| ~ (R/h)^(3/2) / tan(theta/2). This computes the linear
(small kappa) response of caps of several opening angles and thicknesses on two mesh resolutions,
fits the exponent (over all thicknesses and over the thinnest three) and writes JSON + a table.

    scripts/in-env python3 benchmarks/edge_bulk_scaling.py [OUT.json]

OUT.json defaults to benchmarks/results/edge_bulk.json, which docs/paper-comparison.md reads.
"""

from __future__ import annotations

import json
import math
import sys
import time

import numpy as np
from mpi4py import MPI

from shells.algorithms.newton import NewtonSolver
from shells.geometry.shapes import SphericalCap
from shells.surface.mesh import MeshSpec, generate
from shells.surface.model import ModelParameters, ShellModel


def works(h: float, theta_deg: float, layer_elements: float, size: float, kappa_R: float = 0.05):
    cap = SphericalCap(1.0, math.radians(theta_deg))
    sm = generate(MeshSpec(cap, h=h, size=size, layer_elements=layer_elements))
    model = ShellModel(sm, ModelParameters(h=h, nu=0.5))
    ns = NewtonSolver(model)
    model.kappa.value = kappa_R
    ok, _ = ns.solve()
    s = model.scalars()
    ns.destroy()
    return {"h_over_R": h, "theta_deg": theta_deg, "layer_elements": layer_elements,
            "size": size, "dofs": model.num_dofs(), "converged": ok, "W_edge": s["W_edge"],
            "W_bulk": s["W_bulk"], "P_kappa": s["curvature_potential"],
            "ratio": abs(s["W_edge"] / s["W_bulk"])}


def main(out: str = "benchmarks/results/edge_bulk.json") -> None:
    rows = []
    hs = [0.04, 0.02, 0.01, 0.005, 0.0025]
    for theta in (30.0, 60.0, 90.0):
        for le, size in ((3.0, 0.2), (5.0, 0.15)):
            for h in hs:
                t = time.perf_counter()
                r = works(h, theta, le, size)
                r["seconds"] = time.perf_counter() - t
                r["thetabar"] = math.radians(theta) / math.sqrt(h)
                r["paper_scale"] = (1 / h) ** 1.5 / math.tan(math.radians(theta) / 2)
                rows.append(r)
                if MPI.COMM_WORLD.rank == 0:
                    print(f"theta {theta:5.1f} h/R {h:7.4f} thetabar {r['thetabar']:6.2f} "
                          f"layer {le:.0f} dofs {r['dofs']:7d} |We/Wb| {r['ratio']:10.2f} "
                          f"/ paper scale {r['ratio'] / r['paper_scale']:.3f}  "
                          f"P/(-(Wb+We)) {r['P_kappa'] / -(r['W_bulk'] + r['W_edge']):.4f} "
                          f"{r['seconds']:.0f}s", flush=True)
    fits = []
    for theta in (30.0, 60.0, 90.0):
        for le in (3.0, 5.0):
            sel = [r for r in rows if r["theta_deg"] == theta and r["layer_elements"] == le]
            hh = np.array([r["h_over_R"] for r in sel])
            rr = np.array([r["ratio"] for r in sel])
            all_fit = -np.polyfit(np.log(hh), np.log(rr), 1)[0]
            thin_fit = -np.polyfit(np.log(hh[-3:]), np.log(rr[-3:]), 1)[0]
            local = [-math.log(rr[i + 1] / rr[i]) / math.log(hh[i + 1] / hh[i])
                     for i in range(len(hh) - 1)]
            fits.append({"theta_deg": theta, "layer_elements": le, "exponent_all": all_fit,
                         "exponent_thinnest3": thin_fit, "local_exponents": local})
            if MPI.COMM_WORLD.rank == 0:
                print(f"theta {theta:5.1f} layer {le:.0f}: exponent (all) {all_fit:.3f}, "
                      f"(thinnest 3) {thin_fit:.3f}, local {np.round(local, 3).tolist()} "
                      f"[paper: 1.5]")
    if MPI.COMM_WORLD.rank == 0:
        import pathlib

        pathlib.Path(out).parent.mkdir(parents=True, exist_ok=True)
        with open(out, "w") as f:
            json.dump({"rows": rows, "fits": fits}, f, indent=1)
        print(f"wrote {out}")


if __name__ == "__main__":
    main(*sys.argv[1:2])
