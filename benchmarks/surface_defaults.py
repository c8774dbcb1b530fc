"""The surface model's default discretisation against the 1D model (issue 42): `shells critical`
with its defaults (no --size, no --degree) on closed spheres of h/R 0.05, 0.02, 0.01 (going up)
and on caps of θ̄ = 2, 5, 8, 12 at h/R = 0.04 and 0.01 (going down; θ̄ = θ/√(h/R), θ the cap's
half-angle), the first critical point compared with `shells critical --model axisym`. Each
surface run takes minutes on 2 cores; cases may be chosen by name. Writes JSON (merged into
an existing file, case by case) and prints a table.

    scripts/in-env python3 benchmarks/surface_defaults.py [--out OUT.json] [CASE ...]
    (CASE: sphere-H for H in 0.05 0.02 0.01, cap-TB-H for TB in 2 5 8 12 and H in 0.04 0.01,
    cap-2-0.04-p3; default: all)
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import time
from pathlib import Path

CASES = {
    "sphere-0.05": ["--shape", "sphere", "--h-over-r", "0.05", "--direction", "up"],
    "sphere-0.02": ["--shape", "sphere", "--h-over-r", "0.02", "--direction", "up"],
    "sphere-0.01": ["--shape", "sphere", "--h-over-r", "0.01", "--direction", "up"],
    **{f"cap-{tb:g}-{h:g}": ["--shape", "cap", "--theta-deg",
                             repr(math.degrees(tb * math.sqrt(h))), "--h-over-r", repr(h),
                             "--direction", "down"] for h in (0.04, 0.01) for tb in (2, 5, 8, 12)},
}
#: not a default: the θ̄ = 2 cap at h/R = 0.04 with P3 on its default mesh, to tell P2's share
CASES["cap-2-0.04-p3"] = [*CASES["cap-2-0.04"], "--degree", "3"]


def shells(args: list[str], ranks: int) -> tuple[dict, float]:
    cmd = (["mpirun", "-n", str(ranks)] if ranks > 1 else []) + ["shells", "critical",
                                                                 *args, "--json"]
    t0 = time.perf_counter()
    out = subprocess.run(cmd, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1]), time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="benchmarks/results/surface_defaults.json")
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("cases", nargs="*", default=list(CASES))
    a = ap.parse_args()
    path = Path(a.out)
    rows = json.loads(path.read_text()) if path.exists() else {}
    for name in a.cases:
        args = CASES[name]
        ref, t_ref = shells(args + ["--model", "axisym"], 1)
        try:
            sur, t_sur = shells(args + ["--first-only"], a.ranks)
        except subprocess.CalledProcessError as e:  # a refusal is a result
            rows[name] = {"refused": e.stderr.strip().splitlines()[-1], "axisym": ref["kappa_R"]}
        else:
            rows[name] = {"surface": sur["kappa_R"], "axisym": ref["kappa_R"],
                          "relative": sur["kappa_R"] / ref["kappa_R"] - 1,
                          "mode_surface": [sur["mode_m"], sur["mode_n"]],
                          "mode_axisym": [ref["mode_m"], ref["mode_n"]],
                          "dofs": sur["dofs"], "mesh": sur["mesh"],
                          "discretisation_error": sur.get("discretisation_error"),
                          "locator_accuracy": sur["critical_points"][0].get("locator_accuracy"),
                          "wall_s": t_sur, "axisym_wall_s": t_ref, "ranks": a.ranks}
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(rows, indent=1))
    print(f"{'case':>12} {'surface kappa R':>16} {'1D kappa R':>12} {'rel':>10} {'dofs':>7} "
          f"{'wall s':>7}")
    for name, r in rows.items():
        if "refused" in r:
            print(f"{name:>12} refused: {r['refused']}")
            continue
        print(f"{name:>12} {r['surface']:16.6f} {r['axisym']:12.6f} {r['relative']:+10.2e} "
              f"{r['dofs']:7d} {r['wall_s']:7.0f}")


if __name__ == "__main__":
    main()
