"""``python -m bubblerob_cli ARGS``: the same as ``bubblerob ARGS``."""

import sys

from bubblerob_cli.main import main

sys.exit(main())
