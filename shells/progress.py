"""The progress of a long run (a shared leaf): a progress bar on a terminal, a log line every
10 s elsewhere, nothing on ranks other than 0.

On a terminal (stderr a TTY) and unless ``quiet()`` was called (``--json``), a tqdm bar shows
the share of the κ range done, the points and the critical points so far and the time left
(from the κ covered, so a fold that turns the branch back holds it). Elsewhere (a batch job,
a pipe) a log line every 10 s says the same.
"""

from __future__ import annotations

import logging
import sys
import time
from typing import Any

__all__ = ["Progress", "quiet"]

log = logging.getLogger("shells")

_QUIET = False


def quiet(on: bool = True) -> None:
    """No progress bar (the command line's ``--json``: its output is for a program)."""
    global _QUIET
    _QUIET = on


class Progress:
    """The progress of a run from κ = 0 towards ``kappa_end`` on ``comm``'s rank 0.

    Args:
        label: what runs (e.g. ``"branch"``).
        kappa_end: the end of the range in the run's κ unit (κR); None: the share is not
            shown.
        comm: the run's communicator (None: one process).
        interval: seconds between log lines when stderr is not a terminal; the first comes
            after one interval, so a short run (or one refused after its first point) logs
            none.
    """

    def __init__(self, label: str, kappa_end: float | None, comm: Any = None,
                 interval: float = 10.0) -> None:
        self.label = label
        self.end = abs(kappa_end) if kappa_end else None
        self.on = comm is None or comm.rank == 0
        self.points = 0
        self.critical = 0
        self.interval = interval
        self.last = time.monotonic()
        self.bar = None
        if self.on and not _QUIET and sys.stderr.isatty():
            from tqdm import tqdm

            self.bar = tqdm(total=1000 if self.end else None, desc=label, unit="‰",
                            leave=True, file=sys.stderr, dynamic_ncols=True,
                            bar_format="{desc}: {percentage:3.0f}%|{bar}| {postfix} "
                            "[{elapsed}<{remaining}]" if self.end else None)
        self.done_share = 0

    def update(self, kappa: float, critical: int = 0, **extra: Any) -> None:
        """A point at κ (the run's κ unit) was computed, with ``critical`` new critical
        points; ``extra``: values shown beside (e.g. ``psi3_over_h``)."""
        if not self.on:
            return
        self.points += 1
        self.critical += critical
        share = min(1.0, abs(kappa) / self.end) if self.end else None
        text = (f"point {self.points}, kappa {kappa:+.5g}, critical {self.critical}"
                + "".join(f", {k} {v:+.4g}" for k, v in extra.items()))
        if self.bar is not None:
            if share is not None:
                step = int(1000 * share) - self.done_share
                if step > 0:
                    self.bar.update(step)
                    self.done_share += step
            self.bar.set_postfix_str(text, refresh=True)
            return
        now = time.monotonic()
        if now - self.last >= self.interval:
            pct = f"{100 * share:.0f} % of the range, " if share is not None else ""
            log.info("%s: %s%s", self.label, pct, text)
            self.last = now

    def close(self) -> None:
        """End the bar (its last state stays on the terminal)."""
        if self.bar is not None:
            self.bar.close()
            self.bar = None
