"""What the analyses write for ParaView while they run (analyses layer): ``ShapeWriter``, the
bifurcated states of a post-buckling run as 3D shapes (the 1D model: a revolved surface and
its meridian) or fields (the surface model: VTX).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

__all__ = ["ShapeWriter"]


class ShapeWriter:
    """Writes the requested bifurcated states while the model holds them (``all``), or the
    last one of each side at the end (``last``): 1D, a revolved surface (.vts) and the meridian
    (.csv); 2D, VTX fields (one .bp per side)."""

    def __init__(self, out: Path | None, fields: str, model_kind: str, h: float) -> None:
        self.out, self.fields, self.kind, self.h = out, fields, model_kind, h
        self.files: list[str] = []
        self.last: dict[int, tuple[Any, Any, dict[str, Any]]] = {}
        self.writers: dict[int, Any] = {}

    def __call__(self, model: Any, rec: dict[str, Any]) -> None:
        if self.out is None or self.fields == "none" or rec["branch"] != "bifurcated":
            return
        if self.fields == "all":
            self._write(model, rec)
        else:
            from shells.problem.interface import get_state

            self.last[rec["side"]] = (model, get_state(model), dict(rec))

    def _write(self, model: Any, rec: dict[str, Any]) -> None:
        from mpi4py import MPI

        side = rec["side"]
        if self.kind == "axisym":
            if MPI.COMM_WORLD.rank != 0:
                return
            from shells.axisym.revolve import revolve, write_profile_csv, write_vts

            prof = model.meridian_profile()
            d = self.out / "shapes"
            d.mkdir(parents=True, exist_ok=True)
            stem = d / f"side{side:+d}_{rec['index']:03d}"
            self.files.append(write_vts(revolve(prof), str(stem) + ".vts"))
            write_profile_csv(prof, str(stem) + ".csv", self.h)
            self.files.append(str(stem) + ".csv")
            return
        from shells.surface.fields import FieldWriter

        if side not in self.writers:
            path = self.out / f"fields_side{side:+d}.bp"
            self.writers[side] = FieldWriter(model, path)
            self.files.append(str(path))
        self.writers[side].write(float(rec["index"]))

    def close(self) -> None:
        from shells.problem.interface import set_state

        for model, state, rec in self.last.values():
            set_state(model, state)
            self._write(model, rec)
        for w in self.writers.values():
            w.close()
