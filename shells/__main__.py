"""``python3 -m shells``: the command-line interface."""

import sys

from shells.cli import main

sys.exit(main())
