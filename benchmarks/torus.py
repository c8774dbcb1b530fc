"""The torus under a uniform natural curvature (issue 17: a closed shell without poles): the
first critical point of the surface model (P3, the pole-free rigid-motion gauge) on three
built-in meshes and on a mesh written by gmsh outside shells (tests/data/gmsh_torus.py: one
piece, no sectors, its shape recovered from its nodes), against each other.

    scripts/in-env mpirun -n 2 python3 benchmarks/torus.py [--h-over-r 0.1] [--ring 3]

Writes ``benchmarks/results/torus.json`` (rank 0) and prints a table: per mesh the kind, κh,
the mode's m, DOFs and wall time; the user mesh's κh against the built-in mesh of the same
size; the spread of the three built-in levels. For scale: the closed sphere of the same h/R
(its κ_b h from the 1D model).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

from mpi4py import MPI

from shells.analyses import axisym_runs, critical
from shells.geometry.shapes import Sphere, Torus

HERE = Path(__file__).parent
JSON = HERE / "results" / "torus.json"
WRITER = HERE.parent / "tests" / "data" / "gmsh_torus.py"
SIZES = (0.4, 0.3, 0.2)
USER_SIZE = 0.3


def say(msg: str) -> None:
    if MPI.COMM_WORLD.rank == 0:
        print(msg, flush=True)


def _run(shape: Torus, h: float, **kw) -> dict:
    t0 = time.perf_counter()
    r = critical.run(shape, h, 0.5, direction="up", model="surface", first_only=True, **kw)
    return {"kind": r["kind"], "kappa_h": r["kappa_h"], "kappa_R": r["kappa_R"],
            "mode_m": r["mode_m"], "dofs": r["dofs"], "wall_s": time.perf_counter() - t0}


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--h-over-r", type=float, default=0.1)
    ap.add_argument("--ring", type=float, default=3.0)
    a = ap.parse_args()
    comm = MPI.COMM_WORLD
    torus = Torus(1.0, a.ring)
    out: dict = {"shape": torus.describe(), "h_over_R": a.h_over_r, "nu": 0.5, "model": "surface",
                 "degree": 3, "built_in": {}, "ranks": comm.size}
    for s in SIZES:
        out["built_in"][str(s)] = r = _run(torus, a.h_over_r, size=s)
        say(f"built-in size {s}: {r['kind']} at kappa h = {r['kappa_h']:.6f} (m = "
            f"{r['mode_m']}), {r['dofs']} DOFs, {r['wall_s']:.0f} s")
    user = Path("/tmp") / f"shells_bench_user_torus_{a.ring:g}.msh"
    if comm.rank == 0:
        subprocess.run([sys.executable, str(WRITER), str(user), "--ring", str(a.ring),
                        "--size", str(USER_SIZE)], check=True, capture_output=True)
    comm.barrier()
    out["user_mesh"] = r = _run(torus, a.h_over_r, mesh_file=str(user))
    r["size"] = USER_SIZE
    say(f"user mesh size {USER_SIZE}: {r['kind']} at kappa h = {r['kappa_h']:.6f} (m = "
        f"{r['mode_m']}), {r['dofs']} DOFs, {r['wall_s']:.0f} s")
    sph = axisym_runs.critical(Sphere(1.0), a.h_over_r, 0.5, direction="up")
    out["sphere_kappa_b_h"] = sph["kappa_h"]
    ks = [out["built_in"][str(s)]["kappa_h"] for s in SIZES]
    ref = out["built_in"][str(USER_SIZE)]["kappa_h"]
    out["user_vs_built_in_rel"] = r["kappa_h"] / ref - 1
    out["built_in_spread_rel"] = (max(ks) - min(ks)) / ks[-1]
    if comm.rank == 0:
        JSON.parent.mkdir(parents=True, exist_ok=True)
        JSON.write_text(json.dumps(out, indent=1) + "\n")
    say("\n| mesh | kind | kappa h | m | DOFs | wall |\n| --- | --- | --- | --- | --- | --- |")
    for s in SIZES:
        b = out["built_in"][str(s)]
        say(f"| built-in {s} | {b['kind']} | {b['kappa_h']:.6f} | {b['mode_m']} | {b['dofs']} "
            f"| {b['wall_s']:.0f} s |")
    say(f"| user {USER_SIZE} | {r['kind']} | {r['kappa_h']:.6f} | {r['mode_m']} | {r['dofs']} "
        f"| {r['wall_s']:.0f} s |")
    say(f"user mesh against built-in (size {USER_SIZE}): {out['user_vs_built_in_rel']:+.2e}; "
        f"built-in spread over sizes {SIZES}: {out['built_in_spread_rel']:.2e}; closed sphere "
        f"of the same h/R (1D): kappa_b h = {sph['kappa_h']:.6f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
