"""The closed sphere's curvature buckling and its subcritical post-buckling branch (the paper's
Fig. 3), on the 1D model through ``shells.analyses.postbuckle``: Ψ3(pole)/h against κ/κ_b for h/R =
0.001, 0.01 and 0.1 (ν = ½), the theory line -κh/12, the located κ_b, the branch switched onto at
it with rotational symmetry enforced (the inward-dimple side), axisymmetric profiles and a 3D
render of a buckled sphere. Writes JSON, PNG/PDF figures and a VTK shape, and prints a table.

    scripts/in-env python3 benchmarks/sphere_postbuckling.py [OUTDIR [--figure-only|--render-only]]
    (OUTDIR: default benchmarks/results; --figure-only redraws the figure, --render-only the 3D
    render (and its .vts and profile CSV), from the JSON of a previous run)
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from shells.analyses.postbuckle import PostbuckleConfig, postbuckle
from shells.axisym.revolve import revolve, write_profile_csv, write_vts
from shells.geometry.shapes import Sphere
from shells.theory import sphere_kappa_b_h

H_OVER_R = (0.001, 0.01, 0.1)
PROFILE_AT = (0.95, 0.85, 0.75)  # κ/κ_b on the inward branch where profiles are kept


def run_one(h: float, max_points: int) -> dict:
    t0 = time.perf_counter()
    profiles: dict[float, dict] = {}
    kc: list[float] = []

    def on_point(model, rec) -> None:
        if rec["branch"] == "bifurcated" and rec["side"] == -1 and kc:
            ratio = rec["kappa"] / kc[0]
            for target in PROFILE_AT:
                if target not in profiles and ratio <= target:
                    profiles[target] = {k: v.copy() for k, v in model.meridian_profile().items()}
                    profiles[target]["kappa_over_kappa_b"] = ratio

    recs = []
    for r in postbuckle(PostbuckleConfig(Sphere(1.0), h, max_points=max_points,
                                         kappa_min_ratio=0.3), on_point):
        if "critical_point" in r:
            kc.append(r["critical_point"]["kappa"])
        recs.append(r)
    cp = next(r["critical_point"] for r in recs if "critical_point" in r)
    fund = [r for r in recs if r.get("branch") == "fundamental"]
    bif = [r for r in recs if r.get("branch") == "bifurcated"]
    down = [r for r in bif if r["side"] == -1]
    lin = [r for r in fund if 0 < r["kappa"] <= 0.9 * cp["kappa"]]
    slope = float(np.polyfit([r["kappa_h"] for r in lin],
                             [r["psi3_pole_over_h"] for r in lin], 1)[0])
    keys = ("kappa", "kappa_h", "psi3_pole_over_h", "psi3_over_h", "energy", "negative_count",
            "negative_count_axisymmetric", "negative_counts", "orientation_modes",
            "mode_amplitude", "branch", "side", "start", "subcritical", "kappa_c",
            "control_parameter")
    return {"h_over_R": h, "critical_point": cp, "wall_s": time.perf_counter() - t0,
            "kappa_b_h_thin_limit": sphere_kappa_b_h(0.5),
            "slope_psi3_vs_kappa_h": slope, "slope_theory": -1.0 / 12 / (1 + h * h / 12),
            "min_kappa_over_kappa_b": min(r["kappa"] for r in down) / cp["kappa"] if down
            else None,
            "kappa_over_kappa_b_at_depth": _at_depths(down, cp["kappa"]),
            "secondary": _secondary(down, cp["kappa"]),
            # the critical points the postbuckle run located on the inward side (its summary)
            "located_on_inward_side": _located(recs, down),
            "summary": recs[-1]["summary"],
            "points": [{k: r.get(k) for k in keys} for r in fund + bif],
            "profiles": {str(k): {kk: (vv.tolist() if isinstance(vv, np.ndarray) else vv)
                                  for kk, vv in p.items()} for k, p in profiles.items()}}


DEPTHS = (2.0, 5.0, 10.0, 20.0)  # Ψ3(pole)/h = -depth: where the curves are compared


def _secondary(down: list[dict], kc: float) -> dict | None:
    """The first point of the inward side, past its first two (next to κ_b the neighbouring
    degrees are still unstable), where the dimple has a negative eigenvalue besides its own and
    besides its sliding over the sphere (``orientation_modes``): depth, κ/κ_b and the Fourier
    blocks m with a negative count there (m = 0: an axisymmetric one more). None if none."""
    for r in down[2:]:
        if r["negative_count"] - r["orientation_modes"] > 1:
            counts = r["negative_counts"]
            blocks = [m for m, c in enumerate(counts) if c > (1 if m == 0 else 0)
                      and not (m == 1 and 2 * c <= r["orientation_modes"])]
            return {"depth": -r["psi3_pole_over_h"], "kappa_over_kappa_b": r["kappa"] / kc,
                    "negative_count": r["negative_count"],
                    "orientation_modes": r["orientation_modes"], "blocks": blocks,
                    "negative_counts": counts}
    return None


def _located(recs: list[dict], down: list[dict]) -> list[dict]:
    """The inward side's located critical points, each with the depths of the two points
    that bracket it."""
    out = []
    for i, r in enumerate(down):
        for c in r.get("critical", []):
            out.append({**c, "depth_between": [-down[i - 1]["psi3_pole_over_h"],
                                               -r["psi3_pole_over_h"]]})
    return out


def _at_depths(down: list[dict], kc: float) -> dict[str, float | None]:
    """κ/κ_b on the inward side at the pole depths ``DEPTHS`` (linear interpolation over the
    part parametrised by the depth, where it grows monotonically; None if not reached)."""
    part = [r for r in down if r.get("control_parameter", 1.0) == 1.0]
    d = np.array([-r["psi3_pole_over_h"] for r in part])
    k = np.array([r["kappa"] / kc for r in part])
    out: dict[str, float | None] = {}
    for depth in DEPTHS:
        ok = len(d) > 1 and np.all(np.diff(d) > 0) and d[0] <= depth <= d[-1]
        out[f"{depth:g}"] = float(np.interp(depth, d, k)) if ok else None
    return out


def figure(results: list[dict], out: Path) -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, axp) = plt.subplots(1, 2, figsize=(10.5, 4.2),
                                  gridspec_kw={"width_ratios": [1.5, 1]})
    colors = {0.001: "tab:blue", 0.01: "tab:green", 0.1: "tab:red"}
    x = np.linspace(0, 1, 50)
    ax.plot(x, -x * sphere_kappa_b_h(0.5) / 12, "k-", lw=2, label=r"theory $-\kappa h/12$")
    for res in results:
        h, kc = res["h_over_R"], res["critical_point"]["kappa"]
        c = colors.get(h, None)
        pts = res["points"]
        f = [p for p in pts if p["branch"] == "fundamental" and p["kappa"] <= kc]
        ax.plot([p["kappa"] / kc for p in f], [p["psi3_pole_over_h"] for p in f], "--",
                color=c, lw=1)
        for side in (1, -1):
            d = [p for p in pts if p["branch"] == "bifurcated" and p["side"] == side]
            if not d:
                continue
            # side -1 pushes the pole in (the dimple, the paper's branch), +1 out
            inward = side == -1
            ax.plot([1.0] + [p["kappa"] / kc for p in d],
                    [f[-1]["psi3_pole_over_h"]] + [p["psi3_pole_over_h"] for p in d],
                    "-" if inward else ":", color=c, lw=1.5 if inward else 1,
                    label=f"h/R = {h:g}, n = {res['critical_point']['mode_n']}"
                    + (" (pole inwards, unstable)" if inward else " (pole outwards)"))
    ax.set_xlabel(r"$\kappa/\kappa_b$")
    ax.set_ylabel(r"$\Psi_3(\mathrm{pole})/h$")
    ax.set_xlim(0, 1.05)
    ax.set_ylim(-40, 1.0)
    ax.legend(fontsize=8, loc="lower left")
    ax.set_title("closed sphere, 1D model, nu = 1/2")
    ref = next((r for r in results if r["h_over_R"] == 0.01), results[0])
    h = ref["h_over_R"]
    for _key, prof in sorted(ref["profiles"].items(), key=lambda kv: -float(kv[0])):
        r0, z0 = np.array(prof["r0"]), np.array(prof["z0"])
        rr, zz = r0 + np.array(prof["ur"]), z0 + np.array(prof["uz"])
        sel = z0 > 0.6  # the cap around the north pole, where the dimple is
        axp.plot(rr[sel], zz[sel], label=f"kappa/kappa_b = {prof['kappa_over_kappa_b']:.2f}")
    t = np.linspace(0, 0.9, 100)
    axp.plot(np.sin(t), np.cos(t), "k:", lw=0.8, label="reference")
    axp.set_aspect("equal")
    axp.set_title(f"axisymmetric profiles, h/R = {h:g}")
    axp.legend(fontsize=7)
    fig.tight_layout()
    paths = []
    for ext in ("png", "pdf"):
        p = out / f"sphere_postbuckling.{ext}"
        fig.savefig(p, dpi=150)
        paths.append(str(p))
    plt.close(fig)
    return paths


def _cutaway(grid, n_phi: int):
    """A revolved grid without the quarter of azimuths that faces the renders' camera (-y):
    the cut meridians show the dimple's profile."""
    q = (n_phi - 1) // 8
    part = grid.extract_subset((0, grid.dimensions[0] - 1, q, n_phi - 1 - q, 0, 0))
    return part.rotate_z(-90.0, inplace=False)


def render_3d(res: dict, out: Path) -> list[str]:
    """The buckled sphere at the deepest kept profile: VTK (.vts) and an off-screen render
    (the deformed shape cut open, coloured by Ψ3/h, the reference sphere's outline beside)."""
    from shells.analyses.render import render_surface

    key = min(res["profiles"], key=float)
    prof = {k: np.asarray(v) for k, v in res["profiles"][key].items()}
    h = res["h_over_R"]
    # exaggerate nothing: the dimple is tens of thicknesses deep
    grid = revolve(prof)
    vts = write_vts(grid, out / "sphere_postbuckled.vts")
    write_profile_csv(prof, out / "sphere_postbuckled_profile.csv", h)
    n_phi = 193
    shape = revolve(prof, n_phi=n_phi)
    shape.point_data["psi3_over_h"] = shape.point_data["normal_displacement"] / h
    reference = revolve({**prof, "ur": 0 * prof["ur"], "uz": 0 * prof["uz"]}, n_phi=n_phi)
    png = str(out / "sphere_postbuckled_3d.png")
    render_surface(_cutaway(shape, n_phi), png, scalars="psi3_over_h", symmetric=True,
                   reference=_cutaway(reference, n_phi), label="normal displacement $\\Psi_3/h$",
                   title=f"closed sphere, h/R = {h:g}: the dimpled branch at κ/κ_b = "
                         f"{prof['kappa_over_kappa_b']:.2f} (grey: the sphere)",
                   elevation=30.0, azimuth=0.0)
    return [vts, png]


def main(outdir: str = "benchmarks/results", *flags: str) -> None:
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    if "--figure-only" in flags or "--render-only" in flags:  # from a previous run's JSON
        results = json.loads((out / "sphere_postbuckling.json").read_text())["results"]
        files = (figure(results, out) if "--figure-only" in flags else
                 render_3d(next(r for r in results if r["h_over_R"] == 0.01), out))
        print("files:", ", ".join(files))
        return
    results = [run_one(h, 80) for h in H_OVER_R]
    files = figure(results, out) + render_3d(next(r for r in results
                                                  if r["h_over_R"] == 0.01), out)
    (out / "sphere_postbuckling.json").write_text(json.dumps(
        {"results": results, "files": files}, indent=1, default=float))
    print(f"{'h/R':>6} {'kappa_b h':>10} {'n':>3} {'slope':>9} {'theory':>9} "
          f"{'min k/kb':>8} " + " ".join(f"{'k/kb@' + format(-d, 'g'):>9}" for d in DEPTHS)
          + f" {'wall s':>6}")
    for r in results:
        cp = r["critical_point"]
        at = r["kappa_over_kappa_b_at_depth"]
        print(f"{r['h_over_R']:6g} {cp['kappa_h']:10.5f} {cp['mode_n']:3d} "
              f"{r['slope_psi3_vs_kappa_h']:9.5f} {r['slope_theory']:9.5f} "
              f"{r['min_kappa_over_kappa_b'] or math.nan:8.3f} "
              + " ".join(f"{at[f'{d:g}'] if at[f'{d:g}'] is not None else math.nan:9.4f}"
                         for d in DEPTHS) + f" {r['wall_s']:6.1f}")
    for r in results:
        sec = r["secondary"]
        print(f"h/R = {r['h_over_R']:g}, inward side: " + (
            "one negative eigenvalue (the dimple's own, its sliding apart) to the last point"
            if sec is None else
            f"a negative eigenvalue besides the dimple's own and its sliding from "
            f"{sec['depth']:.1f} h deep (kappa/kappa_b = {sec['kappa_over_kappa_b']:.3f}): "
            f"blocks m = {sec['blocks']}, counts by m {sec['negative_counts']}"))
        for c in r.get("located_on_inward_side", []):
            print(f"  located: {c['kind']} m = {c['mode_m']} at kappa/kappa_b = "
                  f"{c['kappa_over_kappa_c']:.5f} (accuracy {c['accuracy']:.1e}), between "
                  f"{c['depth_between'][0]:.2f} and {c['depth_between'][1]:.2f} h deep")
    print("files:", ", ".join(files))


if __name__ == "__main__":
    main(*sys.argv[1:])
