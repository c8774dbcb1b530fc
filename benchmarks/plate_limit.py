"""Plate limit on the surface model: a free disk's first bifurcation under natural curvature.

    scripts/in-env python3 benchmarks/plate_limit.py [--h-over-r 0.02] [--meshes 0.15:2 0.1:3 0.07:4]

A flat disk of radius r with uniform natural curvature κ bifurcates into an m = 2 (saddle/
cylinder) mode at |κ| r²/h = √(10 + 7√2) = 4.4609 (Pezzulla et al. 2016, ν = 1/2). For each mesh
(bulk size : elements across the rim layer √(r h)): DOFs, the located κ r²/h, its mode m and
the relative difference to 4.4609. Results are written to JSON as they come.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from mpi4py import MPI

from shells.continuation import ContinuationSettings
from shells.critical import CriticalSettings, follow
from shells.geometry import Disk
from shells.mesh import MeshSpec, generate
from shells.model import ModelParameters, ShellModel
from shells.theory import plate_a


def run(h: float, size: float, layer: float, sign: float) -> dict:
    comm = MPI.COMM_WORLD
    t0 = time.perf_counter()
    sm = generate(MeshSpec(Disk(1.0), h=h, size=size, layer_elements=layer), comm)
    model = ShellModel(sm, ModelParameters(h=h, nu=0.5))
    a = plate_a()
    st = ContinuationSettings(ds=0.3 * a * h, ds_max=0.3 * a * h, ds_unit="kappa")
    first = None
    for _, _, found in follow(model, st, sign * 1.5 * a * h, CriticalSettings(stop_at_first=True)):
        first = found[0] if found else first
    v = abs(first.kappa) / h if first else None
    return {"h_over_r": h, "size": size, "layer_elements": layer, "sign": sign,
            "dofs": model.num_dofs(), "kappa_r2_over_h": v, "mode_m": first.mode_m if first else None,
            "kind": first.kind if first else "none",
            "rel_diff": v / a - 1 if v else None, "wall_time": time.perf_counter() - t0}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--h-over-r", type=float, default=0.02)
    ap.add_argument("--meshes", nargs="+", default=["0.15:2", "0.1:3", "0.07:4"])
    ap.add_argument("--sign", type=float, default=1.0)
    ap.add_argument("-o", default="benchmarks/results/plate_limit.json")
    a = ap.parse_args()
    out = Path(a.o)
    rows = json.loads(out.read_text())["runs"] if out.exists() else []
    for m in a.meshes:
        size, layer = (float(v) for v in m.split(":"))
        if any(r["size"] == size and r["layer_elements"] == layer and r["h_over_r"] == a.h_over_r
               and r["sign"] == a.sign for r in rows):
            continue
        rows.append(run(a.h_over_r, size, layer, a.sign))
        if MPI.COMM_WORLD.rank == 0:
            out.parent.mkdir(parents=True, exist_ok=True)
            out.write_text(json.dumps({"runs": rows}, indent=1))
    if MPI.COMM_WORLD.rank == 0:
        print(f"\nfree disk, nu = 0.5: |kappa| r^2/h at the first bifurcation (theory "
              f"{plate_a():.4f})")
        print(f"{'h/r':>6} {'size':>6} {'layer':>6} {'dofs':>8} {'k r2/h':>9} {'m':>3} {'diff':>8}")
        for r in rows:
            print(f"{r['h_over_r']:6.3f} {r['size']:6.3f} {r['layer_elements']:6.1f} "
                  f"{r['dofs']:8d} {r['kappa_r2_over_h']:9.4f} {r['mode_m']:3d} "
                  f"{100 * r['rel_diff']:7.2f}%")


if __name__ == "__main__":
    main()
