"""``shells plot`` (CLI layer; no library module imports it): the figure of any run folder,
read with ``shells.api.results.load``."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from shells.cli import common

__all__ = ["add_subcommand"]


def add_subcommand(sub: Any) -> argparse.ArgumentParser:
    """Add ``shells plot`` to ``sub`` (the CLI's subparsers); returns its parser."""
    p = sub.add_parser("plot", help="the figure (and table) of a run folder",
                       description="Draw the result in a run folder (-o DIR of critical, "
                       "branch, postbuckle, knockdown or phase-diagram, or a folder the Python "
                       "API saved): a branch's Psi3/h against kappa R, stable and unstable "
                       "parts apart, critical points marked.")
    p.add_argument("folder", metavar="DIR", help="the run folder")
    p.add_argument("-o", "--output", default=None,
                   help="the figure (default DIR/plot.png)")
    p.add_argument("--y", default=None,
                   help="the quantity against kappa R (a key of the points, e.g. energy)")
    p.add_argument("--csv", default=None, metavar="FILE.csv", help="also the table as CSV")
    common.add_json(p)
    p.set_defaults(func=_cmd_plot)
    return p


def _cmd_plot(args: argparse.Namespace) -> int:
    from shells.api.results import load

    res = load(args.folder)
    out = args.output or str(Path(args.folder) / "plot.png")
    if common.rank() == 0:
        res.plot(out, y=args.y)
        if args.csv:
            res.to_csv(args.csv)
    common.emit({"analysis": res.analysis, "png": out, "csv": args.csv, "rows": len(res.rows())},
                argparse.Namespace(json=args.json), lambda: print(f"wrote {out}"))
    return 0
