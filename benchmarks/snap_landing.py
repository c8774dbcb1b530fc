"""Where caps land when they snap (issue 41): `shells snap` on caps of θ̄ = θ/√(h/R) at
h/R = 0.04 (the paper's Fig. 1 d is θ̄ = 5), the landing state's symmetry bracketing θ̄_c (the
paper: θ̄_c ≈ 3.85; the 1D proxy, where the everted branch's loss of symmetry crosses the fold
line: 3.953). Each case follows the branch to the fold and minimises past it; cases run one
after the other and are merged into the JSON as they finish (a rerun skips the finished ones
and resumes an unfinished one from its checkpoint). Prints a table.

    scripts/in-env python3 benchmarks/snap_landing.py [--ranks N] [--past P] [--size S]
        [--layer-elements L] [--degree D] [--h-over-r H] [--name NAME]
        [THETABAR ...]   (default: 2.5 3 3.5 4 4.5 5 6)

``--name NAME``: another set of runs (another mesh or h/R) beside the first, its folders in
benchmarks/results/snap/NAME/ and its JSON benchmarks/results/snap_landing_NAME.json.

The shallowest caps need a finer mesh than the others: θ̄ = 2.5 lands with spurious m = 8
rim wrinkles at size 0.35 R (P2) and 0.1 R (P2 or P3, 2 elements across √(Rh)), symmetric on
the everted state at 0.05 R, P3, 4 elements (``--size 0.05 --layer-elements 4 --degree 3``)
and on the default mesh (no mesh options: P2, 0.1 R, 4 elements).
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import time
from pathlib import Path

OUT = Path("benchmarks/results")
H_OVER_R = 0.04


def run_case(tb: float, a: argparse.Namespace) -> dict:
    folder = OUT / "snap" / (a.name or "") / f"thetabar_{tb:g}"
    cmd = (["mpirun", "-n", str(a.ranks)] if a.ranks > 1 else []) + [
        "shells", "snap", "--shape", "cap", "--theta-deg", repr(math.degrees(tb * math.sqrt(
            a.h_over_r))), "--h-over-r", str(a.h_over_r), "--past", str(a.past), "-o",
        str(folder), "--json"]
    if a.size is not None:
        cmd += ["--size", str(a.size)]
    if a.layer_elements is not None:
        cmd += ["--layer-elements", str(a.layer_elements)]
    if a.degree is not None:
        cmd += ["--degree", str(a.degree)]
    t0 = time.perf_counter()
    out = subprocess.run(cmd, capture_output=True, text=True)
    if out.returncode != 0:
        return {"failed": out.stderr.strip().splitlines()[-1:], "wall_s": time.perf_counter() - t0}
    res = json.loads(out.stdout.strip().splitlines()[-1])
    ld, ev = res["landing"], res["axisymmetric_everted"]
    return {"kappa_fold_R": res["start"]["kappa_fold_R"], "kappa_R": res["start"]["kappa_R"],
            "unstable_at_start": [u["mode_m"] for u in res["start"]["unstable"]],
            "landing": {k: ld[k] for k in ("energy", "stable", "negative_count", "orbit_modes",
                                           "symmetric", "mode_m", "rim_rotation_deg",
                                           "psi3_pole_over_h", "iterations")},
            "spectrum": ld["spectrum"][:6], "everted": ev, "dofs": res["dofs"],
            "mesh": res["mesh"], "folder": str(folder), "wall_s": time.perf_counter() - t0,
            "ranks": a.ranks}


def bracket(rows: dict) -> dict | None:
    """θ̄_c between the deepest cap that lands symmetric and the shallowest that does not."""
    done = {float(k): v for k, v in rows.items() if "landing" in v and v["landing"]["stable"]}
    sym = [t for t, v in done.items() if v["landing"]["symmetric"]]
    broken = [t for t, v in done.items() if not v["landing"]["symmetric"]]
    if not sym or not broken or max(sym) > min(broken):
        return None
    lo, hi = max(sym), min(broken)
    return {"low": lo, "high": hi, "width": hi - lo, "paper": 3.85, "axisym_proxy": 3.953}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("thetabar", nargs="*", type=float, default=[2.5, 3, 3.5, 4, 4.5, 5, 6])
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("--past", type=float, default=0.01)
    ap.add_argument("--size", type=float, default=None)
    ap.add_argument("--layer-elements", type=float, default=None)
    ap.add_argument("--degree", type=int, default=None)
    ap.add_argument("--h-over-r", type=float, default=H_OVER_R)
    ap.add_argument("--name", default=None, help="another set of runs (folders, JSON)")
    ap.add_argument("--out", default=None, help="the JSON (default: by --name)")
    a = ap.parse_args()
    path = Path(a.out or OUT / ("snap_landing.json" if a.name is None
                                else f"snap_landing_{a.name}.json"))
    data = json.loads(path.read_text()) if path.exists() else {"h_over_R": a.h_over_r,
                                                                 "cases": {}}
    for tb in a.thetabar:
        key = f"{tb:g}"
        if "landing" in data["cases"].get(key, {}):
            continue
        print(f"thetabar {tb:g} ...", flush=True)
        data["cases"][key] = run_case(tb, a)
        data["thetabar_c"] = bracket(data["cases"])
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(data, indent=1))
    print(f"{'thetabar':>8} {'kfold R':>9} {'stable':>6} {'landing':>10} {'E landing':>12} "
          f"{'E everted':>12} {'rim deg':>8} {'its':>5} {'wall s':>7}")
    for key, v in sorted(data["cases"].items(), key=lambda kv: float(kv[0])):
        if "landing" not in v:
            print(f"{key:>8} failed: {v.get('failed')}")
            continue
        ld, ev = v["landing"], v["everted"]
        kind = "symmetric" if ld["symmetric"] else f"m = {ld['mode_m']}"
        e_ev = f"{ev['energy']:12.8f}" if ev.get("energy") is not None else f"{'-':>12}"
        print(f"{key:>8} {v['kappa_fold_R']:9.5f} {str(ld['stable']):>6} {kind:>10} "
              f"{ld['energy']:12.8f} {e_ev} {ld['rim_rotation_deg']:8.1f} "
              f"{ld['iterations']:5d} {v['wall_s']:7.0f}")
    print("thetabar_c bracket:", data.get("thetabar_c"))


if __name__ == "__main__":
    main()
