"""The robots, as data: one :class:`RobotDescription` per robot, by name in :data:`ROBOTS`.

``gym.make("BubbleRob-v0")`` is ``robot="bubblerob"``, ``gym.make("PioneerP3DX-v0")`` is
``robot="pioneer_p3dx"``; any env kwarg left ``None`` takes the robot's value.
"""

from __future__ import annotations

from bubblerob_env.robots.bubblerob import BUBBLEROB
from bubblerob_env.robots.description import (
    ASSETS_DIR,
    ArenaDefaults,
    LaserDefaults,
    ProximityDefaults,
    RobotDescription,
)
from bubblerob_env.robots.pioneer_p3dx import PIONEER_P3DX

__all__ = [
    "ASSETS_DIR",
    "BUBBLEROB",
    "PIONEER_P3DX",
    "ROBOTS",
    "ArenaDefaults",
    "LaserDefaults",
    "ProximityDefaults",
    "RobotDescription",
    "robot_description",
]

ROBOTS: dict[str, RobotDescription] = {robot.name: robot for robot in (BUBBLEROB, PIONEER_P3DX)}
"""Every robot by its name."""


def robot_description(name: object) -> RobotDescription:
    """The robot called ``name``, or a one-line ``ValueError`` listing the robots."""
    if isinstance(name, str) and name in ROBOTS:
        return ROBOTS[name]
    raise ValueError(f"robot must be one of {list(ROBOTS)}, got {name!r}")
