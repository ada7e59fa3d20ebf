"""``RobotDescription``: one robot as data (its MJCF, sizes, sensors, frames, limits, arena).

The env, the sensors, the kernel's settings, the argument checks, the ROS layer (through
:class:`~bubblerob_env.specs.EnvSpecs`) and the policies read a robot from here; nothing else in
the code names a robot. Adding a robot is its MJCF (a self-contained robot file that a scene
``<include>``s, with the MJCF names of :mod:`bubblerob_env.names`), a scene, and one module in
this package with its description, registered in :data:`bubblerob_env.robots.ROBOTS`.

The layout follows MuJoCo Playground's robots: a robot MJCF that compiles alone, scenes that
include it, and a constants module that the Python code reads.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bubblerob_env import names

__all__ = [
    "ASSETS_DIR",
    "ArenaDefaults",
    "LaserDefaults",
    "ProximityDefaults",
    "RobotDescription",
]

ASSETS_DIR = Path(__file__).resolve().parents[1] / "assets"
"""Where the robots' MJCF files and their scenes are."""


@dataclass(frozen=True)
class LaserDefaults:
    """The robot's 2D laser scanner (what ``laser_num_rays=None`` etc. mean)."""

    num_rays: int
    fov: float
    """Field of view (radians), centred on the robot's +x."""
    range_min: float
    range_max: float
    publish_every: int = 1
    """Control steps between two scans a ROS stream publishes (the tutorial's Pioneer: 4)."""
    window: tuple[float, float] = (0.0, 0.0)
    """``(radius, half height)`` (m) of the scanner's window, a cylinder centred on the laser's
    plane: what another robot's laser sees of this robot in a world of several robots
    (:mod:`bubblerob_env.multi`), as a real lidar sees another robot's lidar."""


@dataclass(frozen=True)
class ProximityDefaults:
    """The single forward range sensor on the robot's nose."""

    range_max: float
    trigger_distance: float


@dataclass(frozen=True)
class ArenaDefaults:
    """The arena sized for the robot: its side, the random obstacles, the start's clearance."""

    size: float
    num_obstacles: tuple[int, int]
    obstacle_size: tuple[float, float]
    """Range of an obstacle's radius / half side (m)."""
    start_clearance: float
    clearance_distance: float
    """Range (m) under which the reward's clearance cost starts."""
    obstacle_height: float | None = None
    """Obstacles' height (m); ``None``: the scene's ``obstacle`` class decides."""


@dataclass(frozen=True)
class RobotDescription:
    """One robot, everything the code reads about it.

    Frames follow REP 103 and the MJCF names of :mod:`bubblerob_env.names` (``base_link`` on the
    wheel axle, ``laser_link``, ``proximity_link``, ``camera_link``): every robot MJCF defines
    them, so the static transforms are read from the compiled model.
    """

    name: str
    """Registry key, ``gym.make(..., robot=name)``."""
    title: str
    """What people call it, for messages."""
    env_id: str
    """The Gymnasium id that makes it with its defaults."""
    robot_file: Path
    """The robot's self-contained MJCF (compiles alone)."""
    scene_file: Path
    """The default scene: an arena that includes the robot."""
    radius: float
    """A circle about ``base_link`` that holds the whole robot seen from above (m): the start
    pose's and the obstacles' keep-out, and the reward's hull."""
    max_wheel_speed: float
    """The motors' speed limit (rad/s): what a wheels action of 1 means."""
    laser: LaserDefaults
    proximity: ProximityDefaults
    arena: ArenaDefaults
    max_angular_speed: float | None = None
    """Yaw rate (rad/s) a twist action of 1 means; ``None``: spinning with both wheels at the
    limit."""
    frames: tuple[str, ...] = (names.LASER_SITE, names.PROXIMITY_SITE, names.CAMERA_SITE)
    """Sensor frames (MJCF sites) published as ``base_link -> frame`` on ``/tf_static``."""

    def __post_init__(self) -> None:
        for path in (self.robot_file, self.scene_file):
            if not path.is_file():
                raise ValueError(f"robot {self.name!r}: no MJCF file {path}")
        if not (self.radius > 0 and self.max_wheel_speed > 0 and self.laser.fov > 0):
            raise ValueError(f"robot {self.name!r}: radius, wheel speed and fov must be > 0")
        if not 0 < self.laser.fov <= 2 * math.pi:
            raise ValueError(f"robot {self.name!r}: laser fov must be in (0, 2*pi]")

    def env_defaults(self) -> dict[str, Any]:
        """The env kwargs whose ``None`` means "this robot's", and their values.

        (``xml_file=None`` means the robot's ``scene_file`` too; it is not here because a given
        scene is checked and the robot's own is not.)
        """
        laser, proximity, arena = self.laser, self.proximity, self.arena
        return {
            "max_wheel_speed": self.max_wheel_speed,
            "max_angular_speed": self.max_angular_speed,
            "laser_num_rays": laser.num_rays,
            "laser_fov": laser.fov,
            "laser_range_min": laser.range_min,
            "laser_range_max": laser.range_max,
            "proximity_range_max": proximity.range_max,
            "proximity_trigger_distance": proximity.trigger_distance,
            "arena_size": arena.size,
            "num_obstacles": arena.num_obstacles,
            "obstacle_size": arena.obstacle_size,
            "start_clearance": arena.start_clearance,
            "clearance_distance": arena.clearance_distance,
        }

    def fill_defaults(self, arguments: dict[str, Any]) -> dict[str, Any]:
        """``arguments`` with this robot's value for each of :meth:`env_defaults` left ``None``."""
        defaults = self.env_defaults()
        return {
            key: defaults[key] if value is None and key in defaults else value
            for key, value in arguments.items()
        }
