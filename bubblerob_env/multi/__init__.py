"""Several robots in one world: :func:`parallel_env`, a PettingZoo ``ParallelEnv``.

Needs the ``multi`` extra (``pip install bubblerob[multi]``: PettingZoo).
"""

from __future__ import annotations

from bubblerob_env.multi.parallel import MultiRobotEnv, parallel_env

__all__ = ["MultiRobotEnv", "parallel_env"]
