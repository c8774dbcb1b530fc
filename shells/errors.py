"""Error types: bad user input is an ``InputError``, reported by the CLI as one line."""

from __future__ import annotations

__all__ = ["InputError"]


class InputError(ValueError):
    """Invalid user input (parameters, files). The CLI prints it as one line and exits 2."""
