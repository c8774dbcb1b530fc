"""`shells` against a peer solver, side by side at equal accuracy (issue 14): the NGSolve HHJ
shell of ../shared/peers/ngsolve-hhj (Neunteufel & Schöberl's Hellan-Herrmann-Johnson method for
nonlinear shells, the same energy), run as an external program in its own virtual environment.

    scripts/in-env python3 benchmarks/peer_ngsolve.py [--cases cap30 deep5] [-o OUT.json]
    python3 benchmarks/peer_ngsolve.py ...          (on the host: the same; ours via scripts/in-env)

Both solvers run on this machine in one run, one after the other, serial, one core each
(OMP_NUM_THREADS=1). `shells` is called as a user calls it, `scripts/in-env shells critical ...`
(inside the env scripts/in-env runs it directly), with its form-compile cache in a private folder
(XDG_CACHE_HOME): a run that compiled forms is repeated, and the difference is the compile time.
The peer runs with its venv's python (default /tmp/ngs-venv, which the env's root sees: /tmp and
/root are bound into it); its C++ kernels are compiled anew in every run (that is part of its
time). A missing venv is created as the peer's README says (python3 -m venv, pip install ngsolve
scipy); where that cannot be done (the env's python3 has no ensurepip) the benchmark stops with
one line: create the venv on the host, or run the benchmark on the host.

Cases (R = 1, h/R = 0.04, nu = 1/2): `cap30`, the 30 degree cap: its fold going up (kappa > 0)
and its m = 2 bifurcation going down; `deep5`, the cap of thetabar = theta / sqrt(h/R) = 5
(theta = 1 rad): its first critical point going up. Reference: the 1D model (shells.axisym) at
400 cells (critical points located to 1e-6), 200 cells beside it. Equal accuracy: each solver
climbs its ladder of discretisations, cheapest first, and stops at the first level whose value is
within 1e-4 (relative) of the reference and of the right kind; that level's wall time counts. The
ratio ours/peer is printed per point (goal: at most 1/2). Every run is appended to the JSON
(default benchmarks/results/peer_ngsolve.json) as soon as it ends. Table and findings:
docs/peer-comparison.md.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import resource
import shutil
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
IN_ENV = REPO / "scripts" / "in-env"
PEER_DIR = (REPO / ".." / "shared" / "peers" / "ngsolve-hhj").resolve()
OUT = REPO / "benchmarks" / "results" / "peer_ngsolve.json"
WORK = Path("/tmp/peer-ngsolve-bench")
TOL = 1.0e-4
H_OVER_R = 0.04
NU = 0.5

#: ours: (degree, bulk size / R, elements across sqrt(R h) at the rim), cheapest first (P2
#: needs about 40k DOFs for 1e-4 on the 30 degree cap's fold; P3 reaches it with 13k)
OURS_LADDER = [(3, 0.3, 2.0), (3, 0.3, 2.5), (3, 0.3, 3.0), (3, 0.2, 4.0)]
#: the peer: (bulk maxh, rim maxh, order), cheapest first (its README's table, plus a coarser one)
PEER_LADDER = [(0.15, 0.06, 2), (0.1, 0.04, 2), (0.1, 0.04, 3), (0.07, 0.025, 3),
               (0.05, 0.015, 3)]

CASES = {
    "cap30": {"theta_deg": 30.0, "points": [
        {"point": "fold", "direction": "up", "peer_task": "fold", "kind": "fold", "m": 0},
        {"point": "bif m=2", "direction": "down", "peer_task": "bif", "kind": "bifurcation",
         "m": 2}]},
    "deep5": {"theta_deg": math.degrees(5.0 * math.sqrt(H_OVER_R)), "points": [
        {"point": "first up", "direction": "up", "peer_task": "up", "kind": None, "m": None}]},
}

REF_CODE = """
import json, math, sys
from shells.analyses.axisym_runs import critical
from shells.geometry.shapes import SphericalCap
theta, h, direction, cells = float(sys.argv[1]), float(sys.argv[2]), sys.argv[3], int(sys.argv[4])
d = critical(SphericalCap(1.0, math.radians(theta)), h, 0.5, direction=direction, cells=cells,
             layer_cells=8.0 * cells / 200, rel_tol=1e-6, max_critical=1)
print(json.dumps({"kind": d["kind"], "kappa_R": d["kappa_R"], "mode_m": d["mode_m"],
                  "dofs": d["dofs"]}))
"""


def log(msg: str) -> None:
    print(msg, flush=True)


def run(cmd: list[str], env: dict[str, str], cwd: Path | None = None,
        stdout_file: Path | None = None) -> dict:
    """Run a command; its wall and CPU seconds (user + sys of it and its children)."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    p = subprocess.run(cmd, env=env, cwd=cwd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if stdout_file is not None:
        stdout_file.write_text(p.stdout + "\n--- stderr ---\n" + p.stderr)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return {"rc": p.returncode, "stdout": p.stdout, "stderr": p.stderr, "wall_s": wall,
            "cpu_s": cpu, "load_before": load}


def base_env() -> dict[str, str]:
    env = dict(os.environ)
    env.update(OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
    return env


# ------------------------------------------------------------------------------------ the peer
def peer_python(venv: Path) -> Path:
    """The peer's venv python, created as its README says if missing; else exit with one line."""
    py = venv / "bin" / "python"
    check = [str(py), "-c", "import ngsolve, scipy; print(ngsolve.__version__)"]
    if py.exists() and subprocess.run(check, capture_output=True).returncode == 0:
        return py
    host_py = shutil.which("python3") or sys.executable
    log(f"setting up the peer's venv {venv} (ngsolve, scipy; about 500 MB)")
    ok = subprocess.run([host_py, "-m", "venv", str(venv)], capture_output=True).returncode == 0
    ok = ok and subprocess.run([str(py), "-m", "pip", "install", "-q", "ngsolve", "scipy"],
                               capture_output=True).returncode == 0
    if not ok or subprocess.run(check, capture_output=True).returncode != 0:
        sys.exit(f"peer_ngsolve: cannot set up the peer's venv {venv} with {host_py} here; on the "
                 f"host: python3 -m venv {venv} && {venv}/bin/pip install ngsolve scipy")
    return py


def peer_version(py: Path) -> str:
    return subprocess.run([str(py), "-c", "import ngsolve; print(ngsolve.__version__)"],
                          capture_output=True, text=True).stdout.strip()


def peer_value(res: dict, task: str) -> dict:
    """The peer's value for the point and what it is."""
    if task == "fold":
        return {"kind": "fold", "mode_m": 0, "kappa_R": res["fold"]["kappa_fold_fit3"],
                "solve_s": res["fold"]["time"]}
    if task == "bif":
        return {"kind": "bifurcation", "mode_m": res["bif"]["mode_m"],
                "kappa_R": res["bif"]["kappa_c"], "solve_s": res["bif_time"]}
    up = res["up"]
    first = None
    if up["crossings"]:
        c = up["crossings"][0]
        k = c["kappa_quad"] if c["kappa_quad"] is not None else c["kappa_lin"]
        first = {"kind": "bifurcation", "mode_m": c["m"], "kappa_R": k}
    fold = up.get("fold")
    if fold and up["stop_reason"].startswith("fold") and (
            first is None or fold["kappa_fold_fit3"] < first["kappa_R"]):
        first = {"kind": "fold", "mode_m": 0, "kappa_R": fold["kappa_fold_fit3"]}
    if first is None:
        first = {"kind": "none", "mode_m": None, "kappa_R": float("nan")}
    first["solve_s"] = up["time"]
    return first


def run_peer(py: Path, theta_deg: float, task: str, level: tuple, tag: str) -> dict:
    maxh, hrim, order = level
    build = WORK / "ngs-build"
    build.mkdir(parents=True, exist_ok=True)
    out = WORK / f"peer_{tag}.json"
    out.unlink(missing_ok=True)
    env = base_env()
    env["PATH"] = f"{py.parent}:{env.get('PATH', '')}"   # its kernels are compiled by ngscxx
    cmd = [str(py), str(PEER_DIR / "cap_hhj.py"), "--maxh", str(maxh), "--hrim", str(hrim),
           "--order", str(order), "--theta", repr(theta_deg), "--h", str(H_OVER_R),
           "--task", task, "--out", str(out)]
    r = run(cmd, env, cwd=build, stdout_file=WORK / f"peer_{tag}.log")
    row = {"solver": "peer", "level": f"maxh {maxh}/{hrim}, order {order}", "cmd": cmd,
           "wall_s": r["wall_s"], "cpu_s": r["cpu_s"], "load_before": r["load_before"],
           "rc": r["rc"]}
    if r["rc"] != 0 or not out.exists():
        row["error"] = r["stderr"].strip().splitlines()[-1:] or ["no output"]
        return row
    res = json.loads(out.read_text())
    row.update(peer_value(res, task))
    row.update(dofs=res["ndof_condensed"], dofs_total=res["ndof_total"],
               setup_s=res["t_setup"])
    return row


# ---------------------------------------------------------------------------------------- ours
def cache_files(cache: Path) -> int:
    return sum(1 for _ in cache.rglob("*")) if cache.exists() else 0


def run_ours(theta_deg: float, direction: str, level: tuple, cache: Path, tag: str) -> dict:
    degree, size, layer = level
    env = base_env()
    env["XDG_CACHE_HOME"] = str(cache)
    cmd = [str(IN_ENV), "shells", "critical", "--shape", "cap", "--theta-deg", repr(theta_deg),
           "--h-over-r", str(H_OVER_R), "--nu", str(NU), "--direction", direction,
           "--first-only", "--degree", str(degree), "--size", str(size), "--layer-elements",
           str(layer), "--json"]
    compile_s = None
    n0 = cache_files(cache)
    r = run(cmd, env, stdout_file=WORK / f"ours_{tag}.log")
    if r["rc"] == 0 and cache_files(cache) != n0:   # it compiled forms: time it again, warm
        cold = r["wall_s"]
        r = run(cmd, env, stdout_file=WORK / f"ours_{tag}.log")
        compile_s = cold - r["wall_s"]
    row = {"solver": "ours", "level": f"P{degree}, size {size}, layer {layer}", "cmd": cmd,
           "wall_s": r["wall_s"], "cpu_s": r["cpu_s"], "load_before": r["load_before"],
           "rc": r["rc"], "compile_s": compile_s}
    if r["rc"] != 0:
        row["error"] = r["stderr"].strip().splitlines()[-1:] or ["no output"]
        return row
    d = json.loads(r["stdout"].strip().splitlines()[-1])
    cps = d["critical_points"]
    first = cps[0] if cps else {"kind": "none", "kappa_R": float("nan"), "mode_m": None}
    row.update(kind=first["kind"], mode_m=first.get("mode_m"), kappa_R=first["kappa_R"],
               dofs=d["dofs"])
    return row


# ---------------------------------------------------------------------------------------- main
def reference(theta_deg: float, direction: str) -> dict:
    out = {}
    for cells in (200, 400):
        r = run([str(IN_ENV), "python3", "-c", REF_CODE, repr(theta_deg), str(H_OVER_R),
                 direction, str(cells)], base_env())
        if r["rc"] != 0:
            sys.exit(f"peer_ngsolve: the 1D reference failed: {r['stderr'].strip()[-300:]}")
        out[cells] = json.loads(r["stdout"].strip().splitlines()[-1])
    ref = out[400]
    return {"kind": ref["kind"], "mode_m": ref["mode_m"], "kappa_R": ref["kappa_R"],
            "kappa_R_200_cells": out[200]["kappa_R"],
            "rel_diff_200_400": out[200]["kappa_R"] / ref["kappa_R"] - 1, "dofs": ref["dofs"]}


def accurate(row: dict, ref: dict) -> bool:
    if "kappa_R" not in row or not math.isfinite(row["kappa_R"]):
        return False
    if row.get("kind") != ref["kind"] or row.get("mode_m") != ref["mode_m"]:
        return False
    return abs(row["kappa_R"] / ref["kappa_R"] - 1) <= TOL


def fmt_row(case: str, point: str, row: dict, ref: dict) -> str:
    val = row.get("kappa_R", float("nan"))
    err = val / ref["kappa_R"] - 1 if math.isfinite(val) else float("nan")
    extra = f" (compile {row['compile_s']:.1f} s)" if row.get("compile_s") else ""
    if row.get("setup_s"):
        extra = f" (setup+compile {row['setup_s']:.1f} s, solve {row['solve_s']:.1f} s)"
    kind = f"{row.get('kind', '?')} m={row.get('mode_m')}"
    return (f"{case:6} {point:9} {row['solver']:5} {row['level']:26} {row.get('dofs', 0):>6} "
            f"{kind:16} {val:+.6f} {err:+.1e} {row['wall_s']:7.1f} {row['cpu_s']:7.1f}{extra}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", nargs="+", choices=list(CASES), default=list(CASES))
    ap.add_argument("--venv", type=Path, default=Path("/tmp/ngs-venv"))
    ap.add_argument("-o", "--output", type=Path, default=OUT)
    ap.add_argument("--keep-cache", action="store_true",
                    help="keep the form cache of an earlier run (no compile time measured)")
    args = ap.parse_args()
    if not (PEER_DIR / "cap_hhj.py").exists():
        sys.exit(f"peer_ngsolve: no peer at {PEER_DIR}")
    py = peer_python(args.venv)
    WORK.mkdir(parents=True, exist_ok=True)
    cache = WORK / "fenics-cache"
    if not args.keep_cache:
        shutil.rmtree(cache, ignore_errors=True)
    data = {"what": "shells vs the NGSolve HHJ peer at equal accuracy (1e-4 vs the 1D model)",
            "machine": {"host": platform.node(), "cpus": os.cpu_count(),
                        "python": platform.python_version()},
            "peer": {"dir": str(PEER_DIR), "python": str(py), "ngsolve": peer_version(py)},
            "h_over_R": H_OVER_R, "nu": NU, "tolerance": TOL, "omp_threads": 1,
            "started": time.strftime("%Y-%m-%d %H:%M:%S"), "cases": {}}

    def save() -> None:
        args.output.parent.mkdir(parents=True, exist_ok=True)
        args.output.write_text(json.dumps(data, indent=1) + "\n")

    header = (f"{'case':6} {'point':9} {'who':5} {'level':26} {'DOFs':>6} {'kind':16} "
              f"{'kappa R':>10} {'error':>8} {'wall s':>7} {'cpu s':>7}")
    log(header)
    for cname in args.cases:
        case = CASES[cname]
        theta = case["theta_deg"]
        cdata = data["cases"].setdefault(cname, {"theta_deg": theta, "thetabar": math.radians(
            theta) / math.sqrt(H_OVER_R), "points": {}})
        for pt in case["points"]:
            ref = reference(theta, pt["direction"])
            pdata = cdata["points"].setdefault(pt["point"], {"reference": ref, "runs": []})
            save()
            log(f"{cname:6} {pt['point']:9} 1D    400 (200) cells {ref['dofs']:>13} "
                f"{ref['kind'] + ' m=' + str(ref['mode_m']):16} {ref['kappa_R']:+.6f} "
                f"(200 cells: {ref['rel_diff_200_400']:+.1e})")
            best = {}
            for solver, ladder in (("ours", OURS_LADDER), ("peer", PEER_LADDER)):
                for i, level in enumerate(ladder):
                    tag = f"{cname}_{pt['direction']}_{i}"
                    row = (run_ours(theta, pt["direction"], level, cache, tag)
                           if solver == "ours" else run_peer(py, theta, pt["peer_task"], level,
                                                             tag))
                    row["accurate"] = accurate(row, ref)
                    if "kappa_R" in row:
                        row["rel_error"] = row["kappa_R"] / ref["kappa_R"] - 1
                    pdata["runs"].append(row)
                    save()
                    log(fmt_row(cname, pt["point"], row, ref) + ("  <- 1e-4" if
                                                                 row["accurate"] else ""))
                    if row["accurate"]:
                        best[solver] = row
                        break
            if len(best) == 2:
                o, p = best["ours"], best["peer"]
                pdata["equal_accuracy"] = {
                    "ours": {k: o.get(k) for k in ("level", "dofs", "kappa_R", "rel_error",
                                                   "wall_s", "cpu_s", "compile_s")},
                    "peer": {k: p.get(k) for k in ("level", "dofs", "kappa_R", "rel_error",
                                                   "wall_s", "cpu_s", "setup_s", "solve_s")},
                    "ratio_wall": o["wall_s"] / p["wall_s"], "ratio_cpu": o["cpu_s"] / p["cpu_s"],
                    "goal_met": o["wall_s"] <= 0.5 * p["wall_s"]}
                e = pdata["equal_accuracy"]
                log(f"{cname:6} {pt['point']:9} ratio ours/peer: wall {e['ratio_wall']:.3f}, "
                    f"cpu {e['ratio_cpu']:.3f} (goal <= 0.5: "
                    f"{'met' if e['goal_met'] else 'NOT met'})")
            else:
                pdata["equal_accuracy"] = {"missing": [s for s in ("ours", "peer")
                                                       if s not in best]}
                log(f"{cname:6} {pt['point']:9} no level within {TOL:g} for "
                    f"{pdata['equal_accuracy']['missing']}")
            save()
    data["finished"] = time.strftime("%Y-%m-%d %H:%M:%S")
    save()
    log("ratio summary (ours/peer, wall; goal <= 0.5):")
    for cname, c in data["cases"].items():
        for pname, p in c["points"].items():
            e = p.get("equal_accuracy", {})
            if "ratio_wall" in e:
                log(f"  {cname} {pname}: {e['ratio_wall']:.3f} (ours {e['ours']['wall_s']:.1f} s "
                    f"{e['ours']['level']}, peer {e['peer']['wall_s']:.1f} s {e['peer']['level']})")
            else:
                log(f"  {cname} {pname}: no ratio, {e}")


if __name__ == "__main__":
    main()
