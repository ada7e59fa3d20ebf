"""``python -m train``: a command shim (the command is :mod:`bubblerob_cli.train`)."""

import sys

from bubblerob_cli.train import main

sys.exit(main())
