"""``python -m dynamics``: the command line (see :mod:`dynamics.cli`)."""

import sys

from .cli import main

sys.exit(main())
