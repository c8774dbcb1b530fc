"""``python3 -m shells``: the command-line interface."""

from shells.cli import entry

entry()
