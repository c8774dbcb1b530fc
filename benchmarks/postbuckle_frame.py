"""How much of a post-buckled branch's readings is the rigid-motion gauge's tilt.

The surface model's gauge holds a pattern without axial symmetry tilted by an angle that depends
on its orientation (docs/model.md, "Rigid motions"); the snap's landings are read in the shell's
best-fit rigid frame (``ShellModel.rigid_frame``), the post-buckling records in the gauge
(``ShellModel.scalars``, whose Ψ3 at the pole is the continuation's linear functional). This
script follows a cap's bifurcated m = 2 branch on the surface model and reads every point both
ways: the tilt, Ψ3 at the pole and its mean, the apex, the rim rotation and the spectrum's
m = 1 and m = 2 amplitudes (over m = 0's).

    scripts/in-env python3 benchmarks/postbuckle_frame.py [--theta-deg 30] [--points 10]
        [--direction down] [--size 0.3] [--out FILE]

Writes benchmarks/results/postbuckle_frame.json (``--out``) and prints a table.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from contextlib import nullcontext
from pathlib import Path

import numpy as np

OUT = Path("benchmarks/results/postbuckle_frame.json")
KEYS = ("psi3_pole_over_h", "psi3_over_h", "apex_uz_over_h", "rim_rotation_deg")


def main() -> None:
    from mpi4py import MPI

    from shells.analyses.postbuckle import PostbuckleConfig, postbuckle
    from shells.geometry.shapes import SphericalCap
    from shells.surface.frame import rotation_angle_deg

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--theta-deg", type=float, default=30.0)
    ap.add_argument("--h-over-r", type=float, default=0.04)
    ap.add_argument("--direction", default="down")
    ap.add_argument("--points", type=int, default=10)
    ap.add_argument("--size", type=float, default=0.3)
    ap.add_argument("--layer-elements", type=float, default=3.0)
    ap.add_argument("--out", type=Path, default=OUT)
    a = ap.parse_args()
    rows: list[dict] = []

    def on_point(model, rec: dict) -> None:
        if rec.get("branch") == "fundamental":
            return
        frame = model.rigid_frame()
        Q = frame.rotation()
        row = {"kappa_R": rec["kappa_R"], "mode_amplitude": rec.get("mode_amplitude"),
               "tilt_deg": rotation_angle_deg(Q)}
        for where, held in (("gauge", nullcontext()), ("frame", frame.aligned())):
            with held:
                s, p = model.scalars(), model.azimuthal_spectrum(model.state)
            amp = np.sqrt(p / p[0])
            row[where] = {**{k: s.get(k) for k in KEYS}, "amp_m1": float(amp[1]),
                          "amp_m2": float(amp[2])}
        rows.append(row)

    cfg = PostbuckleConfig(shape=SphericalCap(1.0, math.radians(a.theta_deg)),
                           h_over_r=a.h_over_r, model="surface", direction=a.direction,
                           sides=(1,), max_points=a.points, size=a.size,
                           layer_elements=a.layer_elements)
    t0 = time.perf_counter()
    list(postbuckle(cfg, on_point=on_point))
    wall = time.perf_counter() - t0
    worst = {k: max(abs(r["gauge"][k] - r["frame"][k]) for r in rows) for k in KEYS}
    out = {"config": {k: v for k, v in vars(a).items() if k != "out"}, "points": rows,
           "max_tilt_deg": max(r["tilt_deg"] for r in rows), "max_gauge_minus_frame": worst,
           "wall_s": wall, "ranks": MPI.COMM_WORLD.size}
    if MPI.COMM_WORLD.rank == 0:
        a.out.write_text(json.dumps(out, indent=1) + "\n")
        print(f"{'kappa R':>9} {'amplitude':>9} {'tilt deg':>9} {'Psi3 pole':>10} "
              f"{'(frame)':>10} {'rim deg':>9} {'(frame)':>9} {'m1':>7} {'(frame)':>8}")
        for r in rows:
            g, f = r["gauge"], r["frame"]
            print(f"{r['kappa_R']:9.5f} {r['mode_amplitude']:9.4f} {r['tilt_deg']:9.4f} "
                  f"{g['psi3_pole_over_h']:10.6f} {f['psi3_pole_over_h']:10.6f} "
                  f"{g['rim_rotation_deg']:9.5f} {f['rim_rotation_deg']:9.5f} "
                  f"{g['amp_m1']:7.4f} {f['amp_m1']:8.1e}")
        print("largest |gauge - frame|:", {k: float(f"{v:.2g}") for k, v in worst.items()})


if __name__ == "__main__":
    main()
