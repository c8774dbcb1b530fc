"""Speed of the 1D model's stability checks (issue 14): a baseline revision against the working
tree, in one run on the same machine, as ratios.

    git archive 7016cc2 shells | tar -x -C /tmp/baseline    # on the host (no git in-env)
    scripts/in-env python3 benchmarks/axisym_speed.py --baseline-dir /tmp/baseline
        [--repeat 3] [-o benchmarks/results/axisym_speed.json]

The case: the θ̄ = 8 cap (h/R = 0.01, θ = 46.2°, ν = 1/2), all modes m = 0..12 checked at every
point, as ``shells critical --shape cap --theta-deg 46.2 --h-over-r 0.01 --model axisym`` runs
it (``shells.axisym.critical``: the branch up to its fold, every critical point located).

The baseline's ``shells`` package is the one in ``--baseline-dir`` (or, where git is at hand,
``git archive REV shells`` of ``--baseline`` into a temporary folder); each repetition runs one
fresh process per version, alternating, and the best of ``--repeat`` is kept: the process's wall
time, its imports, the run itself, and within the run the time in the per-point checks of every
block (``Stability.negative_counts``) and in the inertias (``Stability.inertia``, the locator's
as well). The imports are those of the libraries (dolfinx with PETSc, SLEPc: 0.35 s, which
either version's run would otherwise pay on its first use) and of ``shells``; the run's CPU time
is reported beside its wall time (this machine's wall times vary by up to 30 % between runs of
the same code). The located points of both versions are compared (largest relative difference
of κ).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
BASELINE = "7016cc2"  # the revision before issue 14's speed-ups (θ̄ = 8: 4.4 s measured)


def worker() -> None:
    """One run of the case in this process; prints one JSON line."""
    t0 = time.perf_counter()
    import math

    import dolfinx.fem.petsc  # noqa: F401 - the libraries' imports are not the run's
    import slepc4py.SLEPc  # noqa: F401

    from shells.algorithms import stability
    from shells.analyses import axisym_runs
    from shells.geometry.shapes import SphericalCap

    t_import = time.perf_counter() - t0
    timers = {"negative_counts": 0.0, "inertia": 0.0, "points": 0, "inertias": 0}

    def timed(name: str, fn):  # noqa: ANN001, ANN202 - a wrapper of either version's method
        def wrapper(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202
            t = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                timers[name] += time.perf_counter() - t
                if name == "negative_counts":
                    timers["points"] += 1
                else:
                    timers["inertias"] += 1
        return wrapper

    S = stability.Stability
    S.negative_counts = timed("negative_counts", S.negative_counts)
    S.inertia = timed("inertia", S.inertia)
    if hasattr(S, "exact_inertia"):  # the exact counts on condensed blocks (84037b8 on)
        S.exact_inertia = timed("inertia", S.exact_inertia)
    t1, c1 = time.perf_counter(), time.process_time()
    r = axisym_runs.critical(SphericalCap(1.0, math.radians(46.2)), 0.01, 0.5, direction="up")
    t_run, c_run = time.perf_counter() - t1, time.process_time() - c1
    print(json.dumps({"import_s": t_import, "run_s": t_run, "run_cpu_s": c_run, **timers,
                      "critical": [(c["kind"], float(c["kappa_R"]), c["mode_m"])
                                   for c in r["critical_points"]]}))


def run_once(tree: Path) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree))
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--worker"],
                         env=env, cwd=tempfile.gettempdir(), capture_output=True, text=True,
                         check=True)
    wall = time.perf_counter() - t0
    rec = json.loads(out.stdout.strip().splitlines()[-1])
    rec["process_s"] = wall
    return rec


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", default=BASELINE)
    ap.add_argument("--baseline-dir", help="a folder holding the baseline's shells package")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("-o", default=str(REPO / "benchmarks/results/axisym_speed.json"))
    a = ap.parse_args()
    if a.worker:
        worker()
        return
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(a.baseline_dir or tmp)
        if not a.baseline_dir:
            archive = subprocess.run(["git", "-C", str(REPO), "archive", a.baseline, "shells"],
                                     capture_output=True, check=True).stdout
            subprocess.run(["tar", "-x", "-C", str(base)], input=archive, check=True)
        if not (base / "shells" / "__init__.py").is_file():
            raise SystemExit(f"no shells package in {base}")
        runs: dict[str, list[dict]] = {"before": [], "after": []}
        for _ in range(a.repeat):
            runs["before"].append(run_once(base))
            runs["after"].append(run_once(REPO))
    keys = ("process_s", "import_s", "run_s", "run_cpu_s", "negative_counts", "inertia")
    best = {v: {k: min(r[k] for r in rs) for k in keys} for v, rs in runs.items()}
    for v, rs in runs.items():
        best[v]["points"] = rs[0]["points"]
        best[v]["inertias"] = rs[0]["inertias"]
    cb, ca = runs["before"][0]["critical"], runs["after"][0]["critical"]
    same_kinds = [(k, m) for k, _, m in cb] == [(k, m) for k, _, m in ca]
    change = (max(abs(x[1] - y[1]) / abs(x[1]) for x, y in zip(cb, ca, strict=True))
              if same_kinds else None)
    out = {"case": "cap theta 46.2 deg, h/R 0.01, m = 0..12 (thetabar 8), up to the fold",
           "baseline": a.baseline_dir or a.baseline, "repeat": a.repeat,
           "load_average": list(os.getloadavg()),
           "best": best, "runs": runs, "critical_before": cb, "critical_after": ca,
           "same_critical_points": same_kinds, "largest_relative_change": change}
    Path(a.o).write_text(json.dumps(out, indent=1))
    print(f"thetabar 8 cap, m = 0..12, best of {a.repeat} (s); baseline {a.baseline} vs the "
          f"working tree; load average {out['load_average'][0]:.1f}")
    print(f"{'':28s}{'before':>9s}{'after':>9s}{'ratio':>8s}")
    names = {"process_s": "process (wall)", "import_s": "imports", "run_s": "axisym_runs.critical",
             "run_cpu_s": "  its CPU time (all threads)",
             "negative_counts": "  per-point checks", "inertia": "  inertias (all)"}
    for k, label in names.items():
        b, f = best["before"][k], best["after"][k]
        print(f"{label:28s}{b:9.3f}{f:9.3f}{b / f if f else float('inf'):8.2f}")
    b, f = best["before"], best["after"]
    print(f"{'check calls / inertias':28s}{b['points']:>5d}/{b['inertias']}"
          f"{f['points']:>5d}/{f['inertias']}")
    print(f"critical points: {len(ca)}, same kinds and modes: {same_kinds}, largest relative "
          f"change of kappa: {change}")


if __name__ == "__main__":
    main()
