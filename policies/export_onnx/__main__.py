"""``python -m policies.export_onnx``: a command shim (the command: :mod:`bubblerob_cli.export`)."""

import sys

from bubblerob_cli.export import main

sys.exit(main())
