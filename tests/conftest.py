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
