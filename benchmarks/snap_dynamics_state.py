"""Where a `shells snap --method dynamics` run is, and where it is heading (issue 41).

A snap integrated in time can pass close to unstable equilibria (saddles) of the energy and
creep away from them slowly: with mass-proportional damping α, an unstable direction of
generalised eigenvalue μ < 0 (H v = μ M v) grows at the rate s, s² + α s + μ = 0, which is
|μ|/α when α² ≫ |μ| (overdamped). This script reads the run's latest checkpoint (the state,
the time series so far) and reports, at that state:

* the series' last rows: time, kinetic and elastic energy, the m = 1..4 amplitudes, and the
  growth rate of each amplitude over the last ``--window`` time units;
* the Hessian's eigenvalues nearest 0 (H v = μ M v) with each eigenvector's dominant m, the
  negative count modulo the symmetry orbit, and the growth rate s of each unstable direction
  at the run's damping;
* with ``--minimise``: the stable state the energy minimiser (``minimise_to_stable``, the polish
  the run itself applies at rest) reaches from there, its energy, symmetry and the relative
  difference to a minimisation run's landing (``--landing-energy``).

    scripts/in-env python3 benchmarks/snap_dynamics_state.py RUN_DIR [--minimise]
        [--landing-energy E] [--eigenvalues K] [--window T] [--out FILE]

Writes benchmarks/results/snap_dynamics_state.json (``--out``) and prints a summary.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from shells.analyses.snap import SERIES_COLUMNS as COLUMNS

sys.path.insert(0, str(Path(__file__).resolve().parent))

OUT = Path("benchmarks/results/snap_dynamics_state.json")


def growth(series: np.ndarray, window: float) -> dict[str, float]:
    """The exponential growth rate of each amplitude m = 1..4 over the series' last ``window``
    time units (log-linear fit; per unit R √(ρ/E))."""
    t = series[:, 0]
    sel = t >= t[-1] - window
    out = {}
    for j, name in enumerate(COLUMNS[5:], start=5):
        a = series[sel, j]
        if np.all(a > 0) and sel.sum() >= 3:
            out[name] = float(np.polyfit(t[sel], np.log(a), 1)[0])
    return out


def main() -> None:
    import snap_orbit_pinning as pinning
    from mpi4py import MPI

    from shells.algorithms.stability import Stability
    from shells.analyses.snap import DAMPING, classify_landing
    from shells.analyses.store import load_state_checkpoint
    from shells.problem.interface import set_state

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir", type=Path)
    ap.add_argument("--minimise", action="store_true",
                    help="also minimise from the state (the polish the run applies at rest)")
    ap.add_argument("--landing-energy", type=float, default=None,
                    help="a minimisation run's landing energy to compare with")
    ap.add_argument("--eigenvalues", type=int, default=6)
    ap.add_argument("--window", type=float, default=50.0)
    ap.add_argument("--out", type=Path, default=OUT, help="the JSON written")
    a = ap.parse_args()
    comm = MPI.COMM_WORLD
    meta = json.loads((a.run_dir / "checkpoint" / "meta.json").read_text())
    header = meta["header"]
    if header["method"] != "dynamics" or "progress" not in meta:
        sys.exit(f"{a.run_dir}: not a dynamics run under way (stage {meta.get('stage')})")
    damping = DAMPING if header["damping"] is None else header["damping"]
    model = pinning.build(header, header["size"], header["layer_elements"])
    got = load_state_checkpoint(a.run_dir / "checkpoint", model, ("w",))
    if got is None:
        sys.exit(f"{a.run_dir}: the checkpoint cannot be read on this mesh")
    _, states, scalars = got
    kappa = (1 + header["past"]) * meta["kappa_fold"]
    model.set_kappa(kappa)
    set_state(model, states["w"])
    series = np.asarray(scalars["series"]).reshape(-1, len(COLUMNS))
    out = {"run": str(a.run_dir), "header": header, "damping": damping,
           "kappa_R": kappa * header["shape"]["R"], "dofs": model.num_dofs(),
           "steps": meta["progress"]["steps"],
           "last": dict(zip(COLUMNS, map(float, series[-1]), strict=True)),
           "kinetic_peak": float(series[:, 1].max()),
           "growth_rates": growth(series, a.window), "window": a.window}
    state = classify_landing(model)
    out["state"] = {k: state[k] for k in ("energy", "negative_count", "orbit_modes", "mode_m",
                                          "symmetric", "spectrum")}
    stab = Stability(model)
    vals, vecs = stab.eigenpairs(a.eigenvalues, modes=True)
    stab.destroy()
    eig = []
    for mu, v in zip(vals, vecs, strict=True):
        power = model.azimuthal_spectrum(v)
        row = {"mu": float(mu), "mode_m": int(np.argmax(power))}
        if mu < 0:  # s² + α s + μ = 0, the unstable root
            row["growth_rate"] = 0.5 * (-damping + math.sqrt(damping**2 - 4 * mu))
        eig.append(row)
        v.destroy()
    out["eigenvalues"] = eig
    if a.minimise:
        from shells.algorithms.minimise import minimise_to_stable

        t0 = time.perf_counter()
        res = minimise_to_stable(model)
        land = classify_landing(model, (res.negative_count, res.orbit_modes))
        out["minimised"] = {"reason": res.reason, "iterations": res.iterations,
                            "wall_time": time.perf_counter() - t0,
                            **{k: land[k] for k in ("energy", "stable", "mode_m", "symmetric",
                                                    "rim_rotation_deg")}}
        if a.landing_energy is not None:
            out["minimised"]["relative_difference"] = (
                (land["energy"] - a.landing_energy) / abs(a.landing_energy))
    if comm.rank == 0:
        a.out.parent.mkdir(parents=True, exist_ok=True)
        a.out.write_text(json.dumps(out, indent=1) + "\n")
        last = out["last"]
        print(f"step {out['steps']}, t = {last['time']:.2f} R sqrt(rho/E), damping {damping:g}: "
              f"kinetic {last['kinetic']:.3g} ({last['kinetic'] / out['kinetic_peak']:.2g} of "
              f"its peak), elastic {last['elastic']:.10g}")
        print("amplitudes m = 1..4: " + " ".join(f"{last[c]:.4g}" for c in COLUMNS[5:])
              + f"; growth rates over the last {a.window:g}: "
              + " ".join(f"{k[-2:]} {v:+.2e}" for k, v in out["growth_rates"].items()))
        st = out["state"]
        print(f"state: energy {st['energy']:.10g}, m = {st['mode_m']}, negative "
              f"{st['negative_count']} (orbit {st['orbit_modes']})")
        print(f"{'mu':>12} {'m':>3} {'growth rate':>12}")
        for r in eig:
            print(f"{r['mu']:12.4e} {r['mode_m']:3d} {r.get('growth_rate', float('nan')):12.3e}")
        if a.minimise:
            m = out["minimised"]
            print(f"minimised: {m['reason']} in {m['iterations']} iterations, energy "
                  f"{m['energy']:.13g}, {'stable' if m['stable'] else 'UNSTABLE'}, m = "
                  f"{m['mode_m']}" + (f", relative difference {m['relative_difference']:.2e}"
                                      if "relative_difference" in m else ""))


if __name__ == "__main__":
    main()
