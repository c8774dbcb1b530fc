"""Shared test helpers. Every test is valid on any number of ranks: results are reduced over
MPI.COMM_WORLD before asserting, so all ranks take the same branch."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI


@pytest.fixture
def comm() -> MPI.Comm:
    return MPI.COMM_WORLD


@pytest.fixture
def shared_tmp(tmp_path_factory: pytest.TempPathFactory):
    """A temporary directory with the same path on every rank (rank 0 creates it)."""
    c = MPI.COMM_WORLD
    path = str(tmp_path_factory.mktemp("shared")) if c.rank == 0 else None
    from pathlib import Path

    return Path(c.bcast(path, root=0))


def fitted_rate(sizes, errors) -> float:
    """Least-squares slope of log(error) against log(size)."""
    return float(np.polyfit(np.log(sizes), np.log(errors), 1)[0])


#: the MPI settings a child process keeps (those ``scripts/in-env`` sets for running as root)
_KEEP_MPI = {"OMPI_ALLOW_RUN_AS_ROOT", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "OMPI_MCA_btl",
             "OMPI_MCA_btl_vader_single_copy_mechanism", "OMPI_MCA_rmaps_base_oversubscribe",
             "OMPI_MCA_btl_base_warn_component_unused"}


def child_env(**extra: str) -> dict[str, str]:
    """The environment for a child process started by a test: none of the running MPI job's
    variables (a child that inherits them joins the job and waits for it), the repository on
    PYTHONPATH."""
    import os
    from pathlib import Path

    env = {k: v for k, v in os.environ.items()
           if k in _KEEP_MPI or not k.startswith(("OMPI_", "PMIX_", "PRTE_"))}
    root = str(Path(__file__).resolve().parents[1])
    env["PYTHONPATH"] = root + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    env.update(extra)
    return env


# ------------------------------------------------------------------------------------------
# Hangs fail. Every test has a timeout (pyproject: pytest-timeout, thread method): when it runs
# out, the test's node id, its captured output and every thread's stack are printed and the
# process exits with status 1, which ends an MPI job too. On several ranks a test that fails on
# one rank only, before a collective (e.g. a parse on rank 0 before a ``bcast``), leaves the
# other ranks waiting in that collective: the failing rank prints its failure at once (rank 1's
# output goes to scratch/pytest-rank1.log under scripts/run-pytest) and, after each test, every
# rank waits for the others to finish it before the next test starts, so no rank goes on into
# another test's collectives with a partner still inside the last one. That wait ends with the
# test's timeout: the stuck rank's timer fires, or this rank's own deadline (the test's timeout
# plus a grace of 30 s, since pytest cancels a failed test's timer) ends the job, naming the test.
# ------------------------------------------------------------------------------------------
_SYNC_GRACE = 30.0
_sync_comm = None
_WAITING = pytest.StashKey[dict]()  # {"waiting": True} while the test waits for the other ranks
_STARTED = pytest.StashKey[float]()  # when the test's setup began (time.monotonic)


def _item_timeout(item) -> float:
    """The test's timeout in seconds (its ``timeout`` mark, else the configured value; 0: none)."""
    mark = item.get_closest_marker("timeout")
    if mark is not None and mark.args:
        return float(mark.args[0])
    try:
        value = item.config.getoption("timeout", None) or item.config.getini("timeout")
    except ValueError:  # pytest-timeout is not installed
        return 0.0
    return float(value or 0.0)


def _timed_out(item, settings, waiting: bool) -> None:
    """pytest-timeout's thread-method handler with the test's node id and rank in its header:
    release the capture, print the captured output and the stacks, exit the process."""
    import os
    import sys
    import traceback

    import pytest_timeout

    terminal = item.config.get_terminal_writer()
    try:
        capman = item.config.pluginmanager.getplugin("capturemanager")
        out = err = None
        if capman:
            capman.suspend_global_capture(item)
            out, err = capman.read_global_capture()
        where = (" (this rank had finished it: another rank failed before a collective or "
                 "hangs)" if waiting else "")
        terminal.sep("+", title=f"Timeout after {settings.timeout:g} s: {item.nodeid} on rank "
                                f"{MPI.COMM_WORLD.rank} of {MPI.COMM_WORLD.size}{where}")
        if out:
            terminal.sep("~", title="Captured stdout")
            terminal.write(out)
        if err:
            terminal.sep("~", title="Captured stderr")
            terminal.write(err)
        pytest_timeout.dump_stacks(terminal)
        terminal.sep("+", title=f"Timeout: {item.nodeid}")
    except Exception:
        traceback.print_exc()
    finally:
        terminal.flush()
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(1)


@pytest.hookimpl(tryfirst=True)
def pytest_timeout_set_timer(item, settings):
    """The thread method's timer, with :func:`_timed_out` as its handler."""
    if settings.method != "thread":
        return None
    import threading

    state = {"waiting": False}
    item.stash[_WAITING] = state
    timer = threading.Timer(settings.timeout, lambda: _timed_out(item, settings,
                                                                 state["waiting"]))
    timer.name = f"timeout {item.nodeid}"
    timer.daemon = True

    def cancel():
        timer.cancel()
        timer.join()

    item.cancel_timeout = cancel
    timer.start()
    return True


def pytest_runtest_setup(item):
    import time

    item.stash[_STARTED] = time.monotonic()


def pytest_runtest_logreport(report):
    """On several ranks, a failure is printed at once by the rank it happened on."""
    if MPI.COMM_WORLD.size > 1 and report.failed:
        import sys

        sys.stderr.write(f"\n[rank {MPI.COMM_WORLD.rank}] FAILED {report.nodeid} "
                         f"({report.when})\n{report.longreprtext}\n")
        sys.stderr.flush()


@pytest.hookimpl(hookwrapper=True, trylast=True)
def pytest_runtest_teardown(item, nextitem):
    """On several ranks, wait (on a communicator of its own) until every rank has finished the
    test; past the test's timeout plus a grace, end the job, naming the test."""
    yield
    world = MPI.COMM_WORLD
    if world.size == 1:
        return
    import sys
    import time

    global _sync_comm
    if _sync_comm is None:
        _sync_comm = world.Dup()
    limit = _item_timeout(item)
    start = item.stash.get(_STARTED, time.monotonic())
    deadline = start + limit + _SYNC_GRACE if limit > 0 else float("inf")
    state = item.stash.get(_WAITING, {"waiting": False})
    state["waiting"] = True
    req = _sync_comm.Ibarrier()
    while not req.Test():
        if time.monotonic() > deadline:
            sys.stderr.write(
                f"\n[rank {world.rank}] {item.nodeid}: finished here, but not on every rank "
                f"within its timeout ({limit:g} s) + {_SYNC_GRACE:g} s: a rank failed before a "
                "collective or hangs; ending the job\n")
            sys.stderr.flush()
            world.Abort(1)
        time.sleep(0.002)
    state["waiting"] = False
