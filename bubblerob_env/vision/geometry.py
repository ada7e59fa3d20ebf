"""Bearing and distance of scene objects from the camera's pose, from the layout's geometry alone.

Bearings follow REP 103: radians from the camera's optical axis, positive to the left
(counter-clockwise seen from above). Distances are horizontal, in metres, from the camera's centre:
to an obstacle's vertical axis, or to the nearest point of a wall's footprint.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from bubblerob_env import names

__all__ = ["CameraPose", "bearing_to_column", "column_to_bearing", "wall_point"]


@dataclass(frozen=True)
class CameraPose:
    """The camera's position (x, y, z) and heading (yaw of its optical axis), in the world."""

    x: float
    y: float
    z: float
    heading: float

    @classmethod
    def of(cls, model: mujoco.MjModel, data: mujoco.MjData) -> CameraPose:
        """The front camera's pose in ``data`` (``mj_forward`` or a step must have run)."""
        cam = model.camera(names.FRONT_CAMERA).id
        x, y, z = (float(v) for v in data.cam_xpos[cam])
        # A MuJoCo camera looks along its -z axis: column 2 of its orientation matrix.
        forward = -data.cam_xmat[cam].reshape(3, 3)[:, 2]
        return cls(x, y, z, math.atan2(float(forward[1]), float(forward[0])))

    def bearing(self, x: float, y: float) -> float:
        """Bearing of the world point ``(x, y)``, in (-pi, pi]."""
        angle = math.atan2(y - self.y, x - self.x) - self.heading
        return math.atan2(math.sin(angle), math.cos(angle))

    def distance(self, x: float, y: float) -> float:
        """Horizontal distance to the world point ``(x, y)``."""
        return math.hypot(x - self.x, y - self.y)


def wall_point(
    model: mujoco.MjModel, data: mujoco.MjData, geom: int, pose: CameraPose
) -> tuple[float, float]:
    """The point of a box geom's footprint nearest the camera (the camera's own if inside)."""
    centre = data.geom_xpos[geom]
    axes = data.geom_xmat[geom].reshape(3, 3)[:2, :2]  # the footprint's x and y axes, as columns
    half = model.geom_size[geom][:2]
    offset = np.array([pose.x - centre[0], pose.y - centre[1]])
    local = np.clip(axes.T @ offset, -half, half)
    nearest = axes @ local
    return float(centre[0] + nearest[0]), float(centre[1] + nearest[1])


def column_to_bearing(column: float, width: int, focal_length: float) -> float:
    """Bearing of the image column ``column`` (pixel index; fractions allowed) of a level camera."""
    return math.atan(((width - 1) / 2.0 - column) / focal_length)


def bearing_to_column(bearing: float, width: int, focal_length: float) -> float:
    """The image column (pixel index, fractional) a bearing inside the field of view falls on."""
    return (width - 1) / 2.0 - focal_length * math.tan(bearing)
