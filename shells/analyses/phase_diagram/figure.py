"""The phase diagram's figure (driver layer): computed phases shaded, fits and the paper's lines."""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from shells.theory import PAPER, buckling_kappa_R, plate_a, snap_kappa_R

__all__ = ["make_figure"]

log = logging.getLogger("shells")


# ------------------------------------------------------------------------------------------------
# the figure
# ------------------------------------------------------------------------------------------------
def _shade_computed(ax: Any, pts: list[dict[str, Any]], ylo: float, yhi: float) -> None:
    """Shade the phases as computed: each computed θ̄ colours the band halfway to its neighbours.
    Blue (broken symmetry) below the κ < 0 loss of symmetry; white (symmetric, original
    orientation) up to the first instability going up (the snap, the loss of symmetry before
    the fold, or κR = 1 for a smooth inversion); then, where the shell is symmetric and everted
    (after a snap or an inversion), green up to its loss of symmetry (the everted branch's
    computed one, else the mirror 2 - κ_b of the κ < 0 one), and blue above. Points computed in
    one direction only (the θ̄_s bisection's) take no band: their neighbours' bands cover them."""
    blue, green = "#bcd3ee", "#c9e8c0"
    pts = sorted((p for p in pts if p.get("up_kind") is not None
                  and p.get("kappa_down_R") is not None), key=lambda p: p["thetabar"])
    tbs = [p["thetabar"] for p in pts]
    for i, p in enumerate(pts):
        lo = 0.5 * (tbs[i - 1] + tbs[i]) if i > 0 else max(0.0, tbs[0] - 0.5 * (
            tbs[1] - tbs[0]) if len(tbs) > 1 else tbs[0] - 0.5)
        hi = 0.5 * (tbs[i] + tbs[i + 1]) if i + 1 < len(tbs) else tbs[i] + 0.5 * (
            tbs[i] - tbs[i - 1] if i > 0 else 1.0)
        band = [lo, hi]

        def fill(y0: float | None, y1: float | None, color: str, band: list = band) -> None:
            if y0 is not None and y1 is not None and y1 > y0:
                ax.fill_between(band, y0, y1, color=color, lw=0)

        down = p.get("kappa_down_R")
        fill(ylo, down, blue)
        kind = p["up_kind"]
        top = {"snap": p.get("kappa_snap_R"), "bifurcation": p.get("kappa_bif_up_R"),
               "inversion": 1.0}.get(kind)
        if kind == "bifurcation":
            fill(top, yhi, blue)
            continue
        ev = p.get("kappa_everted_R") if kind == "snap" else p.get("kappa_up_R")
        if ev is None and down is not None:
            ev = 2.0 - down
        fill(top, ev, green)
        fill(ev if ev is not None else None, yhi, blue)


def make_figure(result: dict[str, Any], stem: Path) -> list[str]:
    """Draw the phase diagram in the paper's style.

    θ̄ horizontal, κR vertical, phases shaded from the computed transitions
    (``_shade_computed``, the smallest h/R), computed points, the fitted lines solid and the
    paper's dashed.

    Args:
        result: the diagram's result (``run``'s).
        stem: the path without suffix.

    Returns:
        The files written (``stem``.png and .pdf).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pts = result["points"]
    fits = result["fits"]
    hs = sorted({p["h_over_R"] for p in pts}) or [0.01]
    h0 = hs[0]
    tb_hi = max([p["thetabar"] for p in pts + (result.get("landings") or [])] + [5.0])
    x = np.linspace(0.5, tb_hi * 1.02, 600)
    x = x[x < 0.98 * math.pi / math.sqrt(h0)]
    ylo = min(-6.0, float(np.nanmin([p.get("kappa_down_R") or 0 for p in pts] + [0])) - 0.5)
    yhi = max(8.0, 1.1 * float(np.nanmax([p.get("kappa_snap_R") or 0 for p in pts] + [0])))
    fig, ax = plt.subplots(figsize=(7.5, 7.2))
    _shade_computed(ax, [p for p in pts if p["h_over_R"] == h0], ylo, yhi)
    _draw_lines(ax, x, h0, fits)
    _draw_points(ax, pts, hs, plt.cm.viridis(np.linspace(0.0, 0.8, len(hs))))
    _draw_landings(ax, result.get("landings") or [])
    ax.set_xlim(0, x[-1])
    ax.set_ylim(ylo, yhi)
    ax.axhline(0, color="0.6", lw=0.5)
    ax.set_xlabel(r"$\bar\theta = \theta/\sqrt{h/R}$")
    ax.set_ylabel(r"$\kappa R$")
    ax.set_title(f"Curvature-induced instabilities of open caps (shaded from the computed "
                 f"transitions, h/R = {h0:g}; lines: fits)", fontsize=9)
    ax.legend(fontsize=6.5, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2,
              frameon=False)
    fig.tight_layout()
    files = []
    for ext in ("png", "pdf"):
        f = f"{stem}.{ext}"
        fig.savefig(f, dpi=150)
        files.append(f)
    plt.close(fig)
    return files


def _draw_lines(ax: Any, x: np.ndarray, h0: float, fits: dict[str, Any]) -> None:
    """The fitted lines (solid; the paper's values where a fit is missing), the paper's
    (dashed) and the plate limit (dotted) at h/R = ``h0`` over θ̄ = ``x``."""
    al = fits.get("alpha") or PAPER["alpha"]
    be = fits.get("beta") or PAPER["beta"]
    b = fits.get("b") or PAPER["b"]
    c = fits.get("c") or PAPER["c"]
    ts = fits.get("thetabar_s") or PAPER["thetabar_s"]
    down = np.array([buckling_kappa_R(t, h0, b, c) for t in x])
    mirror = 2.0 - down
    ax.plot(x, down, "k-", lw=1.2, label="fits: Eq. (4), mirrored, snap line")
    ax.plot(x, mirror, "k-", lw=1.2)
    xs = x[x >= ts]
    ax.plot(xs, be * xs - al, "k-", lw=1.2)
    pd = np.array([buckling_kappa_R(t, h0) for t in x])
    ax.plot(x, pd, "--", color="0.4", lw=1.0, label="paper")
    ax.plot(x, 2.0 - pd, "--", color="0.4", lw=1.0)
    xs = x[x >= PAPER["thetabar_s"]]
    ax.plot(xs, snap_kappa_R(xs), "--", color="0.4", lw=1.0)
    xp = x[x > 1.2]
    ax.plot(xp, 1.0 + plate_a() / xp**2, ":", color="0.5", lw=1.0, label="plate limit")
    ax.plot(xp, 1.0 - plate_a() / xp**2, ":", color="0.5", lw=1.0)


#: the computed points drawn: (record key, marker, which points, legend label)
_MARKERS: tuple[tuple[str, str, Callable[[dict[str, Any]], bool], str], ...] = (
    ("kappa_down_R", "v", lambda p: True, "loss of symmetry, kappa < 0"),
    ("kappa_snap_R", "o", lambda p: p.get("up_kind") == "snap", "snap (fold)"),
    ("kappa_snap_R", "s", lambda p: p.get("up_kind") == "bifurcation",
     "fold preceded by loss of symmetry"),
    ("kappa_bif_up_R", "x", lambda p: p.get("up_kind") == "bifurcation",
     "loss of symmetry before the fold"),
    ("kappa_up_R", "^", lambda p: p.get("up_kind") == "inversion",
     "smooth inversion, then loss of symmetry"),
    ("kappa_everted_R", "D", lambda p: p.get("kappa_snap_R") is not None,
     "everted loss of symmetry (2 - kappa_b)"))


def _draw_points(ax: Any, pts: list[dict[str, Any]], hs: list[float], colors: Any) -> None:
    """The computed points, one colour per h/R of ``hs`` (``_MARKERS``)."""
    for h, col in zip(hs, colors, strict=True):
        ph = [p for p in pts if p["h_over_R"] == h]
        for key, mk, cond, lab in _MARKERS:
            xy = [(p["thetabar"], p[key]) for p in ph if p.get(key) is not None and cond(p)]
            if xy:
                xx, yy = zip(*xy, strict=True)
                ax.plot(xx, yy, mk, ms=4.5, mfc="none" if mk not in "x" else col, mec=col,
                        color=col, label=f"{lab}, h/R = {h:g}")


def _draw_landings(ax: Any, landings: list[dict[str, Any]]) -> None:
    """Where snapped caps landed (``landings.read_landings``), at (θ̄, κR of the snap):
    symmetric open circles, broken symmetry stars labelled with their m."""
    sym = [(r["thetabar"], r["kappa_R"]) for r in landings if r["symmetric"]]
    broken = [r for r in landings if not r["symmetric"]]
    hs = ", ".join(f"{h:g}" for h in sorted({r["h_over_R"] for r in landings}))
    if sym:
        xx, yy = zip(*sym, strict=True)
        ax.plot(xx, yy, "o", ms=7, color="k", mfc="white", mew=1.2,
                label=f"a snap lands symmetric (shells snap), h/R = {hs}")
    if broken:
        ax.plot([r["thetabar"] for r in broken], [r["kappa_R"] for r in broken], "*", ms=11,
                color="#c0392b", mec="k", mew=0.6,
                label=f"a snap lands with broken symmetry, h/R = {hs}")
        for r in broken:
            ax.annotate(f"m={r['mode_m']}", (r["thetabar"], r["kappa_R"]), fontsize=6,
                        xytext=(4, -9), textcoords="offset points")
