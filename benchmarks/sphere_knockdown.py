"""Knock-down of the closed sphere's buckling by axisymmetric imperfections (1D model, rotational
symmetry enforced), under natural curvature and under a dead external pressure (the same code
path: ``shells.analyses.knockdown`` with ``load``), and Koiter's small-δ law.

1. Curves: κ_max/κ_b against δ/h for a pole dimple (width sqrt(Rh)) and the buckling mode's
   shape, h/R = 0.01 and 0.002, ν = 1/2 and 0.3, curvature and pressure (the pressure as its
   equivalent curvature of Eq. (5); its δ = 0 point beside the classical p_c).
2. Asymptotics: at the perfect sphere's bifurcation, Koiter's reduced equation
   (``shells.algorithms.asymptotics``); for even buckling degrees (asymmetric bifurcations) the law
   1 - κ_max/κ_b = C √δ against computed folds down to δ/h = 1e-5 (mode imperfection), for odd
   degrees (symmetric at that order) the measured exponent.

Writes benchmarks/results/sphere_knockdown.json (rewritten after every curve; the points of each
curve are also kept in results/knockdown/, so a rerun skips what is computed) and .png, and
prints tables. ``--curves`` recomputes only the curves named (and ``--law`` the law's cases) and
those missing from the stored JSON, and keeps every other curve of the stored JSON as it is;
each computed curve records the method (``shells.analyses.knockdown.METHOD``) that computed it.

    scripts/in-env python3 benchmarks/sphere_knockdown.py [--quick]
    scripts/in-env python3 benchmarks/sphere_knockdown.py --curves 0.002:0.3:pressure:dimple
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from shells.analyses import knockdown
from shells.analyses.knockdown import METHOD, KnockdownConfig
from shells.theory import sphere_pressure_kappa_h

RESULTS = Path("benchmarks/results")
AMPLITUDES = (0.001, 0.003, 0.01, 0.03, 0.1, 0.3, 1.0)
#: the thinner shell (n ~ 45-50, each fold a few minutes): fewer amplitudes
AMPLITUDES_THIN = (0.001, 0.01, 0.1, 1.0)
#: the law's cases: (h/R, ν) with an even buckling degree under curvature (n = 6 and 10), and
#: one odd (n = 9)
LAW_CASES = ((0.1, 0.5), (0.05, 0.3), (0.05, 0.5))
LAW_AMPLITUDES = (1e-5, 1e-4, 1e-3, 1e-2)


def _exponent(pts: list[dict], upto: float) -> float:
    small = [p for p in pts if 0 < p["delta_over_h"] <= upto and p["knockdown"] is not None
             and p["knockdown"] < 1]
    if len(small) < 2:
        return math.nan
    x = np.log([p["delta_over_h"] for p in small])
    y = np.log([1 - p["knockdown"] for p in small])
    return float(np.polyfit(x, y, 1)[0])


def curve(h: float, nu: float, kind: str, load: str, amps: tuple[float, ...]) -> dict:
    t0 = time.perf_counter()
    cfg = KnockdownConfig(h, (0.0, *amps), nu=nu, imperfection=kind, width=1.0, load=load)
    res = knockdown.run(cfg, Path("results/knockdown") / f"{load}-{kind}-{h}-{nu}",
                        figure=False)
    pts = res["points"]
    return {"h_over_R": h, "nu": nu, "imperfection": kind, "load": load, "method": METHOD,
            "kappa_b_h": res["kappa_b_h"], "degree": res["degree"],
            "asymptotics": res["asymptotics"], "p_b_over_E": res["p_b_over_E"],
            "p_c_over_E_classical": res["p_c_over_E_classical"], "points": pts,
            "small_delta_exponent": _exponent(pts, 0.01),
            "wall_time": time.perf_counter() - t0}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="h/R = 0.01 only, no law cases")
    ap.add_argument("--table", action="store_true",
                    help="print the curves of the stored JSON as a markdown table, no run")
    ap.add_argument("--curves", nargs="+", metavar="H:NU[:LOAD[:IMPERFECTION]]",
                    type=_selector, help="recompute only these curves (e.g. 0.002:0.3:pressure "
                    "or 0.01:0.3:pressure:mode); the others are kept from the stored JSON")
    ap.add_argument("--law", action="store_true",
                    help="with --curves: recompute the law's cases too (kept otherwise)")
    args = ap.parse_args()
    stored_path = RESULTS / "sphere_knockdown.json"
    if args.table:
        table(json.loads(stored_path.read_text()))
        return
    stored = json.loads(stored_path.read_text()) if args.curves else None
    out: dict = {"amplitudes": AMPLITUDES, "curves": [], "law": []}
    RESULTS.mkdir(parents=True, exist_ok=True)

    def save() -> None:
        stored_path.write_text(json.dumps(out, indent=1))

    def kept(h: float, nu: float, load: str, kind: str) -> dict | None:
        """The stored curve, when ``--curves`` does not name it (None: compute it)."""
        if stored is None or any(sel(h, nu, load, kind) for sel in args.curves):
            return None
        return next((c for c in stored["curves"] if (c["h_over_R"], c["nu"], c["load"],
                                                     c["imperfection"]) == (h, nu, load, kind)),
                    None)

    print("Koiter's law (curvature, mode imperfection): 1 - kappa_max/kappa_b against C sqrt(d)")
    if stored is not None and not args.law:
        out["law"] = stored["law"]
    for h, nu in () if args.quick or out["law"] else LAW_CASES:
        c = curve(h, nu, "mode", "curvature", LAW_AMPLITUDES)
        law = c["asymptotics"]
        rows = []
        for p in c["points"]:
            if p["delta_over_h"] > 0:
                k = p["knockdown_asymptotic"]
                rows.append({"delta_over_h": p["delta_over_h"], "knockdown": p["knockdown"],
                             "law": k, "ratio": None if k is None
                             else (1 - p["knockdown"]) / (1 - k)})
        c["law_rows"] = rows
        c["law_exponent"] = _exponent(c["points"], 1e-4)
        out["law"].append(c)
        save()
        coef = law["coefficient"]
        print(f"h/R = {h:5}  nu = {nu}  n = {c['degree']:3d}  {law['kind']:10}  C = "
              f"{coef if coef is None else f'{coef:.4f}'}  exponent (d <= 1e-4) "
              f"{c['law_exponent']:.3f}  ({c['wall_time']:.0f} s)", flush=True)
        for r in rows:
            ratio = "" if r["ratio"] is None else f"  computed/law {r['ratio']:.3f}"
            print(f"   d/h = {r['delta_over_h']:7g}  knock-down {r['knockdown']:.6f}{ratio}")

    cases = [(0.01, 0.5), (0.01, 0.3)] + ([] if args.quick else [(0.002, 0.5), (0.002, 0.3)])
    print("\nknock-down curves (d/h: " + " ".join(f"{a:g}" for a in AMPLITUDES) + "; h/R < 0.01: "
          + " ".join(f"{a:g}" for a in AMPLITUDES_THIN) + ")")
    for h, nu in cases:
        for load in ("curvature", "pressure"):
            for kind in ("dimple", "mode"):
                c = kept(h, nu, load, kind)
                if c is not None:
                    out["curves"].append(c)
                    continue
                c = curve(h, nu, kind, load, AMPLITUDES if h >= 0.01 else AMPLITUDES_THIN)
                out["curves"].append(c)
                save()
                extra = ""
                if load == "pressure":
                    extra = (f"  (kappa_b h / classical "
                             f"{c['kappa_b_h'] / sphere_pressure_kappa_h(nu):.4f})")
                print(f"h/R = {h:5}  nu = {nu}  {load:9}  {kind:6}  kappa_b h = "
                      f"{c['kappa_b_h']:.5f}  n = {c['degree']:3d}  "
                      f"{c['asymptotics']['kind']:10}  exponent {c['small_delta_exponent']:.3f}"
                      f"{extra}  ({c['wall_time']:.0f} s)", flush=True)
                print("   knock-down: " + "  ".join(
                    "  none" if p["knockdown"] is None else f"{p['knockdown']:.4f}"
                    for p in c["points"][1:]))
    save()
    figure(out)
    print(f"wrote {RESULTS / 'sphere_knockdown.json'} and .png")


def _selector(text: str):
    """``H:NU[:LOAD[:IMPERFECTION]]`` as a predicate of a curve's (h/R, ν, load, imperfection)."""
    parts = text.split(":")
    if not 2 <= len(parts) <= 4:
        raise argparse.ArgumentTypeError(f"expected H:NU[:LOAD[:IMPERFECTION]], got {text!r}")
    try:
        h, nu = float(parts[0]), float(parts[1])
    except ValueError as e:
        raise argparse.ArgumentTypeError(f"H and NU must be numbers in {text!r}") from e
    load = parts[2] if len(parts) > 2 else None
    kind = parts[3] if len(parts) > 3 else None
    if load not in (None, "curvature", "pressure") or kind not in (None, "dimple", "mode"):
        raise argparse.ArgumentTypeError(f"LOAD is curvature|pressure, IMPERFECTION "
                                         f"dimple|mode, in {text!r}")
    return lambda h_, nu_, load_, kind_: (h_, nu_) == (h, nu) and load in (None, load_) and \
        kind in (None, kind_)


def table(out: dict) -> None:
    """The curves as markdown rows (docs/imperfections.md)."""
    print("| h/R | ν | load | imperfection | n | κ_b h (pressure: / classical) | "
          + " | ".join(f"δ/h = {a:g}" for a in AMPLITUDES) + " | exponent (δ/h ≤ 0.01) |")
    print("| --- " * (7 + len(AMPLITUDES)) + "|")
    for c in out["curves"]:
        got = {p["delta_over_h"]: p["knockdown"] for p in c["points"]}
        cells = ["–" if a not in got else "none" if got[a] is None else f"{got[a]:.4f}"
                 for a in AMPLITUDES]
        kb = f"{c['kappa_b_h']:.5f}"
        if c["load"] == "pressure":
            kb += f" ({c['kappa_b_h'] / sphere_pressure_kappa_h(c['nu']):.4f})"
        print(f"| {c['h_over_R']:g} | {c['nu']:g} | {c['load']} | {c['imperfection']} | "
              f"{c['degree']} | {kb} | " + " | ".join(cells)
              + f" | {c['small_delta_exponent']:.2f} |")


def figure(out: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    hs = sorted({c["h_over_R"] for c in out["curves"]}, reverse=True)
    ncol = len(hs) + (1 if out["law"] else 0)
    fig, axes = plt.subplots(1, ncol, figsize=(4.2 * ncol, 3.8), squeeze=False)
    colours = {0.5: "C0", 0.3: "C3"}
    for ax, h in zip(axes[0], hs, strict=False):
        for c in (c for c in out["curves"] if c["h_over_R"] == h):
            pts = [p for p in c["points"] if p["delta_over_h"] > 0 and p["knockdown"] is not None]
            ax.semilogx([p["delta_over_h"] for p in pts], [p["knockdown"] for p in pts],
                        ("-" if c["load"] == "curvature" else "--")
                        + ("o" if c["imperfection"] == "dimple" else "s"),
                        color=colours.get(c["nu"], "k"), ms=3,
                        label=f"{c['load']}, {c['imperfection']}, ν = {c['nu']}")
        ax.set_title(f"closed sphere, h/R = {h}", fontsize=9)
        ax.set_xlabel("imperfection amplitude δ/h")
        ax.set_ylabel("κ_max / κ_b  (pressure: p_max / p_b)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6)
    if out["law"]:
        ax = axes[0][-1]
        for i, c in enumerate(out["law"]):
            rows = c["law_rows"]
            d = np.array([r["delta_over_h"] for r in rows])
            ax.loglog(d, [1 - r["knockdown"] for r in rows], "o", color=f"C{i}",
                      label=f"h/R = {c['h_over_R']}, ν = {c['nu']}, n = {c['degree']}")
            coef = c["asymptotics"]["coefficient"]
            if coef:
                ax.loglog(d, coef * np.sqrt(d), "-", color=f"C{i}", lw=1)
        ax.set_title("curvature, mode imperfection: Koiter's law (lines)", fontsize=9)
        ax.set_xlabel("δ/h")
        ax.set_ylabel("1 - κ_max/κ_b")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(RESULTS / "sphere_knockdown.png", dpi=150)
    plt.close(fig)


if __name__ == "__main__":
    main()
