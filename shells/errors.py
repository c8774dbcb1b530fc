"""Error types: bad user input is an ``InputError``, reported by the CLI as one line."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

__all__ = ["InputError", "on_rank_zero"]


class InputError(ValueError):
    """Invalid user input (parameters, files). The CLI prints it as one line and exits 2."""


def on_rank_zero(comm: Any, fn: Callable[[], Any], failure: str) -> Any:
    """Run ``fn`` on rank 0 of ``comm`` and make its verdict every rank's.

    A check that reads or writes files is done once, on rank 0, and all ranks stop (or go
    on) together: the other ranks never wait in a collective that rank 0 will not reach.

    Args:
        comm: the communicator (any object with ``rank``, ``size`` and ``bcast``).
        fn: the work, called on rank 0 only.
        failure: the error's words for an unexpected exception of ``fn``.

    Returns:
        ``fn``'s result on rank 0, None on the others.

    Raises:
        InputError: on every rank, with ``fn``'s ``InputError`` message or ``failure``.
    """
    result, err = None, None
    if comm.rank == 0:
        try:
            result = fn()
        except InputError as e:
            err = str(e)
        except Exception as e:  # noqa: BLE001 - never leave the other ranks waiting
            err = f"{failure}: {type(e).__name__}: {e}"
    if comm.size > 1:
        err = comm.bcast(err, root=0)
    if err:
        raise InputError(err)
    return result
