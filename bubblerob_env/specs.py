"""``EnvSpecs``: what an env tells the outside about itself, as plain data.

The sensor specs (laser, proximity, camera), the static frames, the drive and the action's scale:
everything the ROS layer needs to turn an env frame into messages. Core module: imports nothing
from ``bubblerob_env.ros``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from bubblerob_env.kinematics import DiffDrive
from bubblerob_env.sensors import CameraSpec, LaserSpec, ProximitySpec, StaticTransform

__all__ = ["EnvSpecs"]


@dataclass(frozen=True)
class EnvSpecs:
    """The env's sensors, frames, drive and action scale (all of it plain data)."""

    laser: LaserSpec | None
    proximity: ProximitySpec
    camera: CameraSpec | None
    static_transforms: tuple[StaticTransform, ...]
    drive: DiffDrive
    action_type: str
    max_linear_speed: float
    max_angular_speed: float
    odometry_noise: float = 0.0
    """The env's ``odometry_noise``: with it, ``/odom`` drifts and the truth has a topic of its
    own (``/base_pose_ground_truth``)."""
    robot: str = "bubblerob"
    """The robot's name (:data:`bubblerob_env.robots.ROBOTS`)."""
    scan_every: int = 1
    """Control steps between two laser scans a live ROS stream publishes: the robot's (the
    tutorial's Pioneer publishes ``/vrep/scan`` every 4th step; BubbleRob every step)."""

    @classmethod
    def from_env(cls, env: Any) -> EnvSpecs:
        """The specs of a ``BubbleRobEnv`` (or any wrapper around one): ``env.unwrapped.specs``."""
        specs = env.unwrapped.specs
        if not isinstance(specs, cls):
            raise TypeError(f"expected a BubbleRob env, got {type(env.unwrapped).__name__}")
        return specs
