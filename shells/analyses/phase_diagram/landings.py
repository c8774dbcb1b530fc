"""Where snapped caps landed, for the phase diagram (driver layer): ``read_landings``.

``shells snap`` writes ``snap.json`` with the state a cap lands in past its snap fold. The
phase diagram places each such landing at (θ̄, κR of the snap's start), marked by whether the
cap stayed rotationally symmetric or broke its symmetry (and at which m): the surface model's
θ̄_c, the depth beyond which snapping caps lose their symmetry, read off the figure.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from shells.errors import InputError

__all__ = ["read_landings"]


def _landing(path: Path) -> dict[str, Any]:
    """One ``snap.json``'s landing as a phase-diagram mark."""
    try:
        d = json.loads(path.read_text())
        cfg, start, ld = d["config"], d["start"], d["landing"]
        shape = cfg["shape"]
        h = float(cfg["h_over_r"])
        theta = float(shape["theta"])
        return {"thetabar": theta / math.sqrt(h), "h_over_R": h,
                "kappa_R": float(start["kappa_R"]),
                "kappa_fold_R": start.get("kappa_fold_R"),
                "symmetric": bool(ld["symmetric"]), "mode_m": ld.get("mode_m"),
                "stable": bool(ld.get("stable", True)), "method": d.get("method"),
                "source": str(path)}
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise InputError(f"{path}: not the snap.json of a cap's snap ({type(e).__name__}: "
                         f"{e})") from None


def read_landings(paths: list[str | Path]) -> list[dict[str, Any]]:
    """The landings of the ``shells snap`` runs in ``paths``.

    Args:
        paths: ``snap.json`` files, or folders searched (recursively) for them.

    Returns:
        One dict per run, sorted by θ̄: ``thetabar``, ``h_over_R``, ``kappa_R`` (where the
        snap started), ``kappa_fold_R``, ``symmetric``, ``mode_m``, ``stable``, ``method``,
        ``source``.

    Raises:
        InputError: a path that does not exist, a folder without any ``snap.json``, or a
            file that is not a cap's ``snap.json``.
    """
    files: list[Path] = []
    for p in map(Path, paths):
        if p.is_dir():
            found = sorted(p.rglob("snap.json"))
            if not found:
                raise InputError(f"{p}: no snap.json in this folder (the output of shells snap)")
            files += found
        elif p.is_file():
            files.append(p)
        else:
            raise InputError(f"{p}: no such file or folder")
    return sorted((_landing(f) for f in files), key=lambda r: (r["h_over_R"], r["thetabar"]))
