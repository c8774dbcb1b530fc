"""Run the `shells` command line as a user does, in a child process: ``python3 -m shells ...``
(module paths inside the package do not matter), on rank 0 only, its outcome broadcast so that
every rank asserts the same. The child is one process on any number of ranks, so the 2-rank
pass skips these tests: the serial pass runs the same commands. The child gets the environment
less the variables of a running MPI job (under mpirun they would make it join the job):
``conftest.child_env``."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import child_env
from mpi4py import MPI

REPO = Path(__file__).resolve().parent.parent

#: for a test that runs the command line: on more than one rank it is skipped before its own
#: work (a reference computed first would be computed for nothing), as ``shells`` skips it
one_process_child = pytest.mark.skipif(
    MPI.COMM_WORLD.size > 1, reason="a one-process child of rank 0: the serial pass runs it")


def shells(*args: str, timeout: float = 240.0) -> dict:
    """``python3 -m shells ARGS`` on rank 0: {"rc", "stdout", "stderr", "json"} on every rank
    ("json": the last stdout line parsed, when the run passed ``--json`` and succeeded)."""
    comm = MPI.COMM_WORLD
    if comm.size > 1:
        # the child is one process whatever the ranks: the serial pass runs the same command
        pytest.skip("a one-process child of rank 0: the serial pass runs this command")
    out = None
    if comm.rank == 0:
        p = subprocess.run([sys.executable, "-m", "shells", *args], capture_output=True,
                           text=True, timeout=timeout, env=child_env(), cwd=REPO)
        parsed = None
        if p.returncode == 0 and "--json" in args:
            parsed = json.loads(p.stdout.strip().splitlines()[-1])
        out = {"rc": p.returncode, "stdout": p.stdout, "stderr": p.stderr, "json": parsed}
    # the other ranks wait asleep, not spinning in a blocking collective: the child needs the core
    req = comm.Ibarrier()
    while not req.Test():
        time.sleep(0.05)
    return comm.bcast(out, root=0)
