"""The JSON-lines files that runs append to as they compute (driver layer): branch files,
phase-diagram points, post-buckling runs.

One record per line. ``append_record`` writes a whole line with one write(2) on an O_APPEND
descriptor and fsyncs it, so a crash leaves whole lines only (a kill during the write can at
worst leave a torn last line, which ``read_records`` skips). A file may start with a header
record ``{"header": {...}}`` (``read_with_header``); ``write_header`` replaces a file by a new
one holding only the header, atomically (temporary file, then rename).
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["append_record", "json_default", "read_records", "read_with_header", "write_header"]


def json_default(o: Any) -> Any:
    """JSON for numpy scalars and arrays."""
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def append_record(path: str | os.PathLike, rec: dict[str, Any]) -> None:
    """One line, one write(2) on an O_APPEND descriptor, flushed to disk."""
    line = (json.dumps(rec, default=json_default) + "\n").encode()
    fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        os.write(fd, line)
        os.fsync(fd)
    finally:
        os.close(fd)


def read_records(path: str | os.PathLike) -> list[dict[str, Any]]:
    """The records of a file (none if it does not exist; torn or blank lines are skipped)."""
    path = Path(path)
    if not path.exists():
        return []
    out = []
    for line in path.read_text().splitlines():
        if not line.strip():
            continue
        try:
            out.append(json.loads(line))
        except json.JSONDecodeError:
            continue
    return out


def read_with_header(path: str | os.PathLike) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """(header, the other records) of a file whose records may include {"header": ...}."""
    header: dict[str, Any] = {}
    recs = []
    for rec in read_records(path):
        if "header" in rec:
            header = rec["header"]
        else:
            recs.append(rec)
    return header, recs


def write_header(path: str | os.PathLike, header: dict[str, Any]) -> None:
    """Replace ``path`` by a file holding only the header record (atomically)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps({"header": header}, default=json_default) + "\n")
    os.replace(tmp, path)
