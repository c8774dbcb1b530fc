"""Phase diagram benchmark and the paper comparison (docs/paper-comparison.md).

    scripts/in-env mpirun -n 2 python3 benchmarks/phase_diagram.py [--points 36] [-o DIR]
    scripts/in-env python3 benchmarks/phase_diagram.py --doc-only      # rewrite the doc only

1. The phase diagram (``shells.analyses.phase_diagram``, axisymmetric model) for h/R = 0.01 and 0.04
   over θ̄ in [1, 20] (caps with θ > 0.9 π left out), both ranks computing points; its wall time.
2. Checks, split over the ranks: the closed sphere's κ_b h and the Ψ3 law on the axisymmetric
   model; the everted branch followed through the snap (κ_e = 2 - κ_b R, directly); mesh
   convergence of a few points (cells and rim layer doubled); the plate limit (surface-model
   results in benchmarks/results/plate_limit.json if present, else the axisymmetric disk).
3. JSON (benchmarks/results/phase_diagram.json) and the Markdown comparison.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

from mpi4py import MPI

from shells.analyses import phase_diagram
from shells.analyses.phase_diagram import (
    Discretisation,
    PhaseDiagramConfig,
    Task,
    compute_task,
    everted_check,
)
from shells.theory import PAPER, plate_a, sphere_kappa_b_h, sphere_psi3_linear

RESULTS = Path("benchmarks/results")


def sphere_checks(h_over_r: float, rel_tol: float) -> dict[str, Any]:
    """Closed sphere on the axisymmetric model: first critical κh and Ψ3/h against -κh/12."""
    from shells.analyses import axisym_runs
    from shells.geometry.shapes import Sphere

    t0 = time.perf_counter()
    crit = axisym_runs.critical(Sphere(1.0), h_over_r, 0.5, direction="down", rel_tol=rel_tol)
    psi = []
    for p in axisym_runs.branch(Sphere(1.0), h_over_r, 0.5, direction="up", m_max=0,
                                kappa_max=0.9 * sphere_kappa_b_h(0.5) / h_over_r):
        if p["kappa_h"] != 0:
            psi.append({"kappa_h": p["kappa_h"], "psi3_over_h": p["psi3_over_h"],
                        "law": sphere_psi3_linear(p["kappa_h"], h_over_r)})
    crit_up = axisym_runs.critical(Sphere(1.0), h_over_r, 0.5, direction="up", rel_tol=rel_tol)
    return {"h_over_R": h_over_r, "kappa_b_h_down": crit["kappa_h"], "mode_n_down":
            crit["mode_n"], "kappa_b_h_up": crit_up["kappa_h"], "mode_n_up": crit_up["mode_n"],
            "dofs": crit["dofs"], "psi3": psi, "wall_time": time.perf_counter() - t0}


def everted_with_down(h: float, tb: float, cfg: PhaseDiagramConfig) -> dict[str, Any]:
    """The everted branch followed directly, and the κ < 0 loss of symmetry at the same θ̄."""
    r = everted_check(h, tb, cfg)
    down = compute_task(Task(h, tb, "down", tag="everted"), cfg)
    r["kappa_down_R"] = (down.get("first") or {}).get("kappa_R")
    return r


def convergence_checks(cfg: PhaseDiagramConfig) -> list[dict[str, Any]]:
    """A few points on the default mesh and on a mesh with twice the cells and rim layer."""
    disc = cfg.discretisation
    fine = replace(cfg, discretisation=replace(disc, cells=2 * disc.cells,
                                               layer_cells=2 * disc.layer_cells))
    rows = []
    for h, tb, d in ((0.01, 3.0, "up"), (0.01, 8.0, "up"), (0.01, 8.0, "down"),
                     (0.04, 12.0, "down")):
        r = {}
        for name, c in (("default", cfg), ("fine", fine)):
            rec = compute_task(Task(h, tb, d, tag="convergence"), c)
            r[name] = {"first": rec.get("first"), "fold": (rec.get("fold") or {}).get("kappa_R"),
                       "dofs": rec.get("dofs"), "wall_time": rec["wall_time"]}
        rows.append({"h_over_R": h, "thetabar": tb, "direction": d, **r})
    return rows


def surface_check(args: argparse.Namespace) -> None:
    """One branch on the surface model (serial, COMM_SELF) beside the axisymmetric one."""
    h, tb, d = float(args.surface_check[0]), float(args.surface_check[1]), args.surface_check[2]
    rows = []
    for model in ("surface", "axisym"):
        cfg = PhaseDiagramConfig(h_over_r=(h,), thetabar_range=(tb, tb), points=1, model=model,
                                 discretisation=Discretisation(
                                     size=args.size, layer_elements=args.layer_elements))
        rec = compute_task(Task(h, tb, d, tag="surface-check"), cfg)
        rows.append(rec)
    if MPI.COMM_WORLD.rank == 0:
        f = RESULTS / "phase_diagram_surface.json"
        old = json.loads(f.read_text())["runs"] if f.exists() else []
        f.write_text(json.dumps({"runs": old + [{"surface": rows[0], "axisym": rows[1]}]},
                                indent=1))


def crosscheck(cfg: PhaseDiagramConfig) -> list[dict[str, Any]]:
    """Our tracing against ``shells.axisym.critical`` (bisection on the sign of dκ/ds at folds,
    chord-parametrised bisection at bifurcations, to the diagram's ``rel_tol``) on two
    caps."""
    from shells.analyses import axisym_runs
    from shells.geometry.shapes import SphericalCap

    rows = []
    for h, tb in ((0.04, 3.0), (0.01, 8.0)):
        shape = SphericalCap(1.0, tb * math.sqrt(h))
        ref = axisym_runs.critical(shape, h, cfg.nu, direction="up", m_max=cfg.m_max,
                                   kappa_max=1.6 * (0.85 * tb - 0.67) + 0.5,
                                   settings=axisym_runs.default_settings(shape, h,
                                                                         residual_tol=1e-6),
                                   rel_tol=cfg.rel_tol)
        ours = compute_task(Task(h, tb, "up", tag="crosscheck"), cfg)
        rows.append({"h_over_R": h, "thetabar": tb,
                     "critical": [(c["kind"], c["kappa_R"], c["mode_m"])
                                  for c in ref["critical_points"]],
                     "ours_first": ours.get("first"),
                     "ours_fold": (ours.get("fold") or {}).get("kappa_R")})
    return rows


_PLATE_NOTE = ("√(10+7√2) is a reduced-model value and carries no ν; the full energy's a(ν) "
               "is strongly ν-dependent (1D: 7.90 / 5.62 / 4.60 at ν = 0 / 0.3 / 0.5) and lies "
               "-1.3 % to +5.9 % from the uniform-curvature FvK value 8/(1+ν)^1.5 "
               "(`benchmarks/plate_limit.py --nu-study`)")


def plate_check(rel_tol: float) -> dict[str, Any]:
    f = RESULTS / "plate_limit.json"
    if f.exists():
        runs = json.loads(f.read_text()).get("runs", [])
        if runs:
            return {"source": str(f), "model": "surface", "runs": runs}
    from shells.analyses import axisym_runs
    from shells.geometry.shapes import Disk

    out = {"source": "axisym disk", "model": "axisym", "runs": []}
    for h in (0.01, 0.02):
        c = axisym_runs.critical(Disk(1.0), h, 0.5, direction="up", max_critical=1,
                                 rel_tol=rel_tol)
        out["runs"].append({"h_over_r": h, "kappa_r2_over_h": c["kappa_h"] / h**2,
                            "mode_m": c["mode_m"], "kind": c["kind"]})
    return out


def compute(args: argparse.Namespace) -> None:
    comm = MPI.COMM_WORLD
    cfg = PhaseDiagramConfig(h_over_r=(0.01, 0.04), thetabar_range=(1.0, 20.0),
                             points=args.points, refine=args.refine, rel_tol=args.rel_tol)
    comm.Barrier()
    if args.checks_only:
        old = json.loads((RESULTS / "phase_diagram.json").read_text())
        res, t_diagram = old["diagram"], old["diagram_wall_time"]
        load = old["load_average"]
    else:
        t0 = time.perf_counter()
        res = phase_diagram.run(cfg, args.output)
        t_diagram = time.perf_counter() - t0
        load = list(os.getloadavg())
    checks: dict[str, Any] = {}
    jobs = {"sphere": lambda: sphere_checks(0.01, cfg.rel_tol),
            "everted": lambda: [everted_with_down(0.04, 3.0, cfg),
                                everted_with_down(0.01, 3.5, cfg)],
            "convergence": lambda: convergence_checks(cfg),
            "plate": lambda: plate_check(cfg.rel_tol),
            "crosscheck": lambda: crosscheck(cfg)}
    for i, (name, job) in enumerate(jobs.items()):
        if i % comm.size == comm.rank:
            t1 = time.perf_counter()
            try:
                checks[name] = {"result": job(), "wall_time": time.perf_counter() - t1,
                                "rank": comm.rank}
            except Exception as e:  # noqa: BLE001 - reported in the doc
                checks[name] = {"error": f"{type(e).__name__}: {e}"}
    gathered = comm.gather(checks, root=0)
    if comm.rank == 0:
        allchecks = {k: v for d in gathered for k, v in d.items()}
        out = {"diagram": res, "diagram_wall_time": t_diagram, "ranks": comm.size,
               "load_average": load, "rel_tol": cfg.rel_tol, "checks": allchecks}
        RESULTS.mkdir(parents=True, exist_ok=True)
        (RESULTS / "phase_diagram.json").write_text(json.dumps(out, indent=1))
        try:
            write_doc(out, Path("docs/paper-comparison.md"))
        except Exception as e:  # noqa: BLE001 - the JSON is written: --doc-only redoes this
            print(f"the doc was not written: {e}")
        print(f"phase diagram: {len(res['points'])} points, {res['stats']['computed']} computed "
              f"in {t_diagram:.0f} s on {comm.size} ranks; fits {res['fits']}")


# ------------------------------------------------------------------------------------------------
# the Markdown comparison
# ------------------------------------------------------------------------------------------------
def _rel(ours: float | None, paper: float | None, nd: int = 1) -> str:
    if ours is None or paper is None or paper == 0:
        return "–"
    return f"{100 * (ours / paper - 1):+.{nd}f} %"


def _fmt(v: Any, err: Any = None, nd: int = 3) -> str:
    if v is None:
        return "–"
    s = f"{v:.{nd}f}"
    return s + (f" ± {err:.{nd}f}" if err is not None and math.isfinite(err) else "")


def _shapes_3d_rows(d: dict) -> list[str]:
    """The paper's 3D results on the surface model (benchmarks/shapes_3d.py): a row per case."""
    what = {"cap_buckled": "Fig. 1 (c): θ̄ = 5 cap, h/R = 0.04, κ < 0, buckled (spindle-like)",
            "cap_snap": "Fig. 1 (d): θ̄ = 5 cap, h/R = 0.04, κ > 0, snap-through",
            "ellipsoid_down": "Fig. S5 (a): ellipsoid r3 = 1.5 R, θ = 90°, h/R = 0.04, κ < 0",
            "ellipsoid_up": "Fig. S5 (c, d): ellipsoid r3 = 1.5 R, θ = 90°, h/R = 0.04, κ > 0"}
    paper = {"cap_buckled": "buckles (loss of rotational symmetry)",
             "cap_snap": "snaps, breaking the rotational symmetry (θ̄ > θ̄_c)",
             "ellipsoid_down": "buckles into a spindle-like shape",
             "ellipsoid_up": "snaps"}
    rows = []
    for name, r in d.items():
        a, s = r["axisym"], r["surface"]
        f2 = s["critical_points"][0] if s["critical_points"] else None
        first = (f"{f2['kind']} at κR = {f2['kappa_R']:.5f} (m = {f2['mode_m']})" if f2
                 else "none")
        if "path" in s:
            ev = s.get("everted", {})
            post = (f"followed through the snap fold to a rim rotation of "
                    f"{s['rim_rotation_path_max_deg']:.1f}° (the unstable branch); snapped "
                    f"(everted, Newton from the mirrored shell) at κR = "
                    f"{ev.get('kappa_R', float('nan')):.3f}: rim rotation "
                    f"{ev.get('rim_rotation_deg', float('nan')):.1f}°, "
                    f"{ev.get('negative_count')} negative eigenvalues (m = "
                    f"{ev.get('unstable_m')})")
        else:
            e = s.get("end", {})
            post = (f"m = {e.get('deviation_m')} post-buckled branch to κR = "
                    f"{e.get('kappa_R', float('nan')):.3f}, stable: {e.get('stable')}")
        rd = r.get("relative_difference")
        dofs = f", {s['dofs']} DOFs" if s.get("dofs") else ""
        rows.append(
            f"| {what.get(name, name)} | {paper.get(name, '')} | surface (P{r['mesh']['degree']}"
            f"{dofs}): {first}; {post} | "
            f"{'–' if rd is None else f'{rd:.1e} from the 1D model'} | 1D model: {a['kind']} at "
            f"κR = {a['kappa_R']:.5f} (m = {a['mode_m']}); {s['time_s']:.0f} s on "
            f"{r['ranks']} ranks; renders coloured by e_b: benchmarks/results/shapes_3d/"
            f"{name}_*.png (`benchmarks/shapes_3d.py`) |")
    return rows


def _postbuckling_rows(d: dict) -> list[str]:
    """The closed sphere's Ψ3 law and post-buckling branch (benchmarks/sphere_postbuckling.py)."""
    rows = []
    at_depth = []
    for r in d["results"]:
        h, cp = r["h_over_R"], r["critical_point"]
        rows.append(
            f"| closed sphere, 1D, h/R = {h:g}: slope dΨ3(pole)/d(κh) on the fundamental branch "
            f"(κ ≤ 0.9 κ_b) | -1/12 (-(1/12)/(1 + (h/R)²/12) = {r['slope_theory']:.5f}) | "
            f"{r['slope_psi3_vs_kappa_h']:.5f} | {_rel(r['slope_psi3_vs_kappa_h'], -1 / 12)} | "
            f"κ_b h = {cp['kappa_h']:.5f} (n = {cp['mode_n']}; thin limit 1.5119, "
            f"{_rel(cp['kappa_h'], r['kappa_b_h_thin_limit'])}), located by the common "
            "algorithm layer (`shells.analyses.postbuckle`, penalty 1e5) |")
        # side -1: the dimple at the pole, followed with its depth as the parameter while
        # the depth grows (``control_parameter`` 1), then by arclength past a fold of it
        down = [p for p in r["points"] if p["branch"] == "bifurcated" and p["side"] == -1]
        if not down:
            continue
        s = r["summary"]["sides"]["-1"]
        by_depth = [p for p in down if p.get("control_parameter", 1.0) == 1.0]
        deepest = min(by_depth, key=lambda p: p["psi3_pole_over_h"])
        past = down[len(by_depth):]
        note = (f"; the depth turns at {deepest['psi3_pole_over_h']:.2f} h (κ/κ_b = "
                f"{deepest['kappa'] / cp['kappa']:.3f}) and the branch goes on by arclength to "
                f"κ/κ_b = {min(p['kappa'] for p in past) / cp['kappa']:.3f}, the pole back to "
                f"{past[-1]['psi3_pole_over_h']:.2f} h" if past else "")
        neg = sorted({p["negative_count_axisymmetric"] for p in by_depth})
        at_depth.append((h, r.get("kappa_over_kappa_b_at_depth", {})))
        rows.append(
            f"| closed sphere, 1D, h/R = {h:g}: post-buckling branch (rotational symmetry "
            f"enforced) | subcritical, unstable | subcritical: κ falls from κ_b as the pole "
            f"dimples inwards, to κ/κ_b = {deepest['kappa'] / cp['kappa']:.3f} at Ψ3(pole)/h "
            f"= {deepest['psi3_pole_over_h']:.1f} ({s['points']} points, ended: "
            f"{s['ended']}{note}) | – | negative m = 0 eigenvalues while the depth grows: "
            f"{', '.join(map(str, neg))} (the fundamental branch: 0); "
            "`benchmarks/sphere_postbuckling.py`, figure "
            "benchmarks/results/sphere_postbuckling.png |")
    if len(at_depth) > 1:
        def fmt(v: float | None) -> str:
            return "–" if v is None else f"{v:.3f}"

        depths = sorted({k for _, a in at_depth for k in a}, key=float)
        rows.append(
            "| post-buckling vs h/R | \"does not vary considerably\" | κ/κ_b at the pole "
            "depths Ψ3(pole)/h = " + ", ".join(f"-{k}" for k in depths) + ": "
            + "; ".join(f"h/R = {h:g}: " + ", ".join(fmt(a.get(k)) for k in depths)
                        for h, a in at_depth)
            + " | – | the thin shells' curves collapse in κ/κ_b against Ψ3(pole)/h (within "
            "about 2 %); the thick one's dimple stops deepening at 2.5 h; docs/model.md |")
    return rows


def _dimple_2d_row(d: dict) -> str:
    """The closed sphere's dimple branch, surface model against 1D (benchmarks/dimple_2d.py)."""
    rows = [r for r in d["rows"] if r["difference"] is not None]
    worst = max(abs(r["difference"]) for r in rows)
    pairs = ", ".join(f"{r['depth']:g} h: {r['surface']:.4f} / {r['axisym']:.4f}" for r in rows)
    return (f"| closed sphere, h/R = {d['h_over_R']:g}: post-buckling branch, surface model (no "
            "symmetry imposed) against 1D | – (a check of the two models) | κ/κ_b at pole depths "
            "(2D / 1D): "
            f"{pairs} | {100 * worst:.1f} % | the dimple at the pole followed by its depth on "
            f"both models; 2D κ_b h = {d['surface']['kappa_b_h']:.5f} ({d['surface']['dofs']} "
            f"DOFs) against 1D {d['axisym']['kappa_b_h']:.5f}: the difference is the 2D mesh's "
            f"own error{_finer(d)}; `benchmarks/dimple_2d.py`, docs/model.md |")


def _finer(d: dict) -> str:
    """The dimple row's finer surface mesh, where the benchmark ran one."""
    fine = d.get("surface_finer")
    diffs = [abs(r["difference_finer"]) for r in d["rows"]
             if r.get("difference_finer") is not None]
    if not fine or not diffs:
        return ""
    return (f", which shrinks on a finer mesh (size {fine['size']:g}, {fine['dofs']} DOFs: "
            f"κ_b h = {fine['kappa_b_h']:.5f}, κ/κ_b within {100 * max(diffs):.2f} % of 1D)")


def _edge_bulk_row(d: dict) -> str:
    """The W_edge dominance row from benchmarks/edge_bulk_scaling.py's JSON (finest layer)."""
    rows = d["rows"]
    layer = max(r["layer_elements"] for r in rows)
    fine = [r for r in rows if r["layer_elements"] == layer]
    hs = sorted({r["h_over_R"] for r in fine}, reverse=True)
    thetas = sorted({r["theta_deg"] for r in fine})
    lo, hi = min(r["ratio"] for r in fine), max(r["ratio"] for r in fine)
    loc = "; ".join(
        f"{t:g}°: " + " → ".join(f"{e:.2f}" for e in (
            next(f for f in d["fits"] if f["theta_deg"] == t
                 and f["layer_elements"] == layer)["local_exponents"]))
        for t in thetas)
    thin = min(hs)
    scaled = ", ".join(f"{r['ratio'] / r['paper_scale']:.2f}" for t in thetas for r in fine
                       if r["theta_deg"] == t and r["h_over_R"] == thin)
    return (f"| W_edge dominance, \\|W_edge/W_bulk\\| | ≫ 1, ∝ (R/h)^(3/2)/tan(θ/2) | {lo:.0f} to "
            f"{hi:.0f} over h/R = {hs[0]:g} … {thin:g}, θ = "
            f"{', '.join(f'{t:g}°' for t in thetas)} (surface model, κR = 0.05, "
            f"{layer:g} elements across √(Rh)) | local exponent in R/h from thick to thin: {loc}"
            f" — approaching 3/2 from below | dominance confirmed; the h-scaling approaches the "
            f"predicted 3/2; the θ-dependence does **not** follow 1/tan(θ/2): at h/R = {thin:g} "
            f"the ratio over (R/h)^(3/2)/tan(θ/2) is {scaled} at θ = "
            f"{', '.join(f'{t:g}°' for t in thetas)} (the scaling argument is for the boundary "
            "layer and leaves out the θ-dependence of the bulk work) — "
            "benchmarks/results/edge_bulk.json (`benchmarks/edge_bulk_scaling.py`; "
            "tests/test_model.py fits the exponent) |")


def _sphere_exact(h: float, nu: float = 0.5) -> tuple[float, int]:
    """Smallest critical κh over integer degrees n of the exact 2x2 dispersion relation."""
    from shells.theory import dispersion_kappa_h

    vals = [(dispersion_kappa_h(n * (n + 1), h, nu), n) for n in range(2, 400)]
    vals = [(v, n) for v, n in vals if math.isfinite(v)]
    return min(vals)


def render(data: dict[str, Any]) -> str:
    """The comparison document from the benchmark's JSON (fits recomputed from the points)."""
    from shells.analyses.phase_diagram import fit_all
    from shells.analyses.phase_diagram.fits import fit_snap

    d = data["diagram"]
    pts = d["points"]
    fit = fit_all(pts)
    f, e, x = fit["fits"], fit["fits_error"], fit["extra"]
    ck = data["checks"]
    L: list[str] = []
    w = L.append
    w("# The paper's numbers beside ours\n")
    w("Generated by `benchmarks/phase_diagram.py` from `benchmarks/results/phase_diagram.json` "
      "(rerun: `scripts/in-env mpirun -n 2 python3 benchmarks/phase_diagram.py`; the text below "
      "is regenerated from the JSON by `--doc-only`). Model: the axisymmetric Koiter shell "
      "(`shells.axisym`, 1D meridian, P3 + P2 slopes, Fourier modes m = 0..12), ν = 1/2, unless "
      "stated. Differences are ours/paper - 1.\n")
    n_pts = len([p for p in pts if p.get("tag") == "grid"])
    w(f"Phase diagram run: {n_pts} grid points (h/R = 0.01 and 0.04, θ̄ in [1, 20], caps with "
      f"θ > 0.9π left out: {len(d.get('skipped', []))}), plus {len(pts) - n_pts} θ̄_s bisection "
      f"points, every critical point located to {data.get('rel_tol', 1e-3):.0e} relative in κ; "
      f"{d['stats']['computed']} branches computed in this run in "
      f"{data['diagram_wall_time']:.0f} s on {data['ranks']} MPI ranks (2 cores shared with other "
      f"jobs: load average {data['load_average'][0]:.1f} at the end).\n")
    w("## Summary table\n")
    w("| quantity | paper | ours | difference | notes |")
    w("| --- | --- | --- | --- | --- |")
    sph = (ck.get("sphere") or {}).get("result")
    kb = PAPER["kappa_b_h_nu_half"]
    if sph:
        h = sph["h_over_R"]
        ex, nex = _sphere_exact(h)
        for key, lab in (("kappa_b_h_down", "κ < 0"), ("kappa_b_h_up", "κ > 0")):
            v = sph.get(key)
            if v is not None:
                w(f"| closed sphere κ_b h ({lab}), h/R = {h:g} | {kb:.4f} (thin limit) | "
                  f"{v:+.4f} (n = {sph.get('mode_n_' + key.split('_')[-1])}) | "
                  f"{_rel(abs(v), kb)} | exact 2x2 dispersion at this h/R: {ex:.4f} (n = {nex})"
                  f", ours {_rel(abs(v), ex)} |")
        psi = sph.get("psi3") or []
        if psi:
            dev = max(abs(p["psi3_over_h"] / p["law"] - 1) for p in psi if p["law"] != 0)
            w(f"| Ψ3/h = -κh/12 (sphere, up to κh = {max(abs(p['kappa_h']) for p in psi):.2f})"
              f" | -κh/12 | max deviation | {100 * dev:.2f} % | h/R = {sph['h_over_R']:g}, "
              f"{len(psi)} branch points |")
    sb = RESULTS / "sphere_buckling.json"
    if sb.exists():
        sbd = json.loads(sb.read_text())
        # the best discretisation only (P3; the locking P2 sequence is in docs/model.md)
        deg = max((r.get("degree", 2) for r in sbd.get("runs", [])), default=2)
        runs = sorted((r for r in sbd.get("runs", []) if r.get("degree", 2) == deg),
                      key=lambda r: (-r.get("nu", 0.5), -r["size"]))
        for r in runs:
            nu = r.get("nu", 0.5)
            ex, nex = _sphere_exact(r["h_over_R"], nu)
            kb_nu = sphere_kappa_b_h(nu)
            fold = (", a fold: the mesh makes the bifurcation imperfect"
                    if r.get("kind") == "fold" else "")
            w(f"| closed sphere κ_b h, surface model P{r.get('degree', 2)}, h/R = "
              f"{r['h_over_R']:g}, ν = {nu:g}, mesh size {r.get('size')} ({r.get('dofs')} DOFs"
              f"{fold}) | {kb_nu:.4f} (thin limit) | "
              f"{r['kappa_b_h']:.4f} (n = {r.get('mode_n')}) | {_rel(r['kappa_b_h'], kb_nu)} | "
              f"exact 2x2 at this h/R: {ex:.4f}, {_rel(r['kappa_b_h'], ex)}; converging with "
              "the mesh (benchmarks/results/sphere_buckling.json, the surface model's own "
              "study) |")
        for ex_ in sbd.get("summary", []):
            if ex_.get("degree", 2) != deg or not math.isfinite(ex_.get("extrapolated", math.nan)):
                continue
            kb_nu = sphere_kappa_b_h(ex_["nu"])
            w(f"| closed sphere κ_b h, surface model P{deg}, h/R = {ex_.get('h_over_R', 0.05):g}, "
              f"ν = {ex_['nu']:g}, "
              f"Richardson extrapolation (rate {ex_['rate']:.1f}) | {kb_nu:.4f} (thin limit) | "
              f"{ex_['extrapolated']:.4f} | {_rel(ex_['extrapolated'], kb_nu)} | the 1D model at "
              f"this h/R: {ex_['axisym']:.4f} (n = {ex_['axisym_mode_n']}), "
              f"{_rel(ex_['extrapolated'], ex_['axisym'])}; the O(h/R) gap to the thin limit: "
              "docs/model.md |")
    for k, lab in (("alpha", "α"), ("beta", "β"), ("b", "b"), ("c", "c"),
                   ("thetabar_s", "θ̄_s"), ("thetabar_c", "θ̄_c")):
        w(f"| {lab} | {PAPER[k]} | {_fmt(f[k], e[k])} | {_rel(f[k], PAPER[k])} | "
          f"{_NOTES[k]} |")
    plate = (ck.get("plate") or {}).get("result")
    if plate:
        for r in plate["runs"]:
            v = r.get("kappa_r2_over_h")
            mesh = (f", mesh {r.get('size')}:{r.get('layer_elements')}" if r.get("size")
                    else "")
            w(f"| plate limit a = κ r²/h ({plate['model']}, h/r = {r.get('h_over_r')}{mesh})"
              f" | {plate_a():.4f} | {_fmt(v, None, 4)} (m = {r.get('mode_m')}) | "
              f"{_rel(v, plate_a())} | {_PLATE_NOTE} |")
    b11 = x.get("b11_rim_at_snap")
    if b11:
        w(f"| rim curvature at snap b11 R = (1+ν)(κ_s R - 1) | factor 1 | factor "
          f"{b11['factor']:.3f} (least squares over {b11['n']} folds) | "
          f"{_rel(b11['factor'], 1.0)} | median difference "
          f"{100 * (b11['median_rel_diff'] or math.nan):+.1f} %, max "
          f"{100 * (b11['max_abs_rel_diff'] or math.nan):.1f} % over the "
          f"{b11['n_compared']} folds with (1+ν)(κ_s R - 1) > 0.5; b11 at the rim node |")
    eb = RESULTS / "edge_bulk.json"
    if eb.exists():
        w(_edge_bulk_row(json.loads(eb.read_text())))
    else:
        w("| W_edge dominance | (R/h)^(3/2)/tan(θ/2) | not computed in this run | – | "
          "benchmarks/results/edge_bulk.json absent: run benchmarks/edge_bulk_scaling.py |")
    pb = RESULTS / "sphere_postbuckling.json"
    if pb.exists():
        for row in _postbuckling_rows(json.loads(pb.read_text())):
            w(row)
    d2 = RESULTS / "dimple_2d.json"
    if d2.exists():
        w(_dimple_2d_row(json.loads(d2.read_text())))
    s3 = RESULTS / "shapes_3d.json"
    if s3.exists():
        for row in _shapes_3d_rows(json.loads(s3.read_text())):
            w(row)
    w("")
    # -- details
    w("## Snapping line κ_s R = β θ̄ - α\n")
    sf = x.get("snap_fit") or {}
    w(f"The {sf.get('n')} axisymmetric folds of caps with θ ≤ 90° (θ̄ in "
      f"{sf.get('thetabar_range')}), both h/R pooled: β = {_fmt(f['beta'], e['beta'])}, α = "
      f"{_fmt(f['alpha'], e['alpha'])}, RMS residual {sf.get('rms', math.nan):.3f}.\n")
    w("| subset | n | β | α | RMS |")
    w("| --- | --- | --- | --- | --- |")
    subsets = [("all folds", lambda p: True),
               ("θ ≤ 90° (the paper's snapping argument)", lambda p: p["theta_deg"] <= 90.0),
               ("θ̄ ≤ 10", lambda p: p["thetabar"] <= 10.0),
               ("θ ≤ 60°", lambda p: p["theta_deg"] <= 60.0)]
    for h in sorted({p["h_over_R"] for p in pts}):
        subsets += [(f"h/R = {h:g}, θ ≤ 90°", (lambda hh: lambda p: p["h_over_R"] == hh
                                               and p["theta_deg"] <= 90.0)(h)),
                    (f"h/R = {h:g}, θ̄ ≤ 10", (lambda hh: lambda p: p["h_over_R"] == hh
                                               and p["thetabar"] <= 10.0)(h))]
    for lab, cond in subsets:
        s2 = fit_snap([p for p in pts if cond(p)])
        if s2:
            w(f"| {lab} | {s2['n']} | {_fmt(s2['beta'], s2['beta_err'])} | "
              f"{_fmt(s2['alpha'], s2['alpha_err'])} | {s2['rms']:.3f} |")
    w("")
    rel = [(p["thetabar"], p["h_over_R"], p["kappa_snap_R"] / (0.85 * p["thetabar"] - 0.67) - 1)
           for p in pts if p.get("kappa_snap_R") is not None]
    if rel:
        w("Fold against the paper's line, (κ_s / (0.85 θ̄ - 0.67) - 1) in %:\n")
        w("| θ̄ | h/R | θ (deg) | κ_s R | paper | difference | first instability going up |")
        w("| --- | --- | --- | --- | --- | --- | --- |")
        for p in pts:
            if p.get("kappa_snap_R") is None or p.get("tag") != "grid":
                continue
            pl = 0.85 * p["thetabar"] - 0.67
            first = (f"m = {p['mode_bif_up']} at κR = {p['kappa_bif_up_R']:.3f}"
                     if p.get("up_kind") == "bifurcation" else "the fold")
            w(f"| {p['thetabar']:.2f} | {p['h_over_R']:g} | {p['theta_deg']:.1f} | "
              f"{p['kappa_snap_R']:.3f} | {pl:.3f} | {_rel(p['kappa_snap_R'], pl)} | {first} |")
        w("")
    w("## Loss of symmetry for κ < 0, Eq. (4)\n")
    bf = x.get("buckling_fit") or {}
    w(f"Pooled fit over {bf.get('n')} points: b = {_fmt(f['b'], e['b'])}, c = "
      f"{_fmt(f['c'], e['c'])}, RMS {bf.get('rms', math.nan):.3f}.\n")
    w("| θ̄ | h/R | κ_b R ours | m | Eq. (4) paper | difference | Eq. (4) our b, c |")
    w("| --- | --- | --- | --- | --- | --- | --- |")
    from shells.theory import buckling_kappa_R

    for p in pts:
        if p.get("kappa_down_R") is None or p.get("tag") != "grid":
            continue
        pp = buckling_kappa_R(p["thetabar"], p["h_over_R"])
        ours = (buckling_kappa_R(p["thetabar"], p["h_over_R"], f["b"], f["c"])
                if f["b"] is not None else None)
        w(f"| {p['thetabar']:.2f} | {p['h_over_R']:g} | {p['kappa_down_R']:.3f} | "
          f"{p['mode_down']} | {pp:.3f} | {_rel(p['kappa_down_R'], pp)} | {_fmt(ours)} |")
    w("")
    w("## θ̄_s, θ̄_c, and the deep caps\n")
    for h, eh in (x.get("per_h_over_R") or {}).items():
        w(f"* h/R = {h}: θ̄_s bracket {eh.get('thetabar_s_bracket')} (grid + bisection); "
          f"θ̄_c (computed fold = computed 2 - κ_b) = {_fmt(eh.get('thetabar_c'))}; θ̄_c from "
          f"our fitted lines {_fmt(eh.get('thetabar_c_from_fits'))}, from the paper's lines "
          f"{_fmt(eh.get('thetabar_c_paper_lines'))}; first θ̄ where a loss of symmetry "
          f"precedes the fold: {_fmt(eh.get('thetabar_bifurcation_precedes_fold'))}.")
    w("")
    ev = (ck.get("everted") or {}).get("result") or []
    if ev:
        w("## The everted branch is the mirror of the κ < 0 branch\n")
        w("Reflecting a state in the rim plane keeps a and flips the sign of b; with b° = -a°/R "
          "the energy at κ of the reflected state is the energy at 2/R - κ of the original, so "
          "the everted branch's loss of symmetry is exactly κ_e R = 2 - κ_b R (the paper's "
          "mirrored Eq. (4) is a symmetry of the energy, not an approximation). Direct check: "
          "the branch followed through the snap fold and the second fold onto the everted "
          "branch:\n")
        w("| h/R | θ̄ | folds (κR) | everted loss of symmetry (direct) | m | 2 - κ_b R | "
          "difference |")
        w("| --- | --- | --- | --- | --- | --- | --- |")
        for r in ev:
            eb_ = r.get("everted_bifurcation") or {}
            kd = r.get("kappa_down_R")
            mirror = 2.0 - kd if kd is not None else None
            folds = ", ".join(f"{v:.3f}" for v in r["folds"])
            w(f"| {r['h_over_R']:g} | {r['thetabar']:g} | {folds} | "
              f"{_fmt(eb_.get('kappa_R'))} | {eb_.get('mode_m')} | {_fmt(mirror)} | "
              f"{_rel(eb_.get('kappa_R'), mirror, 3)} |")
        w("")
    conv = (ck.get("convergence") or {}).get("result") or []
    if conv:
        w("## Mesh convergence (axisymmetric model)\n")
        w("Default mesh (200 bulk cells, 8 cells per √(Rh) at the rim) against twice both:\n")
        w("| h/R | θ̄ | direction | first (default) | first (fine) | difference | fold default "
          "/ fine |")
        w("| --- | --- | --- | --- | --- | --- | --- |")
        for r in conv:
            a, b_ = r["default"]["first"] or {}, r["fine"]["first"] or {}
            w(f"| {r['h_over_R']:g} | {r['thetabar']:g} | {r['direction']} | "
              f"{a.get('kind')} m={a.get('mode_m')} {_fmt(a.get('kappa_R'), None, 4)} | "
              f"{b_.get('kind')} m={b_.get('mode_m')} {_fmt(b_.get('kappa_R'), None, 4)} | "
              f"{_rel(a.get('kappa_R'), b_.get('kappa_R'), 3)} | "
              f"{_fmt(r['default']['fold'], None, 4)} / {_fmt(r['fine']['fold'], None, 4)} |")
        w("")
    cc = (ck.get("crosscheck") or {}).get("result") or []
    if cc:
        w("## Cross-check of the location against `shells.axisym.critical`\n")
        w("| h/R | θ̄ | ours: first | ours: fold | axisym_runs.critical: critical points |")
        w("| --- | --- | --- | --- | --- |")
        for r in cc:
            fi = r["ours_first"] or {}
            crit = ", ".join(f"{k} {v:.5f} (m = {m})" for k, v, m in r["critical"])
            w(f"| {r['h_over_R']:g} | {r['thetabar']:g} | {fi.get('kind')} "
              f"{_fmt(fi.get('kappa_R'), None, 5)} (m = {fi.get('mode_m')}) | "
              f"{_fmt(r['ours_fold'], None, 5)} | {crit} |")
        w("")
    sf_file = RESULTS / "phase_diagram_surface.json"
    if sf_file.exists():
        w("## Surface-model (2D) spot checks\n")
        w("`benchmarks/phase_diagram.py --surface-check H THETABAR DIR` (2D surface model on "
          "its gmsh mesh, `shells.algorithms.following.follow`; coarse meshes, not converged):\n")
        w("| h/R | θ̄ | dir | model | DOFs | first critical | fold κR | bifurcation κR (m) | "
          "time |")
        w("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
        for run in json.loads(sf_file.read_text())["runs"]:
            for name in ("axisym", "surface"):
                r = run[name]
                fi = r.get("first") or {}
                bi = r.get("bifurcation") or {}
                mesh = (f" ({r.get('size')}:{r.get('layer_elements')})" if name == "surface"
                        else "")
                w(f"| {r['h_over_R']:g} | {r['thetabar']:g} | {r['direction']} | {name}{mesh} "
                  f"| {r.get('dofs')} | {fi.get('kind')} {_fmt(fi.get('kappa_R'))} | "
                  f"{_fmt((r.get('fold') or {}).get('kappa_R'))} | {_fmt(bi.get('kappa_R'))} "
                  f"({bi.get('mode_m')}) | {r['wall_time']:.0f} s |")
        w("")
    w("## Explanations of the differences above 5 %\n")
    w(explanations(pts, fit, conv, data.get("rel_tol", 1e-3)))
    return "\n".join(L) + "\n"


_NOTES = {
    "alpha": "least squares over the axisymmetric folds of caps with θ ≤ 90°, both h/R pooled; "
             "other subsets below",
    "beta": "idem",
    "b": "Eq. (4) least squares over the κ < 0 losses of symmetry, both h/R pooled",
    "c": "idem",
    "thetabar_s": "mean over h/R of the last-no-snap/first-snap bracket after bisection; error: "
                  "half the bracket and the spread",
    "thetabar_c": "mean over h/R of the crossing of the computed fold and the computed 2 - κ_b",
}

def _worst_convergence(conv: list[dict[str, Any]]) -> float:
    worst = 0.0
    for r in conv:
        a, b = ((r[k]["first"] or {}).get("kappa_R") for k in ("default", "fine"))
        if a is not None and b:
            worst = max(worst, abs(a / b - 1))
    return worst


def explanations(pts: list[dict[str, Any]], fit: dict[str, Any],
                 conv: list[dict[str, Any]], rel_tol: float) -> str:
    """The evidence-backed explanations, with the measured numbers."""
    from shells.analyses.phase_diagram.fits import fit_snap
    from shells.theory import buckling_kappa_R

    f, x = fit["fits"], fit["extra"]
    per = {h: fit_snap([p for p in pts if p["h_over_R"] == h and p["thetabar"] <= 10])
           for h in sorted({p["h_over_R"] for p in pts})}
    mid = [p for p in pts if p.get("kappa_snap_R") is not None and 3 <= p["thetabar"] <= 6]
    below = [p["kappa_snap_R"] / (0.85 * p["thetabar"] - 0.67) - 1 for p in mid]
    conv_txt = (f"doubling the bulk cells and the rim-layer cells moves the located points by "
                f"at most {100 * _worst_convergence(conv):.3f} %" if conv else "")
    t: list[str] = []
    t.append("**The numbers are converged; the differences are not discretisation.** "
             f"In the mesh study above {conv_txt}; the bifurcations are located to "
             f"{rel_tol:.0e} relative in κ and the folds by cubic Hermite interpolation of κ(s) "
             "between the two branch points around the turn (κ is stationary there), which "
             "agrees with `shells.axisym.critical` (table above). Each difference "
             "below is therefore a property of the energy and of the fitted forms.\n")
    noise_file = RESULTS / "locator_noise.json"
    if noise_file.exists():
        nz = json.loads(noise_file.read_text())
        fx = nz["fixed_kappa"]
        ulp = fx["mu_2_one_ulp_perturbations"]
        res = fx.get("mu_2_resolved_shifted") or ulp
        ks = [r["kappa_R"] for r in nz["runs"]]
        fac = fx.get("factorisations", {})
        t.append("**How reproducible a located point is.** The crossing eigenvalues the "
                 "locator interpolates are Rayleigh quotients vᵀHv / vᵀMv of the "
                 "eigenvectors, vᵀHv the quadrature of the energy's second variation d²E(v, v) "
                 "(`shells.algorithms.stability.Stability.eigenpairs`), not the shift-invert's "
                 "eigenvalues, which carry the round-off of the assembled block and of its "
                 "factorisation, of order ε ||H|| = "
                 f"{2.2e-16 * fx['hessian_2_frobenius']:.0e} on the Fourier blocks (Frobenius "
                 f"norm {fx['hessian_2_frobenius']:.1e}: the penalty tying the slope fields, "
                 "1e4 / g² on cells of size 1e-2 R). That decides the slow crossings: the "
                 "down-branch bifurcation of θ̄ = 15.11 at h/R = 0.01 (m = 2), whose crossing "
                 f"eigenvalue changes by only {nz['dmu_dkappaR']:.1e} per unit κR, located "
                 "four times with the continuation's first step scaled by 1, 1 ± 1e-6 and "
                 f"1.001, lands at κR = {min(ks):.9f} to {max(ks):.9f} "
                 f"({nz['located_spread_relative']:.1e} relative; reported accuracy "
                 f"{min(r['reported_accuracy'] for r in nz['runs']):.1e} to "
                 f"{nz['largest_reported_accuracy']:.1e}); one state solved again at "
                 f"κ (1 ± 1e-10 .. 1e-9) moves its μ_2 by {max(res) - min(res):.0e} (1-ulp "
                 f"perturbations of the state by {max(ulp) - min(ulp):.0e}), and the model's "
                 "chain LU and MUMPS give the same state's μ_2 as "
                 f"{fac.get('mu_2_chain', math.nan):.4e} and "
                 f"{fac.get('mu_2_mumps', math.nan):.4e} (`benchmarks/locator_noise.py`). "
                 "Before the quotients (issue 14), the same four runs spread by 3.1e-4 "
                 "relative, the trial states' μ_2 scattered by ~2e-7 run against run, and the "
                 "κ < 0 losses of symmetry of deep caps at h/R = 0.01 were reproducible to "
                 "about 4e-4 only, whatever the tolerance; the rerun with them moved those "
                 "points by up to 2.9e-4 (to reproducible values), the plate limit at "
                 "h/r = 0.01 by 1.0e-4 (4.6036 to 4.6032; earlier runs had spread over "
                 "4.6027 to 4.6044, its m = 2 crossing as slow), every κ > 0 point by at most "
                 "3.8e-6, the fits b and c by 1.0e-5 and 8.4e-6 (θ̄_c by 2e-7; α, β and θ̄_s "
                 "unchanged).\n")
    if below:
        t.append(f"**α, β (snap line).** Our folds lie {-100 * max(below):.1f} % to "
                 f"{-100 * min(below):.1f} % (mean {-100 * float(sum(below) / len(below)):.1f} %)"
                 " below the paper's line for 3 ≤ θ̄ ≤ 6, the same offset as earlier independent "
                 "computations of this energy (~7 % below). A near-uniform shift of κ_s moves "
                 "the intercept α much more than the slope β (their errors are strongly "
                 "correlated, see `fits_extra.snap_fit.cov` in the JSON), hence β within a few % "
                 "and α tens of % off. The law is not exactly universal in θ̄: at fixed θ̄ the fold "
                 "depends on h/R (θ = θ̄ √(h/R) differs), per h/R for θ̄ ≤ 10: " + ", ".join(
                     f"h/R = {h:g}: β = {v['beta']:.3f} ± {v['beta_err']:.3f}, α = "
                     f"{v['alpha']:.3f} ± {v['alpha_err']:.3f} (RMS {v['rms']:.3f})"
                     for h, v in per.items() if v) + "; the paper pooled h/R in [0.001, 0.1], so "
                 "its α, β are an average over a different set of caps. Deep caps (θ > 90°) bend "
                 "the fold curve upwards (h/R = 0.04 near θ̄ = 14 approaches a closed sphere), "
                 "which is why the official fit is restricted to θ ≤ 90°, the range of the "
                 "paper's snapping argument (all folds: see the subsets table). The rim curvature "
                 "at the fold follows the paper's b11 = (1+ν)(-1/R + κ_s) closely (factor "
                 f"{x.get('b11_rim_at_snap', {}).get('factor', math.nan):.3f}), so the boundary "
                 "layer mechanism is reproduced; the offset is in where the fold sits.\n")
    rows = [(p["thetabar"], p["h_over_R"], p["kappa_down_R"],
             buckling_kappa_R(p["thetabar"], p["h_over_R"])) for p in pts
            if p.get("kappa_down_R") is not None]
    if rows:
        shallow = [k / q - 1 for tb, h, k, q in rows if 2 <= tb <= 4]
        deep = [k / q - 1 for tb, h, k, q in rows if h == 0.01 and tb >= 8]
        bf = x.get("buckling_fit") or {}
        t.append("**b, c (Eq. 4, κ < 0).** Eq. (4) is the paper's conjectured interpolation "
                 "between the plate limit and the θ → π divergence, not a solution, and our "
                 "losses of symmetry depart from it in both directions depending on θ̄ (as "
                 "earlier independent computations found): for 2 ≤ θ̄ ≤ 4 ours are "
                 f"{100 * min(shallow, default=math.nan):+.0f} % to "
                 f"{100 * max(shallow, default=math.nan):+.0f} % off Eq. (4) (the sign depends on "
                 "h/R: smaller |κ_b| at h/R = 0.04 and near θ̄_s, larger at h/R = 0.01 and "
                 "θ̄ ≈ 4), "
                 f"for deep caps at h/R = 0.01 (θ̄ ≥ 8) {100 * min(deep, default=math.nan):+.0f} "
                 f"% to {100 * max(deep, default=math.nan):+.0f} % (larger |κ_b|: ours "
                 "flattens at κ_b R ≈ -0.41 where Eq. (4) rises towards -0.2). The two-parameter "
                 f"form cannot follow both (RMS residual of our fit {bf.get('rms', math.nan):.3f}"
                 " against standard errors of a few %), so b and c depend on the θ̄ range "
                 "fitted; per h/R fits are in `fits_extra.per_h_over_R`. The plate limit is "
                 "consistent with the shallow side: the axisymmetric disk bifurcates at "
                 "a = 4.604 (+3 % over √(10 + 7√2), converged in h/r), and the m = 2 mode of the "
                 "shallowest caps matches the plate's saddle.\n")
    br = ", ".join(f"{e.get('thetabar_s_bracket')} (h/R = {h})"
                   for h, e in (x.get("per_h_over_R") or {}).items())
    t.append(f"**θ̄_s and θ̄_c** agree with the paper: θ̄_s brackets {br}, mean "
             f"{_fmt(f['thetabar_s'])} against 2.09; θ̄_c "
             f"= {_fmt(f['thetabar_c'])} against 3.85 from the paper's lines and 3.95 ± 0.26 "
             "from its experiments (the crossing of the paper's own lines depends on h/R through "
             "Eq. (4): 3.66 at h/R = 0.01, 3.83 at 0.04). The everted line is exact: the "
             "mirror symmetry of the energy makes the everted branch's loss of symmetry "
             "2 - κ_b R, checked by following the branch through the snap (table above) and "
             "by the shallow caps, whose smoothly inverted up-branch loses symmetry at "
             "2 - κ_b R to the location tolerance.\n")
    pre = {h: e.get("thetabar_bifurcation_precedes_fold")
           for h, e in (x.get("per_h_over_R") or {}).items()}
    deep = [p for p in pts if p.get("up_kind") == "bifurcation"]
    if deep:
        ratio = {h: [p["kappa_bif_up_R"] / p["kappa_snap_R"] for p in deep
                     if f"{p['h_over_R']:g}" == h] for h in pre}
        ms = sorted({p["mode_bif_up"] for p in deep})
        t.append("**Deep caps lose symmetry before the fold** (not in the paper's diagram; "
                 "earlier computations found m = 3 or 4 just before the fold above θ̄ ≈ 5). Our "
                 "model: the first θ̄ whose up-branch meets a bifurcation m ≥ 1 before the fold "
                 "is " + ", ".join(f"{v} (h/R = {h})" for h, v in pre.items()) + f"; modes m in "
                 f"{ms}, growing with θ̄. κ_bif/κ_s: " + ", ".join(
                     f"h/R = {h}: {min(r):.2f} to {max(r):.2f}" for h, r in ratio.items() if r)
                 + ". At h/R = 0.04 the bifurcation stays within a few % of the fold (m = 2-3 "
                 "up to θ̄ ≈ 9, then m = 6-4; near θ̄ = 10 the fold comes first again where the "
                 "two families exchange); at h/R = 0.01 it moves far ahead of the fold (m up to "
                 "8, at half the fold's κ for θ̄ = 20); our reading (mode shapes not examined): "
                 "the rim, bent to b11 ≈ (1+ν)(κR - 1)/R in a layer of width √(Rh), buckles "
                 "azimuthally, with a wavelength set by that layer. Since θ̄ > θ̄_c there, these "
                 "caps end in broken symmetry either way, but the transition out of the white "
                 "phase is this bifurcation, below the snapping line.\n")
    sf_file = RESULTS / "phase_diagram_surface.json"
    if sf_file.exists():
        for run in json.loads(sf_file.read_text())["runs"]:
            s_, a_ = run["surface"], run["axisym"]
            sf = (s_.get("fold") or {}).get("kappa_R")
            af = (a_.get("fold") or {}).get("kappa_R")
            ab = (a_.get("bifurcation") or {}).get("kappa_R")
            if sf is None or af is None:
                continue
            t.append(f"**2D spot check** (h/R = {s_['h_over_R']:g}, θ̄ = {s_['thetabar']:g}, "
                     f"coarse mesh, {s_.get('dofs')} DOFs): the surface model's branch turns at "
                     f"κR = {sf:.3f}, {_rel(sf, ab)} from the axisymmetric model's loss of "
                     f"symmetry (m = {(a_.get('bifurcation') or {}).get('mode_m')} at "
                     f"{_fmt(ab)}) and {_rel(sf, af)} from its axisymmetric fold ({af:.3f}). "
                     "A turn next to the axisymmetric bifurcation rather than at the fold is "
                     "consistent with the 2D model leaving the symmetric branch there (with the "
                     "symmetry slightly imperfect on a 2D mesh, a subcritical bifurcation shows "
                     "as a turning point). For a shallow cap without a preceding bifurcation the "
                     "same model on a coarse mesh finds the fold where ours is "
                     "(tests/test_critical.py: θ = 30°, h/R = 0.04, κR ≈ 1.39; ours 1.40 at "
                     "θ̄ = 2.63), so the -12 % is not a general 2D/1D offset. The mode of the 2D "
                     "turn was not resolved on this mesh; the converged study follows.\n")
    dc_file = RESULTS / "deep_cap_2d.json"
    if dc_file.exists():
        dc = json.loads(dc_file.read_text())
        one = dc["axisym"][-1]
        rows = "; ".join(f"{r['dofs']} DOFs (size {r['size']:g}, {r['layer_elements']:g} layer "
                         f"elements): {r['kind']} m = {r['mode_m']} at κR = "
                         f"{r['kappa_R']:.6f} ({r['relative_to_axisym']:+.1e}, "
                         f"{r['seconds']:.0f} s)" for r in dc["surface"])
        t.append(f"**Converged 2D check** (`benchmarks/deep_cap_2d.py`, h/R = "
                 f"{dc['h_over_R']:g}, θ = {dc['shape']['theta_deg']:.1f}°, θ̄ = "
                 f"{dc['shape']['theta'] / math.sqrt(dc['h_over_R']):.3f}, up, P3 on "
                 f"{dc['ranks']} ranks): the 1D model's {one['kind']} m = {one['mode_m']} at "
                 f"κR = {one['kappa_R']:.6f} ({one['cells']} cells; 200 and 400 agree to 3e-6); "
                 f"the surface model: {rows}. Same kind and m on every mesh, converging to "
                 "the 1D value: the loss of symmetry before the fold is confirmed in 2D. (The "
                 "coarse spot check above was P2, which locks on deep caps, at θ̄ = 8.000, "
                 "where the 1D model's m = 5 lies at 5.100.)\n")
    return "\n".join(t)


def write_doc(data: dict[str, Any], path: Path) -> None:
    path.write_text(render(data))


def refresh(data: dict[str, Any], outdir: str) -> None:
    """Fits and figure of the stored diagram with the current ``shells.analyses.phase_diagram``."""
    from shells.analyses.phase_diagram import fit_all, make_figure, read_landings

    d = data["diagram"]
    if (RESULTS / "snap").is_dir():  # where the snap_landing.py runs landed
        d["landings"] = read_landings([RESULTS / "snap"])
    fit = fit_all(d["points"], d["config"]["nu"])
    d.update(fits=fit["fits"], fits_error=fit["fits_error"], fits_extra=fit["extra"])
    Path(outdir).mkdir(parents=True, exist_ok=True)
    d["figures"] = make_figure(d, Path(outdir) / "phase_diagram")
    import shutil

    shutil.copy(f"{outdir}/phase_diagram.png", "docs/phase-diagram.png")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=36, help="theta-bar values per h/R")
    ap.add_argument("--refine", type=int, default=3)
    ap.add_argument("-o", "--output", default="results/phase-diagram-benchmark")
    ap.add_argument("--doc-only", action="store_true",
                    help="refresh fits and figure from the stored points, rewrite the doc")
    ap.add_argument("--surface-check", nargs=3, metavar=("H", "THETABAR", "DIR"), default=None,
                    help="spot check of one branch (DIR: up/down) on the 2D surface model, "
                    "appended to benchmarks/results/phase_diagram_surface.json")
    ap.add_argument("--size", type=float, default=0.1, help="surface check: bulk size / R")
    ap.add_argument("--layer-elements", type=float, default=3.0,
                    help="surface check: elements across sqrt(R h)")
    ap.add_argument("--rel-tol", type=float, default=1e-5,
                    help="location accuracy of every critical point, relative in κ (1e-5; "
                    "the CLI's default is 1e-3)")
    ap.add_argument("--checks-only", action="store_true",
                    help="keep the stored diagram, recompute the checks")
    args = ap.parse_args()
    if args.surface_check:
        surface_check(args)
        return
    if args.doc_only:
        data = json.loads((RESULTS / "phase_diagram.json").read_text())
        refresh(data, args.output)
        (RESULTS / "phase_diagram.json").write_text(json.dumps(data, indent=1))
        write_doc(data, Path("docs/paper-comparison.md"))
        return
    compute(args)


if __name__ == "__main__":
    main()
