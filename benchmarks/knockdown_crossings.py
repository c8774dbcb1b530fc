"""What the crossings before an imperfect sphere's fold are (issue 15: h/R = 0.002, ν = 0.3,
pressure, the dimple at δ/h = 0.1 and the mode at δ/h = 0.01, where every attempt of the
knock-down's search once found a "bifurcation" first).

1. Attempts: each step of the search's ladder (0.02, 0.005, 0.00125 in κh; norm of state weight
   1 and balanced), as the search without its window ran them (``first_critical(window=False)``:
   the first critical point ends the attempt): the first critical point's kind, κh, eigenvalue,
   block, Rayleigh degree n, where its mode peaks (angle from the pole) and its load overlap
   |φᵀ ∂R/∂κ| / (|φ|_M |∂R/∂κ|).
2. Scan: the branch in the balanced norm with steps of 0.005 in κh, and beyond ``--scan-from``
   of the fold the 4 eigenvalues nearest 0 of the axisymmetric Jacobian at every point, with
   their degree, peak and load overlap, up to 15 points past the fold. For the mode imperfection
   (P_n even: the same imperfection at both poles) the two lowest modes are also re-diagonalised
   in a translation-free metric (∫ w_n² dA of their normal displacement: the gauge u_z = 0 at the
   north pole adds a translation to a north-pole mode and lowers its eigenvalue in the model's
   mass; the zeros of the eigenvalues do not depend on the metric).

Writes benchmarks/results/knockdown_crossings.json and prints a summary.

    scripts/in-env python3 benchmarks/knockdown_crossings.py [--cells N] [--case dimple|mode]
        [--no-attempts] [--no-scan]
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

CASES = {"dimple": 0.1, "mode": 0.01}
H, NU, DEGREE = 0.002, 0.3, 40  # the perfect sphere's located degree under pressure


class Probe:
    """Eigenpairs of the axisymmetric Jacobian at the model's current state, and what their
    modes look like."""

    def __init__(self, model) -> None:
        from shells.algorithms.stability import Stability

        self.model = model
        self.stab = Stability(model)
        self.dk = model.create_vector()
        W = model.W
        V0, self.map_r = W.sub(0).sub(0).collapse()
        _, self.map_z = W.sub(0).sub(1).collapse()
        t = V0.tabulate_dof_coordinates()[:, 0]
        self.order = np.argsort(t)
        self.t = t[self.order]
        dr, dz = model.shape.meridian_derivative(self.t)
        self.dr, self.dz, self.g = dr, dz, np.hypot(dr, dz)
        r0, _ = model.shape.meridian(self.t)
        self.wgt = 2 * math.pi * r0 * self.g

    def normal(self, arr: np.ndarray) -> np.ndarray:
        """The normal displacement w_n(t) of a mode, its axial translation removed."""
        ur, uz = arr[self.map_r][self.order], arr[self.map_z][self.order]
        shift = np.trapezoid(uz * self.wgt, self.t) / np.trapezoid(self.wgt, self.t)
        return (ur * (-self.dz) + (uz - shift) * self.dr) / self.g

    def describe(self, vec) -> dict:
        """Degree, peak angle and load overlap of a mode (a PETSc Vec)."""
        M = self.stab.mass(None)
        mv = M.createVecLeft()
        M.mult(vec, mv)
        norm = math.sqrt(vec.dot(mv))
        mv.destroy()
        self.model.assemble_dkappa(self.dk)
        wn = self.normal(vec.array)
        return {"mode_n": self.model.classify_mode(vec, None).n,
                "peak_beta": float(self.t[np.argmax(np.abs(wn))]),
                "load_overlap": abs(vec.dot(self.dk)) / norm / self.dk.norm()}

    def eigen(self, nev: int) -> list[dict]:
        vals, vecs = self.stab.eigenpairs(nev, modes=True, block=None)
        return [{"eigenvalue": float(mu), **self.describe(v)}
                for mu, v in sorted(zip(vals, vecs, strict=True), key=lambda p: p[0])]

    def pole_pair(self) -> list[dict]:
        """The two eigenpairs nearest 0 re-diagonalised in the translation-free metric
        G_ij = ∫ w_i w_j dA: eigenvalue (in that metric), peak angle and mirror parity
        ∫ w(β) w(π - β) dA / ∫ w² dA of each."""
        import scipy.linalg as sl

        vals, vecs = self.stab.eigenpairs(2, modes=True, block=None)
        M = self.stab.mass(None)
        wn = []
        for v in vecs:
            mv = M.createVecLeft()
            M.mult(v, mv)
            v.scale(1.0 / math.sqrt(v.dot(mv)))
            mv.destroy()
            wn.append(self.normal(v.array))
        G = np.array([[np.trapezoid(a * b * self.wgt, self.t) for b in wn] for a in wn])
        lam, C = sl.eigh(np.diag(vals), G)
        out = []
        for k in range(2):
            w = C[0, k] * wn[0] + C[1, k] * wn[1]
            mirror = np.interp(math.pi - self.t, self.t, w)
            out.append({"eigenvalue_translation_free": float(lam[k]),
                        "peak_beta": float(self.t[np.argmax(np.abs(w))]),
                        "parity": float(np.trapezoid(w * mirror * self.wgt, self.t)
                                        / np.trapezoid(w * w * self.wgt, self.t))})
        return out


def attempts(kind: str, cells: int | None) -> list[dict]:
    import shells.analyses.knockdown as kd
    from shells.algorithms.newton import NewtonSolver
    from shells.axisym import SNES_OPTIONS

    cfg = kd.KnockdownConfig(H, (CASES[kind],), nu=NU, imperfection=kind, load="pressure",
                             cells=cells)
    model, run = kd.imperfect_model(cfg, CASES[kind], DEGREE)
    ns = NewtonSolver(model, options=SNES_OPTIONS)
    probe = Probe(model)
    end = 1.25 * kd.kappa_scale(cfg) / run.h
    rows = []
    for ds_h in (0.02, 0.005, 0.00125):
        for balanced in (False, True):
            model.w.x.array[:] = 0.0
            model.set_kappa(0.0)
            t0 = time.perf_counter()
            row = {"ds_h": ds_h, "balanced": balanced}
            try:
                found, n = kd.first_critical(model, ns, cfg, end, ds_h, 0.0, balanced,
                                              window=False)
            except RuntimeError as e:
                found, n, row["error"] = [], 0, str(e)
            row.update(points=n, wall_time=time.perf_counter() - t0)
            if found:
                c = found[0]
                row.update(kind=c.kind, kappa_h=c.kappa * run.h, eigenvalue=c.eigenvalue,
                           block=c.block, negative_before=c.negative_before,
                           negative_after=c.negative_after)
                if c.mode is not None:
                    v = model.create_vector()
                    v.array[:] = np.asarray(c.mode)[: v.getLocalSize()]
                    row.update(probe.describe(v))
            rows.append(row)
            print(f"  attempt {ds_h:7g} {'balanced' if balanced else 'weight 1':8}: "
                  + (f"{row['kind']:11} kappa h {row['kappa_h']:.7f}  eigenvalue "
                     f"{row['eigenvalue']:+.2e}  n {row.get('mode_n')}  peak at beta "
                     f"{row.get('peak_beta', math.nan):.3f}  load {row.get('load_overlap', 0):.1e}"
                     if "kind" in row else "no critical point")
                  + f"  ({row['wall_time']:.0f} s)", flush=True)
    ns.destroy()
    return rows


def scan(kind: str, cells: int | None, scan_from: float) -> list[dict]:
    import shells.analyses.knockdown as kd
    from shells.algorithms.continuation import continuation
    from shells.algorithms.newton import NewtonSolver
    from shells.analyses.axisym_runs import default_settings
    from shells.axisym import SNES_OPTIONS
    from shells.geometry.shapes import Sphere

    cfg = kd.KnockdownConfig(H, (CASES[kind],), nu=NU, imperfection=kind, load="pressure",
                             cells=cells)
    model, run = kd.imperfect_model(cfg, CASES[kind], DEGREE)
    ns = NewtonSolver(model, options=SNES_OPTIONS)
    probe = Probe(model)
    model.w.x.array[:] = 0.0
    model.set_kappa(0.0)
    ns.solve()
    xi = kd.balanced_weight(model, ns)
    st = default_settings(Sphere(1.0), H, ds=0.005 / H, ds_max=0.005 / H, ds_unit="kappa",
                          state_weight=xi)
    rows, past = [], 0
    for p in continuation(model, st, kappa_start=0.0, kappa_end=1.25 * kd.kappa_scale(cfg) / H,
                          solver=ns):
        past += p.dkappa_ds < 0
        if p.kappa * H < scan_from and not past:
            continue
        row = {"kappa_h": p.kappa * H, "dkappa_ds": p.dkappa_ds,
               "negative": probe.stab.inertia(None)[0], "modes": probe.eigen(4)}
        if kind == "mode":
            row["pole_pair"] = probe.pole_pair()
        rows.append(row)
        if past > 15:
            break
    ns.destroy()
    return rows


def summary(kind: str, rows: list[dict]) -> None:
    before = [r for r in rows if r["dkappa_ds"] > 0]
    top = max(rows, key=lambda r: r["kappa_h"])
    print(f"  scan: {len(rows)} points, largest kappa h {top['kappa_h']:.7f}")
    for r in before[:: max(1, len(before) // 8)] + [before[-1], *rows[len(before):][:3]]:
        m = r["modes"]
        line = (f"   kappa h {r['kappa_h']:.7f} dk/ds {r['dkappa_ds']:+.2e} neg {r['negative']}  "
                + "  ".join(f"{x['eigenvalue']:+.3e} (n {x['mode_n']}, beta {x['peak_beta']:.2f},"
                            f" load {x['load_overlap']:.1e})" for x in m[:3]))
        if "pole_pair" in r:
            line += "  | pair " + " ".join(f"{x['eigenvalue_translation_free']:+.4f}"
                                           f"@{x['peak_beta']:.2f}" for x in r["pole_pair"])
        print(line)
    # the fold mode's eigenvalue scatter: the point-to-point jumps of the lowest eigenvalue
    low = np.array([r["modes"][0]["eigenvalue"] for r in before])
    jumps = np.abs(np.diff(low, 2)) / 2 if len(low) > 3 else np.array([math.nan])
    print(f"  lowest eigenvalue's scatter (|second difference| / 2, median): "
          f"{float(np.median(jumps)):.1e}")


def _rounded(x):
    """Floats to 8 significant digits (the file holds every scanned point's eigenpairs)."""
    if isinstance(x, float | np.floating):
        return float(f"{x:.8g}")
    if isinstance(x, dict):
        return {k: _rounded(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_rounded(v) for v in x]
    return x


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells", type=int, default=None, help="1D mesh cells (default: the "
                    "knock-down's)")
    ap.add_argument("--case", choices=tuple(CASES), nargs="+", default=list(CASES))
    ap.add_argument("--no-scan", action="store_true")
    ap.add_argument("--no-attempts", action="store_true")
    args = ap.parse_args()
    out_path = Path("benchmarks/results/knockdown_crossings.json")
    out = json.loads(out_path.read_text()) if out_path.exists() else {}
    for kind in args.case:
        key = f"{kind}-{CASES[kind]}-cells{args.cells or 'default'}"
        print(f"{kind}, delta/h = {CASES[kind]}, cells {args.cells or 'default'}", flush=True)
        res = {} if args.no_attempts else {"attempts": attempts(kind, args.cells)}
        if not args.no_scan:
            res["scan"] = scan(kind, args.cells, 3.5 if kind == "dimple" else 4.40)
            summary(kind, res["scan"])
        out[key] = res
        out_path.write_text(json.dumps(_rounded(out), separators=(",", ":")))
    print(f"wrote {out_path}")


if __name__ == "__main__":
    main()
