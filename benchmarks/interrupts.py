"""Ctrl-C on a 2-rank run, counted: SIGINT to the ranks of ``mpirun -n 2 shells critical`` (the
1D model on the θ̄ = 8 cap, a few seconds) at seeded random moments, from start-up to after the
run's end (its teardown: logging, atexit, MPI_Finalize), as a batch scheduler or a terminal
sends it.

    scripts/in-env python3 benchmarks/interrupts.py [--runs 80] [--seed 16] [--window 1.5 7]
        [--repo DIR] [-o benchmarks/results/interrupts.json]

Each run ends in one of three clean ways: interrupted (exit 130 and exactly one line
"shells: interrupted (SIGINT); rerun the same command to resume" on stderr, from rank 0 or,
when rank 0 is busy in a long call, from another rank), completed before the signal (exit 0),
or completed with the signal arriving during the teardown (exit 0, nothing printed: the results
were complete). Anything else is counted as bad: the interruption line missing (mpirun's abort
report alone), a rank ended by the signal, a KeyboardInterrupt or traceback fragment, a hang.
``--repo`` runs another checkout (e.g. an older revision, ``git archive REV | tar -x -C DIR``)
for a before/after comparison. Writes JSON and prints a table.
"""

from __future__ import annotations

import argparse
import collections
import json
import random
import signal
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import reliability as rb  # noqa: E402

ARGV = ["critical", "--model", "axisym", "--shape", "cap", "--theta-deg", "46.2",
        "--h-over-r", "0.01"]
LINE = "shells: interrupted (SIGINT); rerun the same command to resume"
NOISE = ("Traceback", "KeyboardInterrupt", "Exception ignored")


def classify(r: rb.Run) -> str:
    """One run's outcome (module docstring)."""
    lines = [ln for ln in r.stderr.splitlines() if ln.startswith("shells:")]
    noisy = any(w in r.stderr for w in NOISE)
    if r.rc is None:
        return "hang"
    if r.signalled and r.rc == 130 and lines == [LINE] and not noisy:
        return "interrupted"
    if r.rc == 0 and not lines and not noisy:
        return "completed, signal in teardown" if r.signalled else "completed before signal"
    if r.rc == 130 and not lines:
        return "bad: no interruption line"
    return "bad: other"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=80)
    ap.add_argument("--seed", type=int, default=16)
    ap.add_argument("--window", type=float, nargs=2, default=(1.5, 7.0), metavar=("LO", "HI"),
                    help="signal moments, uniform in (LO, HI) seconds after the start")
    ap.add_argument("--repo", default=str(rb.REPO), help="the checkout whose shells runs")
    ap.add_argument("-o", default="benchmarks/results/interrupts.json")
    a = ap.parse_args()
    rb.REPO = Path(a.repo).resolve()
    rng = random.Random(a.seed)
    counts: collections.Counter[str] = collections.Counter()
    runs = []
    t0 = time.perf_counter()
    for i in range(a.runs):
        at = rng.uniform(*a.window)
        with tempfile.TemporaryDirectory() as d:
            r = rb.run(ARGV, Path(d) / "out", 2, after=at, sig=signal.SIGINT)
        kind = classify(r)
        counts[kind] += 1
        runs.append({"at_s": round(at, 3), "exit": r.rc, "signalled": r.signalled,
                     "outcome": kind, "seconds": round(r.seconds, 2),
                     **({"stderr_tail": r.stderr[-400:]} if kind.startswith(("bad", "hang"))
                        else {})})
        print(f"{i:3d} signal at {at:5.2f} s: {kind}", flush=True)
    bad = sum(v for k, v in counts.items() if k.startswith(("bad", "hang")))
    res = {"command": ["mpirun", "-n", "2", "shells", *ARGV], "repo": str(rb.REPO),
           "seed": a.seed, "window_s": list(a.window), "runs": a.runs, "outcomes": dict(counts),
           "bad": bad, "wall_time_s": round(time.perf_counter() - t0, 1), "details": runs}
    Path(a.o).parent.mkdir(parents=True, exist_ok=True)
    Path(a.o).write_text(json.dumps(res, indent=1) + "\n")
    print(f"\n{'outcome':<32} {'runs':>5}")
    for k, v in sorted(counts.items()):
        print(f"{k:<32} {v:>5}")
    print(f"{'bad':<32} {bad:>5}   (of {a.runs}; {a.o})")


if __name__ == "__main__":
    main()
