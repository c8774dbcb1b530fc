"""Result objects of the API's analyses (API layer): the command line's JSON as attributes,
with tables, plots, files and units.

A ``Result`` holds the dict an analysis returns (the same keys as the command's ``--json``
output) and the shell it was computed for. Its keys read as attributes (``res.kappa_R``,
``res.critical_points``); ``kappa`` gives κ in 1/m where the shell has units;
``to_dataframe`` the points (or critical points) as a pandas table; ``plot`` a figure; ``save``
a folder that ``shells.load`` reads back.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

from shells.errors import InputError
from shells.files import json_default, write_atomic

__all__ = ["RESULT_FILE", "Result", "load"]

#: the file ``Result.save`` writes and ``load`` reads
RESULT_FILE = "result.json"


class Result(Mapping):
    """What an analysis computed, read-only.

    Attributes:
        analysis: ``"critical"``, ``"branch"``, ``"postbuckle"``, ``"knockdown"``,
            ``"phase_diagram"`` or ``"snap"``.
        shell: the shell's description (``Shell.describe()``), or None.
        data: the analysis's result (the command line's JSON).
    """

    def __init__(self, analysis: str, data: dict[str, Any],
                 shell: dict[str, Any] | None = None) -> None:
        self.analysis = analysis
        # plain JSON values (numpy scalars become floats, exactly): what --json prints
        self.data = json.loads(json.dumps(data, default=json_default))
        self.shell = shell

    # -- the mapping: the command's JSON keys -------------------------------------------------
    def __getitem__(self, key: str) -> Any:
        return self.data[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self.data)

    def __len__(self) -> int:
        return len(self.data)

    def __getattr__(self, key: str) -> Any:
        if key.startswith("__") or key in ("analysis", "data", "shell"):
            raise AttributeError(key)
        try:
            return self.data[key]
        except KeyError:
            raise AttributeError(f"this {self.analysis} result has no {key!r} (its keys: "
                                 f"{', '.join(self.data)})") from None

    def __repr__(self) -> str:
        head = {k: self.data[k] for k in ("kind", "kappa_R", "kappa_h", "mode_m", "mode_n")
                if k in self.data}
        return f"Result({self.analysis!r}, {head})"

    # -- units --------------------------------------------------------------------------------
    @property
    def radius(self) -> float | None:
        """R in metres where the shell was given with units, else None."""
        return None if self.shell is None else self.shell.get("R_m")

    @property
    def kappa(self) -> Any:
        """κ of the result's first critical point with units (a pint quantity in 1/m) where
        the shell has them; None where it has none or there is no critical point."""
        from shells.units import registry

        kr = self.data.get("kappa_R")
        if kr is None or self.radius is None:
            return None
        return registry().Quantity(kr / self.radius, "1/m")

    # -- tables, files, figures ---------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The result as plain JSON data (a copy), with the shell and the analysis."""
        return json.loads(json.dumps({"analysis": self.analysis, "shell": self.shell,
                                      **self.data}, default=json_default))

    def rows(self) -> list[dict[str, Any]]:
        """The result's table: its points (branches, post-buckling, knock-down, phase
        diagram), or its critical points."""
        if "points" in self.data:
            return list(self.data["points"])
        return list(self.data.get("critical_points", []))

    def to_dataframe(self) -> Any:
        """``rows()`` as a pandas DataFrame, one row each (nested values as objects)."""
        import pandas as pd

        return pd.DataFrame(self.rows())

    def to_csv(self, path: str | Path) -> str:
        """``rows()`` as CSV (``to_dataframe().to_csv``); returns the path."""
        self.to_dataframe().to_csv(path, index=False)
        return str(path)

    def save(self, folder: str | Path) -> str:
        """The result as ``folder/result.json`` (``shells.load`` reads it back) and its table
        as ``folder/table.csv``; returns the folder."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        write_atomic(folder / RESULT_FILE, json.dumps(self.to_dict(), indent=1))
        if self.rows():
            self.to_csv(folder / "table.csv")
        return str(folder)

    def plot(self, path: str | Path | None = None, x: str = "kappa_R",
             y: str | None = None) -> Any:
        """A figure of the result: a branch's ``y`` (default Ψ3/h at the pole) against κR,
        stable and unstable parts apart and critical points marked; a knock-down curve; the
        critical points' κR. Written to ``path`` if given.

        Returns:
            The matplotlib figure.
        """
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(5.5, 3.8))
        rows = self.rows()
        if self.analysis == "knockdown":
            pts = [p for p in rows if p.get("knockdown") is not None and p["delta_over_h"] > 0]
            ax.semilogx([p["delta_over_h"] for p in pts], [p["knockdown"] for p in pts], "o-")
            ax.set_xlabel("imperfection δ/h")
            ax.set_ylabel("knock-down κ_max/κ_b")
        elif "points" in self.data and rows and x in rows[0]:
            y = y or next((k for k in ("psi3_pole_over_h", "psi3_over_h") if k in rows[0]),
                          "energy")
            groups: dict[tuple, list[dict[str, Any]]] = {}
            for p in rows:  # a post-buckling run's fundamental branch and each side apart
                groups.setdefault((p.get("branch"), p.get("side")), []).append(p)
            labelled = set()
            for pts in groups.values():
                stable = [p.get("stable") for p in pts]
                xs, ys = [p[x] for p in pts], [p.get(y) for p in pts]
                if all(s is None for s in stable):
                    ax.plot(xs, ys, "-", color="C0")
                    continue
                for want, style, label in ((True, "-", "stable"), (False, "--", "unstable")):
                    ax.plot([a if s == want else math.nan
                             for a, s in zip(xs, stable, strict=True)], ys, style,
                            color="C0" if want else "C1",
                            label=None if label in labelled else label)
                    labelled.add(label)
            if labelled:
                ax.legend()
            for c in self._critical_markers():
                ax.axvline(c, color="grey", lw=0.8, ls=":")
            ax.set_xlabel(x.replace("kappa_R", "κR").replace("kappa_h", "κh"))
            ax.set_ylabel(y.replace("psi3_pole_over_h", "Ψ3(pole)/h")
                          .replace("psi3_over_h", "Ψ3/h"))
        else:
            cps = self.data.get("critical_points", [])
            ax.plot([c["kappa_R"] for c in cps], range(len(cps)), "o")
            for k, c in enumerate(cps):
                m = c.get("mode_n") if c.get("mode_n") is not None else c.get("mode_m")
                ax.annotate(f"{c['kind']} m={m}", (c["kappa_R"], k), fontsize=8)
            ax.set_xlabel("κR")
            ax.set_yticks([])
        ax.set_title(self.analysis)
        fig.tight_layout()
        if path is not None:
            fig.savefig(path, dpi=150)
        return fig

    def _critical_markers(self) -> list[float]:
        cp = self.data.get("critical_point")
        out = [cp["kappa_R"]] if isinstance(cp, dict) and "kappa_R" in cp else []
        out += [f["kappa_R"] for f in self.data.get("folds", [])]
        return out


def load(folder: str | Path) -> Result:
    """The result in a folder: one ``Result.save`` wrote, or the run folder of a command
    (``-o DIR`` of ``shells critical``, ``branch``, ``postbuckle``, ``knockdown``,
    ``phase-diagram``, ``snap``), read from its files without computing anything.

    Raises:
        InputError: the folder holds no result that can be read.
    """
    from shells.files import read_with_header

    folder = Path(folder)

    def read_json(name: str) -> dict[str, Any]:
        try:
            d = json.loads((folder / name).read_text(encoding="utf-8"))
        except (OSError, ValueError) as e:
            raise InputError(f"cannot read {str(folder / name)!r}: "
                             f"{getattr(e, 'strerror', None) or e}") from None
        if not isinstance(d, dict):
            raise InputError(f"{str(folder / name)!r} is not a result")
        return d

    if (folder / RESULT_FILE).exists():
        d = read_json(RESULT_FILE)
        if "analysis" not in d:
            raise InputError(f"{str(folder / RESULT_FILE)!r} is not a saved result")
        analysis, shell = d.pop("analysis"), d.pop("shell", None)
        return Result(analysis, d, shell)
    if (folder / "critical.json").exists():
        return Result("critical", read_json("critical.json"))
    if (folder / "snap.json").exists():
        return Result("snap", read_json("snap.json"))
    if (folder / "phase_diagram.json").exists():
        return Result("phase_diagram", read_json("phase_diagram.json"))
    if (folder / "postbuckle.jsonl").exists():
        header, recs = read_with_header(folder / "postbuckle.jsonl")
        cp = next((r["critical_point"] for r in recs if "critical_point" in r), None)
        summary = next((r["summary"] for r in recs if "summary" in r), {})
        return Result("postbuckle", {"config": header, "critical_point": cp,
                                     "points": [r for r in recs if "branch" in r],
                                     "sides": summary.get("sides")})
    if (folder / "branch.jsonl").exists():
        header, recs = read_with_header(folder / "branch.jsonl")
        from shells.analyses.branch import folds

        points = [r for r in recs if "index" in r and "kappa_R" in r]
        return Result("branch", {"config": header, "points": points, "folds": folds(points)})
    if (folder / "points.jsonl").exists():
        header, recs = read_with_header(folder / "points.jsonl")
        points = [r for r in recs if "delta_over_h" in r]
        if points:
            return Result("knockdown", {"config": header.get("config", header),
                                        "points": points})
    raise InputError(f"no result in {str(folder)!r}: none of {RESULT_FILE}, critical.json, "
                     "phase_diagram.json, snap.json, postbuckle.jsonl, branch.jsonl, points.jsonl")
