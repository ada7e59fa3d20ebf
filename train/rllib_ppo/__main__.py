"""``python -m train.rllib_ppo``: a command shim (command: :mod:`bubblerob_cli.ray.rllib_ppo`)."""

import sys

from bubblerob_cli.ray.rllib_ppo import main

sys.exit(main())
