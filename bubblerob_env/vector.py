"""The CPU batch's old home: ``bubblerob_env.vector.BubbleRobVectorEnv`` stays importable.

The batch is :mod:`bubblerob_env.batch.cpu`; the vector protocol helpers both batch backends
share are :mod:`bubblerob_env.batch.common`.
"""

from __future__ import annotations

from bubblerob_env.batch.common import (
    add_finals,
    checked_actions,
    checked_autoreset_mode,
    collate_infos,
    reset_mask,
    world_seeds,
)
from bubblerob_env.batch.cpu import ARENA_MEMORY, BubbleRobVectorEnv

__all__ = [
    "ARENA_MEMORY",
    "BubbleRobVectorEnv",
    "add_finals",
    "checked_actions",
    "checked_autoreset_mode",
    "collate_infos",
    "reset_mask",
    "world_seeds",
]
