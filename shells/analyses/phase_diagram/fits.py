"""The phase diagram's merged points and the fits of the paper's laws with standard errors
(driver layer)."""

from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np

from shells.theory import PAPER, mirrored_buckling_kappa_R, plate_a

__all__ = ["fit_all", "merge_points"]

from shells.analyses.phase_diagram.config import SNAP_FIT_THETA_MAX_DEG

log = logging.getLogger("shells")


# ------------------------------------------------------------------------------------------------
# merged points and fits
# ------------------------------------------------------------------------------------------------
def merge_points(recs: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One entry per (h/R, θ̄) with the up and down results and the derived phase data.

    ``up_kind``: "snap" (the fold first), "bifurcation" (loss of symmetry before the fold),
    "inversion" (no fold: smooth inversion, then loss of symmetry of the inverted shell) or
    "none"; ``kappa_everted_R`` = 2 - ``kappa_down_R`` (mirror symmetry), the loss of symmetry of
    the everted branch; ``everted_symmetric``: the snap lands on a stable symmetric everted
    shell (κ_s < κ_e).

    Args:
        recs: the points file's task records.

    Returns:
        The merged points, ordered by (h/R, θ̄).
    """
    by: dict[tuple[float, float], dict[str, Any]] = {}
    for r in recs:
        k = (r["h_over_R"], round(r["thetabar"], 9))
        by.setdefault(k, {})[r["direction"]] = r
    pts = []
    for (h, tb), d in sorted(by.items()):
        up, down = d.get("up"), d.get("down")
        p: dict[str, Any] = {"h_over_R": h, "thetabar": tb, "theta_deg": math.degrees(
            tb * math.sqrt(h)), "tag": (up or down or {}).get("tag", "grid")}
        if up is not None:
            fold, bif = up.get("fold"), up.get("bifurcation")
            if fold is None:
                kind = "inversion" if bif is not None else "none"
            else:
                kind = "bifurcation" if up["first"]["kind"] == "bifurcation" else "snap"
            p.update(up_kind=kind, kappa_up_R=up["first"]["kappa_R"],
                     mode_up=up["first"]["mode_m"],
                     kappa_snap_R=fold["kappa_R"] if fold else None,
                     kappa_bif_up_R=bif["kappa_R"] if bif else None,
                     mode_bif_up=bif["mode_m"] if bif else None,
                     b11_rim_snap_R=(fold or {}).get("b11_rim_R"),
                     b22_rim_snap_R=(fold or {}).get("b22_rim_R"),
                     b11_pole_snap_R=(fold or {}).get("b11_pole_R"))
        if down is not None:
            bif = down.get("bifurcation")
            p.update(kappa_down_R=bif["kappa_R"] if bif else None,
                     mode_down=bif["mode_m"] if bif else None)
            if bif:
                p.update(kappa_everted_R=2.0 - bif["kappa_R"], mode_everted=bif["mode_m"])
        ks, ke = p.get("kappa_snap_R"), p.get("kappa_everted_R")
        if ks is not None and ke is not None:
            p["everted_symmetric"] = ks < ke
        pts.append(p)
    return pts


def _lstsq(X: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Least squares with standard errors s² (XᵀX)⁻¹ (s² = RSS/(n-p)); also the RMS residual."""
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    r = y - X @ coef
    n, k = X.shape
    s2 = float(r @ r) / (n - k) if n > k else math.nan
    cov = s2 * np.linalg.inv(X.T @ X)
    return coef, cov, float(np.sqrt(np.mean(r**2)))


def fit_snap(pts: list[dict[str, Any]]) -> dict[str, Any] | None:
    """The snapping line κ_s R = β θ̄ - α of Eq. (3) fitted to the points' ``kappa_snap_R``
    (least squares, with standard errors); None with fewer than three points."""
    s = [(p["thetabar"], p["kappa_snap_R"]) for p in pts if p.get("kappa_snap_R") is not None]
    if len(s) < 3:
        return None
    tb, k = np.array(s).T
    coef, cov, rms = _lstsq(np.column_stack([tb, -np.ones_like(tb)]), k)
    return {"beta": coef[0], "alpha": coef[1], "beta_err": math.sqrt(cov[0, 0]),
            "alpha_err": math.sqrt(cov[1, 1]), "cov": cov.tolist(), "n": len(tb), "rms": rms,
            "thetabar_range": [float(tb.min()), float(tb.max())]}


def _fit_buckling(pts: list[dict[str, Any]], key: str = "kappa_down_R",
                  mirrored: bool = False) -> dict[str, Any] | None:
    """b, c of Eq. (4) (κ < 0 points; ``mirrored``: 2 - κ for the everted line)."""
    rows = [(p["thetabar"], p["h_over_R"], p[key]) for p in pts if p.get(key) is not None]
    if len(rows) < 3:
        return None
    tb, h, k = np.array(rows).T
    if mirrored:
        k = 2.0 - k
    y = k + plate_a() / tb**2 - 1.0
    X = np.column_stack([1.0 / (tb - math.pi / np.sqrt(h)), np.ones_like(tb)])
    coef, cov, rms = _lstsq(X, y)
    return {"b": coef[0], "c": coef[1], "b_err": math.sqrt(cov[0, 0]),
            "c_err": math.sqrt(cov[1, 1]), "cov": cov.tolist(), "n": len(tb), "rms": rms}


def _crossing(x: np.ndarray, d: np.ndarray) -> float | None:
    """First x where d changes sign from negative to non-negative (linear interpolation)."""
    for i in range(1, len(x)):
        if d[i - 1] < 0 <= d[i]:
            return float(x[i - 1] + (x[i] - x[i - 1]) * (-d[i - 1]) / (d[i] - d[i - 1]))
    return None


def _thetabar_c_from_lines(alpha: float, beta: float, b: float, c: float, h: float
                           ) -> float | None:
    """θ̄ where β θ̄ - α = 2 - κ_b(θ̄) (Eq. 4 with b, c), the paper's triple point."""
    from scipy.optimize import brentq

    f = lambda t: beta * t - alpha - mirrored_buckling_kappa_R(t, h, b, c)  # noqa: E731
    grid = np.linspace(1.0, min(30.0, 0.999 * math.pi / math.sqrt(h)), 400)
    vals = [f(t) for t in grid]
    for i in range(1, len(grid)):
        if vals[i - 1] < 0 <= vals[i]:
            return float(brentq(f, grid[i - 1], grid[i]))
    return None


def fit_all(points: list[dict[str, Any]], nu: float = 0.5) -> dict[str, Any]:
    """Fits of the paper's laws with standard errors.

    α, β: the snapping line over the folds of caps with θ ≤ 90° (the domain of the paper's
    argument; over all folds in ``extra["snap_fit_all_folds"]``); b, c: Eq. (4) over the κ < 0
    points; θ̄_s: per h/R the bracket between the last no-snap and the first snap θ̄, its midpoint
    (error: half its width), pooled: mean over h/R; θ̄_c: per h/R where the computed fold crosses
    the computed everted loss of symmetry 2 - κ_b, pooled: mean.

    Args:
        points: the merged points (``merge_points``).
        nu: Poisson's ratio (for the paper's reference lines).

    Returns:
        {"fits": {"alpha", "beta", "b", "c", "thetabar_s", "thetabar_c"} (None where there
        are too few points), "fits_error": their standard errors, "extra": the fits' details,
        per h/R values and checks}.
    """
    fits: dict[str, Any] = {k: None for k in ("alpha", "beta", "b", "c", "thetabar_s",
                                              "thetabar_c")}
    err: dict[str, Any] = dict(fits)
    extra: dict[str, Any] = {}
    snap = fit_snap([p for p in points if math.degrees(p["thetabar"] * math.sqrt(
        p["h_over_R"])) <= SNAP_FIT_THETA_MAX_DEG])
    if snap:
        fits.update(alpha=snap["alpha"], beta=snap["beta"])
        err.update(alpha=snap["alpha_err"], beta=snap["beta_err"])
        extra["snap_fit"] = snap
    extra["snap_fit_all_folds"] = fit_snap(points)
    buck = _fit_buckling(points)
    if buck:
        fits.update(b=buck["b"], c=buck["c"])
        err.update(b=buck["b_err"], c=buck["c_err"])
        extra["buckling_fit"] = buck
    per_h: dict[str, Any] = {}
    s_vals, s_errs, c_vals = [], [], []
    for h in sorted({p["h_over_R"] for p in points}):
        e = _per_h_over_r(points, h, snap, buck)
        if "thetabar_s_bracket" in e:
            lo, hi = e["thetabar_s_bracket"]
            s_vals.append(0.5 * (lo + hi))
            s_errs.append(0.5 * (hi - lo))
        if e.get("thetabar_c") is not None:
            c_vals.append(e["thetabar_c"])
        per_h[f"{h:g}"] = e
    if s_vals:
        fits["thetabar_s"] = float(np.mean(s_vals))
        spread = float(np.std(s_vals, ddof=1)) / math.sqrt(len(s_vals)) if len(s_vals) > 1 \
            else 0.0
        err["thetabar_s"] = float(math.hypot(max(s_errs), spread))
    if c_vals:
        fits["thetabar_c"] = float(np.mean(c_vals))
        spacing = max((np.diff(sorted({p["thetabar"] for p in points})) if len(points) > 1
                       else [0.0]), default=0.0)
        spread = float(np.std(c_vals, ddof=1)) / math.sqrt(len(c_vals)) if len(c_vals) > 1 \
            else 0.0
        # linear interpolation over one grid step: its error is a fraction of the step
        err["thetabar_c"] = float(math.hypot(0.25 * float(spacing), spread))
    extra["per_h_over_R"] = per_h
    b11 = _b11_at_snap(points, nu)
    if b11 is not None:
        extra["b11_rim_at_snap"] = b11
    return {"fits": fits, "fits_error": err, "extra": extra}


def _per_h_over_r(points: list[dict[str, Any]], h: float, snap: dict[str, Any] | None,
                  buck: dict[str, Any] | None) -> dict[str, Any]:
    """The values of one h/R: θ̄_s's bracket and midpoint, θ̄_c, the first θ̄ whose
    bifurcation precedes the fold, this h/R's fits, and θ̄_c from the fitted lines
    (``snap``, ``buck``: the pooled fits, if any) and from the paper's."""
    ph = sorted((p for p in points if p["h_over_R"] == h and "up_kind" in p),
                key=lambda p: p["thetabar"])
    e: dict[str, Any] = {}
    first = next((i for i, p in enumerate(ph) if p.get("kappa_snap_R") is not None), None)
    if first is not None and first > 0:
        lo, hi = ph[first - 1]["thetabar"], ph[first]["thetabar"]
        e["thetabar_s_bracket"] = [lo, hi]
        e["thetabar_s"] = 0.5 * (lo + hi)
    both = [p for p in ph if p.get("kappa_snap_R") is not None
            and p.get("kappa_everted_R") is not None]
    if len(both) >= 2:
        x = np.array([p["thetabar"] for p in both])
        d = np.array([p["kappa_snap_R"] - p["kappa_everted_R"] for p in both])
        e["thetabar_c"] = _crossing(x, d)
    pre = next((p["thetabar"] for p in ph if p.get("up_kind") == "bifurcation"), None)
    e["thetabar_bifurcation_precedes_fold"] = pre
    e["snap_fit"] = fit_snap(ph)
    pd = [p for p in points if p["h_over_R"] == h]
    e["buckling_fit"] = _fit_buckling(pd)
    e["everted_buckling_fit"] = _fit_buckling(pd, "kappa_everted_R", mirrored=True)
    if snap and buck:
        e["thetabar_c_from_fits"] = _thetabar_c_from_lines(snap["alpha"], snap["beta"],
                                                           buck["b"], buck["c"], h)
    e["thetabar_c_paper_lines"] = _thetabar_c_from_lines(
        PAPER["alpha"], PAPER["beta"], PAPER["b"], PAPER["c"], h)
    return e


def _b11_at_snap(points: list[dict[str, Any]], nu: float) -> dict[str, Any] | None:
    """The rim's meridional curvature at the snap against the paper's (1 + ν)(-1/R + κ_s):
    the proportionality factor (least squares through 0) and the relative differences where
    (1 + ν)(κ_s R - 1) > 0.5 (near θ̄_s the snap sits at κ_s R ≈ 1, where it vanishes);
    None without such points."""
    b11 = [(p["b11_rim_snap_R"], (1 + nu) * (-1.0 + p["kappa_snap_R"]), p["thetabar"])
           for p in points if p.get("b11_rim_snap_R") is not None]
    if not b11:
        return None
    ours, law, _ = (np.array(v) for v in zip(*b11, strict=True))
    keep = law > 0.5
    rel = ours[keep] / law[keep] - 1
    return {"n": int(len(ours)), "factor": float(ours @ law / (law @ law)),
            "n_compared": int(keep.sum()),
            "median_rel_diff": float(np.median(rel)) if rel.size else None,
            "max_abs_rel_diff": float(np.max(np.abs(rel))) if rel.size else None}
