"""Tasks: thin envs on BubbleRobEnv, registered in :mod:`bubblerob_env`.

Each is a subclass of :class:`~bubblerob_env.env.BubbleRobEnv`, as Gymnasium's ``ant_v5`` is of
``mujoco_env``.

- :mod:`~bubblerob_env.tasks.nav`: ``BubbleRobNav-v0`` / ``PioneerP3DXNav-v0``, drive to a goal.
- :mod:`~bubblerob_env.tasks.goals`: the widened ground-truth grid, shortest paths, drawn goals.
"""

from __future__ import annotations

from bubblerob_env.tasks.goals import NavProblem
from bubblerob_env.tasks.nav import NAV_INFO_KEYS, BubbleRobNavEnv

__all__ = ["NAV_INFO_KEYS", "BubbleRobNavEnv", "NavProblem"]
