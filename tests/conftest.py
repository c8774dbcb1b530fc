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
