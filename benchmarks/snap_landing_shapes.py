"""Are two landings of a snap the same state? Distance modulo the shell's symmetries (issue 41).

Two landing states of one cap (the checkpoints of two `shells snap -o DIR` runs on one mesh,
e.g. ``--method minimise`` and ``--method dynamics``) can differ by the symmetries of the free
shell, which change no energy: a rigid motion of the deformed shell (translation and rotation in
space; the gauge picks one representative, and a rigid turn leaves the azimuthal spectrum of
u·n° taken in material coordinates changed) and the orbit (the pattern turned about the
axis in material coordinates). This script removes both: it turns the second landing about the
axis (interpolated), aligns its deformed shell to the first's by the optimal rigid motion
(Kabsch, node-weighted) and searches the turn that makes the two closest. It reports

* the distance before and after, RMS over the nodes of the deformed positions, over h;
* both landings converged again on the mesh (``minimise_to_stable``) at that turn;
* the energy along the straight path between them in the gauged coordinates (a barrier, or a
  flat valley);
* the lowest eigenvalues of the Hessian at each (the softest directions and their m);
* the azimuthal spectra of each and of their difference, and how far each is from its own
  image under the half turn about the axis (modulo rigid motion: zero for an m = 2 pattern
  centred on the pole; the odd m of the spectrum measure the same, but a rigid tilt that the
  gauge adds to an off-centre pattern enters them too).

    scripts/in-env python3 benchmarks/snap_landing_shapes.py A_DIR B_DIR [--out FILE]

Writes benchmarks/results/snap_landing_shapes.json (``--out``) and prints a summary.
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

OUT = Path("benchmarks/results/snap_landing_shapes.json")


def kabsch(model, a: np.ndarray, b: np.ndarray) -> tuple[float, float, np.ndarray]:
    """The RMS distance / h between the deformed nodes of states a and b, b moved by the rigid
    motion that minimises it (collective); also that rotation's angle (degrees) and axis."""
    from mpi4py import MPI

    comm = model.shell.comm
    X = model.owned_dof_coordinates()
    Ya = X + a.reshape(-1, 6)[:, :3]
    Yb = X + b.reshape(-1, 6)[:, :3]
    n = comm.allreduce(len(X))
    ca = comm.allreduce(Ya.sum(axis=0), op=MPI.SUM) / n
    cb = comm.allreduce(Yb.sum(axis=0), op=MPI.SUM) / n
    A, B = Ya - ca, Yb - cb
    H = comm.allreduce(B.T @ A, op=MPI.SUM)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(Vt.T @ U.T))
    Q = Vt.T @ np.diag([1.0, 1.0, d]) @ U.T
    r2 = comm.allreduce(float(np.sum((A - B @ Q.T) ** 2)), op=MPI.SUM)
    angle = math.degrees(math.acos(np.clip((np.trace(Q) - 1) / 2, -1, 1)))
    axis = np.array([Q[2, 1] - Q[1, 2], Q[0, 2] - Q[2, 0], Q[1, 0] - Q[0, 1]])
    axis = axis / max(np.linalg.norm(axis), 1e-300)
    return math.sqrt(r2 / n) / model.params.h, angle, axis


def raw_distance(model, a: np.ndarray, b: np.ndarray) -> float:
    """RMS over the nodes of |u_a - u_b| / h in the gauged coordinates (collective)."""
    comm = model.shell.comm
    d = (a - b).reshape(-1, 6)[:, :3]
    n = comm.allreduce(len(d))
    return math.sqrt(comm.allreduce(float(np.sum(d**2))) / n) / model.params.h


def turned(model, other, b: np.ndarray, angle: float) -> np.ndarray:
    """State b (on ``other``, a model on the same mesh) turned about the axis by ``angle``,
    interpolated onto ``model`` and put back in the gauge."""
    from shells.problem.interface import get_state, set_state

    set_state(other, b)
    transfer(other, model, angle)
    return get_state(model)


def best_turn(model, other, a: np.ndarray, b: np.ndarray, guess: float) -> tuple[float, float]:
    """The turn of b about the axis that brings it closest to a modulo rigid motions (golden
    section over ±15° of ``guess``): (angle, distance / h)."""
    def f(t: float) -> float:
        return kabsch(model, a, turned(model, other, b, t))[0]

    lo, hi = guess - math.radians(15), guess + math.radians(15)
    g = (math.sqrt(5) - 1) / 2
    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    f1, f2 = f(x1), f(x2)
    while hi - lo > math.radians(0.02):
        if f1 < f2:
            hi, x2, f2 = x2, x1, f1
            x1 = hi - g * (hi - lo)
            f1 = f(x1)
        else:
            lo, x1, f1 = x1, x2, f2
            x2 = lo + g * (hi - lo)
            f2 = f(x2)
    return (x1, f1) if f1 < f2 else (x2, f2)


def softest(model, state: np.ndarray, k: int = 6) -> list[dict]:
    """The k eigenvalues of H v = μ M v nearest 0 at ``state``, each with its m and its share
    along the orbit."""
    from shells.algorithms.stability import Stability
    from shells.problem.interface import set_state

    set_state(model, state)
    stab = Stability(model)
    vals, vecs = stab.eigenpairs(k, modes=True)
    out = []
    for mu, v in zip(vals, vecs, strict=True):
        info = model.classify_mode(v, None)
        out.append({"mu": float(mu), "mode_m": info.m,
                    "orbit": float(info.rayleigh.get("orbit", 0.0))})
    stab.destroy()
    return out


def spectrum(model, values: np.ndarray) -> list[float]:
    """Amplitudes of m = 0..12 of u·n° of a state-shaped array, over m = 0's (or the raw ones
    for a difference, normalised by the largest)."""
    v = model.create_vector()
    v.array_w[:] = values[: v.getLocalSize()]
    p = model.azimuthal_spectrum(v)
    v.destroy()
    amp = np.sqrt(p)
    return [float(x) for x in amp / max(amp.max(), 1e-300)]


def main() -> None:
    from mpi4py import MPI

    from shells.analyses.store import load_state_checkpoint
    from shells.problem.interface import get_state, set_state

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("a_dir", type=Path)
    ap.add_argument("b_dir", type=Path)
    ap.add_argument("--out", type=Path, default=OUT, help="the JSON written")
    ap.add_argument("--path-points", type=int, default=11)
    a = ap.parse_args()
    dirs = {"a": a.a_dir, "b": a.b_dir}
    metas = {k: json.loads((d / "checkpoint" / "meta.json").read_text()) for k, d in dirs.items()}
    header = metas["a"]["header"]
    size, layer = header["size"], header["layer_elements"]
    model = build(header, size, layer)
    other = build(header, size, layer)
    kappa = (1 + header["past"]) * metas["a"]["kappa_fold"]
    states = {}
    for k, d in dirs.items():
        meta, got, _ = load_state_checkpoint(d / "checkpoint", model, ("w",))
        states[k] = got["w"]
    for m in (model, other):
        m.set_kappa(kappa)
    out: dict = {"header": header, "runs": {k: str(v) for k, v in dirs.items()},
                 "kappa_R": kappa, "dofs": model.num_dofs()}
    for k in dirs:
        set_state(model, states[k])
        out[k] = converge(model)
        states[k] = get_state(model)
        out[k]["orientation_deg"] = math.degrees(orientation(model))
        out[k]["spectrum"] = spectrum(model, states[k])
        out[k]["softest"] = softest(model, states[k])
        # an m = 2 pattern centred on the pole is its own image under the half turn
        out[k]["half_turn_asymmetry"] = kabsch(model, states[k],
                                               turned(model, other, states[k], math.pi))[0]
    A, B = states["a"], states["b"]
    out["distance_raw"] = raw_distance(model, A, B)
    out["distance_rigid"], out["rigid_angle_deg"], _ = kabsch(model, A, B)
    guess = math.radians(out["a"]["orientation_deg"] - out["b"]["orientation_deg"])
    cand = [best_turn(model, other, A, B, guess + t) for t in (0.0, math.pi)]
    angle, dist = min(cand, key=lambda q: q[1])
    Bt = turned(model, other, B, angle)
    out["turn_deg"], out["distance_turned_rigid"] = math.degrees(angle), dist
    set_state(model, Bt)
    out["b_turned"] = converge(model)
    Bt = get_state(model)
    out["distance_turned_converged_raw"] = raw_distance(model, A, Bt)
    d, ang, axis = kabsch(model, A, Bt)
    out["distance_turned_converged_rigid"] = d
    out["turned_rigid_angle_deg"], out["turned_rigid_axis"] = ang, axis.tolist()
    out["difference_spectrum"] = spectrum(model, Bt - A)
    path = []
    for s in np.linspace(0.0, 1.0, a.path_points):
        set_state(model, (1 - s) * A + s * Bt)
        path.append({"s": float(s), "energy": model.total_energy()})
    out["path"] = path
    e = np.array([q["energy"] for q in path])
    out["path_barrier_relative"] = float((e.max() - max(e[0], e[-1])) / abs(e[0]))
    out["relative_difference"] = float((e[-1] - e[0]) / abs(e[0]))
    if MPI.COMM_WORLD.rank == 0:
        a.out.write_text(json.dumps(out, indent=1) + "\n")
        print(f"energies: a {out['a']['energy']:.12f}  b {out['b']['energy']:.12f}  "
              f"b turned {out['b_turned']['energy']:.12f}  (rel. {out['relative_difference']:.2e})")
        print(f"distance / h: gauged {out['distance_raw']:.4g}, modulo rigid motion "
              f"{out['distance_rigid']:.4g}; turned by {out['turn_deg']:.2f} deg and converged: "
              f"gauged {out['distance_turned_converged_raw']:.4g}, modulo rigid motion "
              f"{out['distance_turned_converged_rigid']:.4g} (rotation {ang:.3f} deg)")
        print(f"path barrier (relative): {out['path_barrier_relative']:.3e}")
        for k in ("a", "b"):
            print(k, "softest:", [(round(q["mu"], 8), q["mode_m"], round(q["orbit"], 2))
                                  for q in out[k]["softest"]])
            print(k, "spectrum:", np.round(out[k]["spectrum"][:6], 4).tolist(),
                  f"half-turn asymmetry / h {out[k]['half_turn_asymmetry']:.4g}")
        print("difference spectrum:", np.round(out["difference_spectrum"][:6], 4).tolist())


if __name__ == "__main__":
    main()
