"""The paper's 3D results on the surface model: Fig. 1 (c) the spindle-like buckled cap (κ < 0,
on its m = 2 post-buckled branch), Fig. 1 (d) the snap-through of a θ̄ = 5 cap at h/R = 0.04
followed through the snap onto the everted side, and the ellipsoids of Fig. S5 (r1 = r2 = R,
r3 = 1.5 R, h/R = 0.04, θ = π/2; κR with R = r1): buckled for κ < 0, snapped for κ > 0.

    scripts/in-env mpirun -n 2 python3 benchmarks/shapes_3d.py [CASE ...] [--quick]

Cases: cap_buckled, cap_snap, ellipsoid_down, ellipsoid_up (default: all). Each case: the 1D
model's first critical point (converged in seconds), the surface model's (P3, bulk size 0.2 R,
3 elements across the rim layer: P2 locks on deep shells, docs/model.md), then the post-critical
states: the m-branch by branch switching (``shells.analyses.postbuckle``), or the fundamental branch
by pseudo-arclength through the snap fold to rim rotations above 90° and the snapped (everted)
state just past the fold's κ, from the mirrored shell (the connected axisymmetric path winds
through a dozen folds before it reaches the stable everted branch: the 1D model's branch of the
θ̄ = 5 cap, ``shells branch --model axisym``). Renders (pyvista, off-screen, coloured by the
bending energy density e_b) in ``benchmarks/results/shapes_3d/CASE_*.png``, the same states as
``.vtu`` (ParaView's default reader; not committed), the numbers merged into
``benchmarks/results/shapes_3d.json``, a table printed. ``--quick``: a coarser mesh (size
0.3, P2), to try the script.
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

from mpi4py import MPI

from shells.algorithms.following import follow
from shells.algorithms.settings import ContinuationSettings, CriticalSettings
from shells.analyses import axisym_runs
from shells.analyses.postbuckle import PostbuckleConfig, postbuckle
from shells.analyses.render import render_state
from shells.geometry.shapes import EllipsoidalCap, SphericalCap, kappa_length
from shells.surface.mesh import MeshSpec, generate
from shells.surface.model import ModelParameters, ShellModel

HERE = Path(__file__).parent
OUT = HERE / "results" / "shapes_3d"
JSON = HERE / "results" / "shapes_3d.json"
H = 0.04
CAP = SphericalCap(1.0, 5.0 * math.sqrt(H))  # θ̄ = 5: θ = 1 rad = 57.3°
ELL = EllipsoidalCap(1.0, 1.5, math.pi / 2)
CASES = {
    "cap_buckled": (CAP, "down", -1.0, "branch"),
    "cap_snap": (CAP, "up", 4.0, "snap"),
    "ellipsoid_down": (ELL, "down", -1.0, "branch"),
    "ellipsoid_up": (ELL, "up", 8.0, "snap"),
}


def say(msg: str) -> None:
    if MPI.COMM_WORLD.rank == 0:
        print(msg, flush=True)


def _cp(c, R: float) -> dict:
    return {"kind": c.kind, "kappa_R": c.kappa * R, "mode_m": c.mode_m}


def snap_case(name: str, shape, kappa_end: float, mesh: dict) -> dict:
    """Follow the fundamental branch from κ = 0 through its first critical points and the snap
    fold, on past a rim rotation of 90° (the earlier director could not turn that far); then
    the snapped (everted) state at 1.1 times the fold's κ, by Newton from the shell mirrored
    through its rim plane (the mirror chart), with its stability. The connected axisymmetric
    path would reach the stable everted branch only through many more folds (the 1D model's
    branch of the θ̄ = 5 cap turns a dozen times first); a snap jumps there at once."""
    from shells.algorithms.stability import Stability

    R = kappa_length(shape)
    h = H * shape.characteristic_size()
    sm = generate(MeshSpec(shape, h=h, size=mesh["size"], layer_elements=mesh["layer"]),
                  MPI.COMM_WORLD)
    params = ModelParameters(h=h, nu=0.5, degree=mesh["degree"],
                             quadrature_degree=2 * mesh["degree"])
    model = ShellModel(sm, params)
    st = ContinuationSettings(ds=0.15, ds_max=0.3, ds_min=1e-7, ds_unit="kappa",
                              target_newton_its=5, max_steps=400)
    # after the first bifurcation the inertia is no longer computed: folds are located
    crit = CriticalSettings(stop_at_fold=False, folds_only_after_first=True)
    found, path, past_90 = [], [], 0
    for p, res, cps in follow(model, st, kappa_end / R, crit):
        s = p.scalars
        path.append({"kappa_R": p.kappa * R, "rim_rotation_deg": s.get("rim_rotation_deg"),
                     "energy": s["energy"], "negative_count": res.negative_count,
                     "dkappa_ds": p.dkappa_ds})
        found.extend(cps)
        say(f"  {name}: kappa R = {p.kappa * R:+.4f}  rim rotation = "
            f"{s.get('rim_rotation_deg', float('nan')):7.2f} deg  negative = "
            f"{res.negative_count}")
        folded = any(c.kind == "fold" for c in found)
        if folded and len(path) and past_90 == 0:
            # the first point past the snap fold: the shape as it starts to snap
            render_state(model, OUT / f"{name}_snap_onset.png",
                         vtu=OUT / f"{name}_snap_onset.vtu",
                         title=f"{name}: past the snap fold, kappa R = {p.kappa * R:.3f}")
            past_90 = 1
        if folded and s["rim_rotation_deg"] > 90:
            past_90 += 1
            if past_90 > 3:
                break
    fold = next((c for c in found if c.kind == "fold"), None)
    out = {"dofs": model.num_dofs(), "critical_points": [_cp(c, R) for c in found],
           "path": path, "rim_rotation_path_max_deg": max(q["rim_rotation_deg"] for q in path)}
    if fold is None:
        return out
    # the snapped state: the mirror chart at 1.1 κ_fold, by natural continuation (steps of at
    # most 0.1 κ_fold, halved where Newton fails) from a κ where Newton converges from the
    # mirrored shell (a sphere cap's mirror is an equilibrium at 2/R; an ellipsoid's at none)
    from shells.algorithms.continuation import continuation

    ev = ShellModel(sm, params)
    nat = ContinuationSettings(method="natural", ds=0.1 * fold.kappa_L, ds_max=0.1 * fold.kappa_L,
                               ds_min=1e-4 * fold.kappa_L, max_newton_its=25)
    ok = False
    for start in (0.5, 0.35, 0.25):
        ev.set_everted_guess()
        try:
            for q in continuation(ev, nat, kappa_start=start * fold.kappa,
                                  kappa_end=1.1 * fold.kappa):
                ok = abs(q.kappa - 1.1 * fold.kappa) <= 1e-9 * abs(fold.kappa)
        except RuntimeError as e:
            say(f"  {name}: from {start} kappa_fold, the everted state was not reached: {e}")
        if ok:
            break
    if ok:
        stab = Stability(ev)
        neg = stab.inertia()[0]
        vals = stab.eigenpairs(4, modes=True)
        modes = [ev.classify_mode(v).m for v in vals[1][:neg]] if neg else []
        stab.destroy()
        s = ev.scalars()
        out["everted"] = {"kappa_R": 1.1 * fold.kappa * R, "negative_count": neg,
                          "unstable_m": modes, "rim_rotation_deg": s["rim_rotation_deg"],
                          "energy": s["energy"]}
        say(f"  {name}: everted at kappa R = {1.1 * fold.kappa * R:.4f}: rim rotation "
            f"{s['rim_rotation_deg']:.1f} deg, negative {neg} (m = {modes})")
        render_state(ev, OUT / f"{name}_everted.png", vtu=OUT / f"{name}_everted.vtu",
                     title=f"{name}: everted, kappa R = {1.1 * fold.kappa * R:.3f}, rim "
                     f"rotation {s['rim_rotation_deg']:.1f} deg")
    else:
        out["everted"] = {"kappa_R": ev.kappa.value * R, "converged": False}
    return out


def branch_case(name: str, shape, kappa_end: float, mesh: dict) -> dict:
    """The bifurcated branch of the first bifurcation going down (one side), to ``kappa_end``;
    renders its last state."""
    R = kappa_length(shape)
    cfg = PostbuckleConfig(shape=shape, h_over_r=H, nu=0.5, model="surface", direction="down",
                           kappa_end=kappa_end / R, size=mesh["size"],
                           layer_elements=mesh["layer"], degree=mesh["degree"], sides=(1,),
                           max_points=mesh["points"])
    last: dict = {}

    def on_point(model, rec):
        if rec.get("branch") == "bifurcated":
            last.update(rec)
            last["model"] = model
            say(f"  {name}: bifurcated kappa R = {rec['kappa_R']:+.4f}  stable = "
                f"{rec.get('stable')}  m = {rec.get('deviation_m')}")

    cp, points = None, []
    for rec in postbuckle(cfg, on_point):
        if "critical_point" in rec:
            cp = rec["critical_point"]
            say(f"  {name}: {cp['kind']} at kappa R = {cp['kappa_R']:.6f}, m = {cp.get('mode_m')}")
        elif rec.get("branch") == "bifurcated":
            points.append({k: rec.get(k) for k in ("kappa_R", "stable", "negative_count",
                                                   "orientation_modes", "deviation_m",
                                                   "mode_amplitude", "energy")})
    model = last.pop("model", None)
    if model is not None and name.startswith("ellipsoid"):
        from shells.analyses.render import render_mesh  # the undeformed shell (Fig. S5 b)

        render_mesh(model.shell, OUT / f"{name}_undeformed.png", title=f"{name}: undeformed")
    if model is not None:
        render_state(model, OUT / f"{name}_buckled.png", vtu=OUT / f"{name}_buckled.vtu",
                     title=f"{name}: m = {last.get('deviation_m')} branch, kappa R = "
                     f"{last['kappa_R']:.3f}")
    return {"critical_points": [{"kind": cp["kind"], "kappa_R": cp["kappa_R"],
                                 "mode_m": cp.get("mode_m")}] if cp else [],
            "branch": points, "end": {k: v for k, v in last.items() if k != "model"},
            "dofs": model.num_dofs() if model is not None else None}


def main(argv: list[str]) -> int:
    quick = "--quick" in argv
    names = [a for a in argv if not a.startswith("--")] or list(CASES)
    mesh = ({"size": 0.3, "layer": 2.0, "degree": 2, "points": 8} if quick
            else {"size": 0.2, "layer": 3.0, "degree": 3, "points": 80})
    results = json.loads(JSON.read_text()) if JSON.exists() and not quick else {}
    for name in names:
        if name not in CASES:
            say(f"unknown case {name!r}: choose from {', '.join(CASES)}")
            return 2
        shape, direction, kend, kind = CASES[name]
        say(f"=== {name}: {shape.describe()}, h/R = {H}, {direction} to kappa R = {kend}")
        t0 = time.perf_counter()
        one_d = axisym_runs.critical(shape, H, 0.5, direction=direction, kappa_max=abs(kend))
        t1 = time.perf_counter()
        two_d = (snap_case if kind == "snap" else branch_case)(name, shape, kend, mesh)
        t2 = time.perf_counter()
        first2 = two_d["critical_points"][0] if two_d["critical_points"] else None
        rec = {"shape": shape.describe(), "h_over_R": H, "direction": direction,
               "mesh": mesh, "ranks": MPI.COMM_WORLD.size,
               "axisym": {"kind": one_d["kind"], "kappa_R": one_d["kappa_R"],
                          "mode_m": one_d["mode_m"], "time_s": t1 - t0,
                          "critical_points": one_d["critical_points"][:3]},
               "surface": {**two_d, "time_s": t2 - t1},
               "relative_difference": (abs(first2["kappa_R"] / one_d["kappa_R"] - 1)
                                       if first2 and one_d["kappa_R"] else None)}
        results[name] = rec
        if MPI.COMM_WORLD.rank == 0 and not quick:
            JSON.write_text(json.dumps(results, indent=1))
    say(f"\n{'case':16} {'1D first':>24} {'surface first':>24} {'rel diff':>9} "
        f"{'end':>24} {'time':>7}")
    for name in names:
        r = results[name]
        a, s = r["axisym"], r["surface"]
        f2 = s["critical_points"][0] if s["critical_points"] else {}
        ev = s.get("everted", {})
        end = (f"path rim {s['rim_rotation_path_max_deg']:.0f}, everted "
               f"{ev.get('rim_rotation_deg', math.nan):.0f} deg" if "path" in s else
               f"m = {s['end'].get('deviation_m')} at {s['end'].get('kappa_R', math.nan):.3f}")
        rd = r["relative_difference"]
        say(f"{name:16} {a['kind']:>12} {a['kappa_R']:8.4f} m{a['mode_m']!s:<2} "
            f"{f2.get('kind', '-'):>12} {f2.get('kappa_R', math.nan):8.4f} "
            f"m{f2.get('mode_m')!s:<2} {rd if rd is None else f'{rd:9.2e}'} {end:>24} "
            f"{s['time_s']:6.0f}s")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
