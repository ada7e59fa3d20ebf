"""The Nav task's rules, one implementation for the single env and for every robot of a world.

- :class:`NavSettings`: the task's arguments (goal radius, goal distance, reward weights, grid),
  checked once;
- :func:`goal_reading` and :func:`spaces_with_goal`: the observation's ``goal`` (distance and
  bearing in the robot's frame) and the spaces that carry it, dict or flat;
- :meth:`NavSettings.reward_parts` and :meth:`NavSettings.arrived`: a step's reward parts and
  whether it reached the goal.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from bubblerob_env.batch.common import Observation
from bubblerob_env.checks import MAX_WEIGHT, check_bounded, check_positive
from bubblerob_env.mapping import DEFAULT_RESOLUTION, RESOLUTION_RANGE

__all__ = [
    "NAV_ARGUMENTS",
    "WANDERING_PARTS",
    "NavSettings",
    "goal_reading",
    "spaces_with_goal",
    "with_goal",
]

NAV_ARGUMENTS = (
    "goal_radius", "min_goal_distance", "progress_reward_weight", "arrival_reward", "time_cost",
    "grid_resolution",
)  # fmt: skip
"""The Nav task's own keyword arguments (every other one is the robot env's)."""
WANDERING_PARTS = ("reward_forward", "reward_spin", "reward_clearance")
"""``BubbleRob-v0``'s reward parts that the Nav task drops from ``info``."""


@dataclass(frozen=True)
class NavSettings:
    """The Nav task's arguments, checked (see :class:`~bubblerob_env.tasks.nav.BubbleRobNavEnv`)."""

    goal_radius: float = 0.2
    min_goal_distance: float = 1.0
    progress_reward_weight: float = 10.0
    arrival_reward: float = 100.0
    time_cost: float = 0.01
    grid_resolution: float = DEFAULT_RESOLUTION

    @classmethod
    def checked(cls, **arguments: Any) -> NavSettings:
        """The settings of ``arguments`` (:data:`NAV_ARGUMENTS`), or one ``ValueError`` line."""
        given = {**cls().__dict__, **arguments}
        goal_radius = _check_metres("goal_radius", given["goal_radius"])
        min_goal_distance = _check_metres("min_goal_distance", given["min_goal_distance"])
        if goal_radius >= min_goal_distance:
            raise ValueError(
                f"goal_radius {given['goal_radius']!r} must be smaller than min_goal_distance "
                f"{given['min_goal_distance']!r}: a goal must not be reached where the robot starts"
            )
        progress, arrival, time = (
            check_bounded(label, given[label], -MAX_WEIGHT, MAX_WEIGHT)
            for label in ("progress_reward_weight", "arrival_reward", "time_cost")
        )
        resolution = check_bounded(
            "grid_resolution", given["grid_resolution"], *RESOLUTION_RANGE, " m"
        )
        return cls(goal_radius, min_goal_distance, progress, arrival, time, resolution)

    def arrived(self, distance: float, touched: bool, truncated: bool) -> bool:
        """Within ``goal_radius`` of the goal, having touched nothing, before the time limit."""
        return distance <= self.goal_radius and not touched and not truncated

    def reward_parts(
        self, before: float, after: float, arrived: bool, collision: float
    ) -> dict[str, float]:
        """A step's parts: progress on the straight distance, arrival, collision, time."""
        return {
            "reward_progress": self.progress_reward_weight * (before - after),
            "reward_arrival": self.arrival_reward if arrived else 0.0,
            "reward_collision": collision,
            "reward_time": -self.time_cost,
        }


def _check_metres(label: str, value: object) -> float:
    """A finite number of metres > 0, or one line naming the value and what is allowed."""
    try:
        return check_positive(label, value)
    except ValueError:
        raise ValueError(f"{label} must be a finite number of metres > 0, got {value!r}") from None


def goal_reading(
    pose: tuple[float, float, float], goal: tuple[float, float]
) -> NDArray[np.float32]:
    """The goal's distance (m) and bearing (rad, counter-clockwise of the heading) from ``pose``."""
    x, y, yaw = pose
    gx, gy = goal
    bearing = math.remainder(math.atan2(gy - y, gx - x) - yaw, math.tau)
    return np.array([math.hypot(gx - x, gy - y), bearing], dtype=np.float32)


def with_goal(obs: Observation, reading: NDArray[np.float32]) -> Observation:
    """``obs`` with the goal's reading: a ``goal`` key, or appended to a flat vector."""
    if isinstance(obs, dict):
        return {**obs, "goal": reading}
    return np.concatenate([obs, reading])


def spaces_with_goal(
    readings: spaces.Dict, flat: spaces.Box | None, arena_size: float
) -> tuple[spaces.Dict, spaces.Space[Any], slice | None]:
    """The dict space with ``goal``, the observation space, and ``goal``'s slice (flat mode).

    ``flat``: the flat observation's space, or None in dict mode. The distance reaches the
    arena's diagonal.
    """
    reach = float(arena_size) * math.sqrt(2.0)
    goal = spaces.Box(np.array([0.0, -math.pi], np.float32), np.array([reach, math.pi], np.float32))
    dict_space = spaces.Dict({**readings.spaces, "goal": goal})
    if flat is None:
        return dict_space, dict_space, None
    size = flat.shape[0]
    low, high = np.concatenate([flat.low, goal.low]), np.concatenate([flat.high, goal.high])
    flat_space = spaces.Box(low, high, dtype=np.float32)
    return dict_space, flat_space, slice(size, size + 2)
