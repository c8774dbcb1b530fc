"""Command-line interface: ``shells <subcommand>``; ``main(argv=None) -> int`` (CLI layer: no
library module imports it).

Conventions for every analysis subcommand: human-readable output on rank 0 only; with ``--json``
the last line of stdout is one JSON object; bad input is one line on stderr and exit status 2,
never a traceback.

Modules: ``common`` (the parser class, logging, ``emit``, argument types, the shape and physics
arguments, the checks of ranges and paths), one per subcommand: ``mesh`` (mesh, info, render),
``branch``, ``critical``, ``postbuckle``, ``phase_diagram``, ``knockdown``, ``snap``. They
parse, call the analyses (``shells.analyses``: each analysis module's ``run``) and print.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence
from typing import Any

from shells import __version__
from shells.errors import InputError

__all__ = ["entry", "main"]

#: signals that arrived between ``entry`` and ``main``'s own handlers (``entry``'s records them)
_EARLY: list[int] = []


def _build_parser() -> argparse.ArgumentParser:
    # the subcommands (NumPy, SciPy, the geometry) are imported here, once ``main`` handles
    # signals, not when ``shells.cli`` is imported
    from shells.cli import (
        branch,
        critical,
        frequencies,
        knockdown,
        mesh,
        phase_diagram,
        plot,
        postbuckle,
        snap,
    )
    from shells.cli.common import Parser

    p = Parser(prog="shells", description="Thin elastic shells with natural curvature "
               "(FEniCSx): meshes, branches, buckling and snap-through.")
    p.add_argument("--version", action="version", version=f"shells {__version__}")
    p.add_argument("-v", "--verbose", action="store_true", help="more log output (rank 0)")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    mesh.add_mesh(sub)
    mesh.add_info(sub)
    branch.add_subcommand(sub)
    critical.add_subcommand(sub)
    phase_diagram.add_subcommand(sub)
    postbuckle.add_subcommand(sub)
    knockdown.add_subcommand(sub)
    snap.add_subcommand(sub)
    frequencies.add_subcommand(sub)
    plot.add_subcommand(sub)
    mesh.add_render(sub)
    return p


class _Interrupts:
    """SIGINT and SIGTERM during ``main``: the run ends with one line and exit status
    128 + the signal's number, and the same command then resumes (every file a run writes is
    whole at any moment: appended lines, renamed checkpoints)."""

    def __init__(self) -> None:
        self.signalled: list[int] = []
        self.handlers: dict[int, Any] = {}

    @staticmethod
    def message(signum: int) -> str:
        """The one line an interrupted run prints."""
        import signal

        return (f"shells: interrupted ({signal.Signals(signum).name}); rerun the same command "
                "to resume")

    @staticmethod
    def importing(frame: Any) -> bool:
        """The interrupted code is importing a module (import machinery on its stack)."""
        while frame is not None:
            if frame.f_code.co_filename.startswith("<frozen importlib"):
                return True
            frame = frame.f_back
        return False

    def terminate(self, signum: int, frame: Any) -> None:
        """The handler: record the signal and unwind (one rank), or end every rank (MPI)."""
        import signal
        import time

        if self.importing(frame):
            # a KeyboardInterrupt inside a C extension's module initialisation (dolfinx's
            # nanobind module calls back into Python for its enums) can abort the process with
            # a native backtrace, or end it by SIGINT (docs/design-notes.md, "Interrupts"):
            # act once the import is done (polled every 50 ms)
            signal.signal(signal.SIGALRM, lambda _s, f: self.terminate(signum, f))
            signal.setitimer(signal.ITIMER_REAL, 0.05)
            return
        self.signalled.append(signum)
        # what is logged from here on is the unwinding's, not the run's: a KeyboardInterrupt
        # raised inside a PETSc callback (the Jacobian's assembly during the start's Newton
        # solve) fails that factorisation, and its "zero pivot: MUMPS from now on" line would
        # come before the interrupt's
        logging.disable(logging.CRITICAL)
        from mpi4py import MPI

        comm = MPI.COMM_WORLD
        if comm.size > 1:
            # unwinding would run collective clean-ups (solver destruction, barriers) on this
            # rank alone while the others compute or wait: a hang. Every file a run writes is
            # whole at any moment, so all ranks end here: rank 0 says so (another rank, if
            # rank 0 has not ended them all within 2 s, as when only it was signalled)
            if comm.rank != 0:
                time.sleep(2.0)
            print(self.message(signum), file=sys.stderr, flush=True)
            # mpirun forwards a rank's stderr through a pipe it reads in its own time; an
            # immediate Abort can lose the line (docs/design-notes.md, "Interrupts")
            time.sleep(0.5)
            comm.Abort(128 + signum)
        raise KeyboardInterrupt

    def install(self) -> None:
        """Install the handler (main thread only) and act on a signal that came earlier."""
        import signal
        import threading

        if threading.current_thread() is threading.main_thread():
            for signum in (signal.SIGINT, signal.SIGTERM):
                self.handlers[signum] = signal.signal(signum, self.terminate)
            self.handlers[signal.SIGALRM] = signal.getsignal(signal.SIGALRM) or signal.SIG_DFL
        if _EARLY and self.handlers:
            # before main's handlers: handled now, the last one named, none left for later
            signum = _EARLY[-1]
            _EARLY.clear()
            self.terminate(signum, None)

    def interrupted(self) -> int:
        """The exit status of an interrupted run, its line printed on rank 0."""
        import signal

        signum = self.signalled[-1] if self.signalled else signal.SIGINT
        if _rank() == 0:
            print(self.message(signum), file=sys.stderr)
        return 128 + signum

    def restore(self) -> None:
        """Logging back on and the handlers as they were (no deferred interrupt after)."""
        import signal

        if self.signalled:
            logging.disable(logging.NOTSET)
        if self.handlers:
            signal.setitimer(signal.ITIMER_REAL, 0.0)
        for signum, handler in self.handlers.items():
            signal.signal(signum, handler)


def _rank() -> int:
    from shells.cli.common import rank

    return rank()


def _run(argv: list[str]) -> int:
    """Parse ``argv`` and run its subcommand (the checks of ranges and paths first)."""
    from shells.cli import common
    from shells.progress import quiet

    parser = _build_parser()
    args = parser.parse_args(argv)
    # whether the model is the subcommand's default (its human output then says so, and why)
    args.model_given = any(a == "--model" or a.startswith("--model=") for a in argv)
    common.setup_logging(args.verbose)
    if args.command is None:
        if _rank() == 0:
            parser.print_help()
        return 0
    quiet(bool(getattr(args, "json", False)))  # --json: for a program, no bar
    common.check_ranges(args)
    common.check_paths(args)
    with common.hold_output(args):  # a second run into the same folder: refused, exit 2
        return int(args.func(args) or 0)


def _failed(e: Exception, argv: list[str]) -> int:
    """A failure: one line on stderr (the traceback with -v), every rank ended (MPI)."""
    import traceback

    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    if "-v" in argv or "--verbose" in argv:
        traceback.print_exc()
    msg = " ".join(f"{type(e).__name__}: {e}".splitlines())
    where = f" (rank {comm.rank} of {comm.size})" if comm.size > 1 else ""
    print(f"shells: failed{where}: {msg}", file=sys.stderr, flush=True)
    if comm.size > 1:
        # the other ranks may wait in a collective for this one: end them all now
        comm.Abort(1)
    return 1


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line.

    Args:
        argv: the arguments (default ``sys.argv[1:]``).

    Returns:
        The exit status: 0 ok, 2 bad input, 1 failure, 128 + the signal's number when
        interrupted (the same command then resumes).
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    irq = _Interrupts()
    try:
        irq.install()
        return _run(argv)
    except InputError as e:
        msg = " ".join(str(e).splitlines())  # one line, whatever the message holds
        if _rank() == 0:
            print(msg if msg.startswith("shells") else f"shells: error: {msg}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return irq.interrupted()
    except Exception as e:  # noqa: BLE001 - a failure is one line, never a traceback
        if irq.signalled:
            # the KeyboardInterrupt was raised inside a PETSc callback (an assembly during a
            # solve), which turned it into a PETSc error
            return irq.interrupted()
        return _failed(e, argv)
    finally:
        irq.restore()


def entry() -> None:
    """The ``shells`` command (console script and ``python3 -m shells``).

    Runs ``main()``, then exits with its status. Once ``main`` has returned, the run is
    complete and its files written: SIGINT and SIGTERM are ignored through the teardown
    (logging, atexit, MPI_Finalize, well under a second; SIGKILL still ends it). With Python's
    default handler a KeyboardInterrupt would be raised in whatever teardown code runs and
    print its fragments, and after the interpreter's own clean-up (which resets Python-level
    handlers to SIG_DFL, not SIG_IGN) a signal during MPI_Finalize would kill the rank, which
    mpirun reports as a rank ended by a signal, exit 130.

    Raises:
        SystemExit: always, with ``main``'s status.
    """
    import signal

    def _between(signum: int, frame: Any) -> None:
        """Until ``main`` has its own handlers the signal is recorded (``main`` then acts on
        it); ``main`` restores this handler in its ``finally``, just before it returns."""
        _EARLY.append(signum)

    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, _between)
    status = main()
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, signal.SIG_IGN)
    sys.exit(status)
