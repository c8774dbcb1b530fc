"""A recorded landing's reading reproduced from another landing's state, turned (issue 41).

Until the landings were read in the shell's best-fit rigid frame (``shells.surface.frame``),
their azimuthal spectrum, rim rotation and Ψ3 at the pole were read in the gauge's
representative, which holds an m = 2 pattern tilted by an angle that depends on the pattern's
orientation ψ against the gauge points. Where one landing's state is gone (the default-mesh
dynamics run of Fig. 1 d; its snap.json and ψ were recorded), this script takes the other
landing's state (a `shells snap -o DIR` run's checkpoint on the same mesh), turns it about the
axis until its gauge-read orientation is the recorded ψ (secant on the turn; interpolated,
the gauge met again, converged with ``minimise_to_stable``) and reads it both ways: if the
gauge reading there is the recorded one, the two landings are one state read at two
orientations; the frame reading is the same at both orientations.

    scripts/in-env python3 benchmarks/snap_landing_reading.py DIR SNAP_JSON PSI_DEG
        [--out FILE]

SNAP_JSON: a JSON file holding the recorded snap result (its "landing"), at its top level or
under "snap". Writes benchmarks/results/snap_landing_reading.json (``--out``).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from snap_orbit_pinning import build, converge, orientation, transfer  # noqa: E402

OUT = Path("benchmarks/results/snap_landing_reading.json")


def readings(model) -> dict:
    """The state's spectrum (m = 0..6 over m = 0), rim rotation and Ψ3 at the pole, read in
    the gauge's representative and in the best-fit frame, and its energy (collective)."""
    def read() -> dict:
        p = model.azimuthal_spectrum(model.state)
        s = model.scalars()
        return {"spectrum": [float(a) for a in np.sqrt(p / p[0])[:7]],
                "rim_rotation_deg": s["rim_rotation_deg"],
                "psi3_pole_over_h": s["psi3_pole_over_h"]}

    out = {"energy": model.total_energy(),
           "psi_gauge_deg": math.degrees(orientation(model, frame=False)), "gauge": read()}
    with model.rigid_frame().aligned():
        out["frame"] = read()
        out["psi_frame_deg"] = math.degrees(orientation(model, frame=False))
    return out


def main() -> None:
    from mpi4py import MPI

    from shells.analyses.store import load_state_checkpoint
    from shells.problem.interface import get_state, set_state

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir", type=Path)
    ap.add_argument("recorded", type=Path)
    ap.add_argument("psi_deg", type=float, help="the recorded landing's gauge-read orientation")
    ap.add_argument("--out", type=Path, default=OUT, help="the JSON written")
    a = ap.parse_args()
    rec = json.loads(a.recorded.read_text())
    rec = rec.get("snap", rec)["landing"]
    meta = json.loads((a.run_dir / "checkpoint" / "meta.json").read_text())
    header = meta["header"]
    model = build(header, header["size"], header["layer_elements"])
    other = build(header, header["size"], header["layer_elements"])
    kappa = (1 + header["past"]) * meta["kappa_fold"]
    _, got, _ = load_state_checkpoint(a.run_dir / "checkpoint", model, ("w",))
    for m in (model, other):
        m.set_kappa(kappa)
    set_state(model, got["w"])
    first = converge(model)
    w0 = get_state(model)
    at_start = readings(model)
    target = math.radians(a.psi_deg)

    def psi_after(turn: float) -> float:
        set_state(other, w0)
        transfer(other, model, turn)
        d = orientation(model, frame=False) - target
        return (d + math.pi / 2) % math.pi - math.pi / 2  # ψ is defined modulo π

    t0 = (target - math.radians(at_start["psi_gauge_deg"]) + math.pi / 2) % math.pi - math.pi / 2
    t1 = t0 + math.radians(1.0)
    f0, f1 = psi_after(t0), psi_after(t1)
    for _ in range(12):
        if abs(f1) < math.radians(0.01) or f1 == f0:
            break
        t0, t1, f0 = t1, t1 - f1 * (t1 - t0) / (f1 - f0), f1
        f1 = psi_after(t1)
    psi_after(t1)
    turned_converged = converge(model)
    at_turn = readings(model)
    rec_spec = rec["spectrum"][:7]
    gap = {"spectrum": float(np.max(np.abs(np.array(at_turn["gauge"]["spectrum"]) - rec_spec))),
           "rim_rotation_deg": at_turn["gauge"]["rim_rotation_deg"] - rec["rim_rotation_deg"],
           "psi3_pole_over_h": at_turn["gauge"]["psi3_pole_over_h"] - rec["psi3_pole_over_h"],
           "energy_relative": (at_turn["energy"] - rec["energy"]) / abs(rec["energy"])}
    frame_gap = {"spectrum": float(np.max(np.abs(np.array(at_turn["frame"]["spectrum"])
                                                 - at_start["frame"]["spectrum"]))),
                 "rim_rotation_deg": at_turn["frame"]["rim_rotation_deg"]
                 - at_start["frame"]["rim_rotation_deg"],
                 "psi3_pole_over_h": at_turn["frame"]["psi3_pole_over_h"]
                 - at_start["frame"]["psi3_pole_over_h"]}
    out = {"run": str(a.run_dir), "recorded": str(a.recorded), "recorded_psi_deg": a.psi_deg,
           "recorded_landing": {k: rec[k] for k in ("energy", "spectrum", "rim_rotation_deg",
                                                    "psi3_pole_over_h")},
           "converged": first, "at_start": at_start, "turn_deg": math.degrees(t1),
           "turned_converged": turned_converged, "at_turn": at_turn,
           "gauge_reading_minus_recorded": gap, "frame_reading_turned_minus_start": frame_gap}
    if MPI.COMM_WORLD.rank == 0:
        a.out.write_text(json.dumps(out, indent=1) + "\n")
        r = np.round
        print(f"turned by {math.degrees(t1):.3f} deg to gauge-read psi "
              f"{at_turn['psi_gauge_deg']:.3f} (recorded {a.psi_deg:.3f})")
        print(f"{'':18} {'m1':>7} {'m2':>7} {'m3':>7} {'rim deg':>9} {'Psi3/h':>9} "
              f"{'energy':>14}")
        rows = [("recorded", rec_spec, rec["rim_rotation_deg"], rec["psi3_pole_over_h"],
                 rec["energy"])]
        rows += [(f"{where}, {how}", r[how]["spectrum"], r[how]["rim_rotation_deg"],
                  r[how]["psi3_pole_over_h"], r["energy"])
                 for how in ("gauge", "frame") for where, r in (("turned", at_turn),
                                                                ("start", at_start))]
        for name, sp, rim, psi3, e in rows:
            print(f"{name:18} {sp[1]:7.4f} {sp[2]:7.4f} {sp[3]:7.4f} {rim:9.4f} {psi3:9.4f} "
                  f"{e:14.10f}")
        print("gauge reading minus recorded:", {k: float(r(v, 6)) for k, v in gap.items()})


if __name__ == "__main__":
    main()
