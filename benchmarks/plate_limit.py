"""Plate limit on the surface model: a free disk's first bifurcation under natural curvature.

    scripts/in-env python3 benchmarks/plate_limit.py [--h-over-r 0.02] [--meshes 0.15:2 0.1:3]
    scripts/in-env python3 benchmarks/plate_limit.py --nu-study     (1D model, seconds)

A flat disk of radius r with uniform natural curvature κ bifurcates into an m = 2 (saddle/
cylinder) mode at |κ| r²/h = √(10 + 7√2) = 4.4609 (Pezzulla et al. 2016, ν = 1/2). For each mesh
(bulk size : elements across the rim layer √(r h)): DOFs, the located κ r²/h, its mode m and
the relative difference to 4.4609. Results are written to JSON as they come.

``--nu-study``: the converged 1D (axisymmetric) disk's a(ν) at h/r = 0.01 and 0.005 beside
√(10 + 7√2) (ν-independent) and the uniform-curvature Föppl-von Kármán value 8/(1+ν)^{3/2}
(``theory.plate_a_uniform_curvature``): both references are reduced models, and a(ν) of the
full energy shows how far each is from it (benchmarks/results/plate_limit_nu.json).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from mpi4py import MPI

from shells.algorithms.following import follow
from shells.algorithms.settings import ContinuationSettings, CriticalSettings
from shells.geometry.shapes import Disk
from shells.surface.mesh import MeshSpec, generate
from shells.surface.model import ModelParameters, ShellModel
from shells.theory import plate_a, plate_a_uniform_curvature


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
            "dofs": model.num_dofs(), "kappa_r2_over_h": v,
            "mode_m": first.mode_m if first else None,
            "kind": first.kind if first else "none",
            "rel_diff": v / a - 1 if v else None, "wall_time": time.perf_counter() - t0}


def nu_study(out: Path) -> None:
    """a(ν) of the 1D model against the two reduced-model references."""
    from shells.analyses import axisym_runs

    rows = []
    for h in (0.01, 0.005):
        for nu in (0.0, 0.25, 0.3, 0.4, 0.5):
            t0 = time.perf_counter()
            r = axisym_runs.critical(Disk(1.0), h, nu, direction="up", kappa_max=25 * h)
            a = r["kappa_R"] / h if r["kind"] != "none" else None
            rows.append({"h_over_r": h, "nu": nu, "a": a, "mode_m": r["mode_m"],
                         "kind": r["kind"], "pezzulla": plate_a(),
                         "uniform_curvature": plate_a_uniform_curvature(nu),
                         "wall_time": time.perf_counter() - t0})
    if MPI.COMM_WORLD.rank == 0:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps({"runs": rows}, indent=1))
        print("free disk, 1D model: a = |kappa| r^2/h at the first bifurcation")
        print(f"{'h/r':>6} {'nu':>5} {'a':>8} {'m':>3} {'vs 4.4609':>10} "
              f"{'8/(1+nu)^1.5':>13} {'vs it':>7}")
        for r in rows:
            a = r["a"]
            print(f"{r['h_over_r']:6.3f} {r['nu']:5.2f} {a:8.4f} {r['mode_m']:3d} "
                  f"{100 * (a / r['pezzulla'] - 1):9.2f}% {r['uniform_curvature']:13.4f} "
                  f"{100 * (a / r['uniform_curvature'] - 1):6.2f}%")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nu-study", action="store_true",
                    help="the 1D model's a(nu) beside both reduced-model references")
    ap.add_argument("--h-over-r", type=float, default=0.02)
    ap.add_argument("--meshes", nargs="+", default=["0.15:2", "0.1:3", "0.07:4"])
    ap.add_argument("--sign", type=float, default=1.0)
    ap.add_argument("-o", default="benchmarks/results/plate_limit.json")
    a = ap.parse_args()
    if a.nu_study:
        nu_study(Path("benchmarks/results/plate_limit_nu.json"))
        return
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
