"""Differential-drive kinematics with the robot's real wheel radius and separation."""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from bubblerob_env import names

__all__ = ["DiffDrive", "yaw_from_quat"]


@dataclass(frozen=True)
class DiffDrive:
    """Wheel radius (m), wheel separation (m) and the motors' speed limit (rad/s)."""

    wheel_radius: float
    wheel_separation: float
    max_wheel_speed: float

    @classmethod
    def from_model(cls, model: mujoco.MjModel, max_wheel_speed: float) -> DiffDrive:
        """Read the wheel geometry from a compiled model."""
        radius = float(model.geom_size[model.geom(names.LEFT_WHEEL_BODY).id][0])
        left = model.body_pos[model.body(names.LEFT_WHEEL_BODY).id]
        right = model.body_pos[model.body(names.RIGHT_WHEEL_BODY).id]
        return cls(radius, float(np.linalg.norm(left - right)), float(max_wheel_speed))

    @property
    def max_linear_speed(self) -> float:
        """Forward speed with both wheels at their limit (m/s)."""
        return self.max_wheel_speed * self.wheel_radius

    @property
    def max_angular_speed(self) -> float:
        """Yaw rate spinning in place with both wheels at their limit (rad/s)."""
        return 2.0 * self.max_linear_speed / self.wheel_separation

    def wheel_speeds(self, linear: float, angular: float) -> NDArray[np.float64]:
        """Inverse kinematics: body twist (m/s, rad/s) -> ``[left, right]`` wheel speeds (rad/s).

        If a wheel would exceed ``max_wheel_speed`` both are scaled by the same factor, which keeps
        the path's curvature and slows the robot down.
        """
        half_track = self.wheel_separation / 2.0
        speeds = np.array([linear - angular * half_track, linear + angular * half_track])
        speeds /= self.wheel_radius
        peak = float(np.max(np.abs(speeds)))
        if peak > self.max_wheel_speed:
            speeds *= self.max_wheel_speed / peak
        return speeds

    def body_twist(self, left: float, right: float) -> tuple[float, float]:
        """Forward kinematics: wheel speeds (rad/s) -> (linear m/s, angular rad/s)."""
        linear = self.wheel_radius * (left + right) / 2.0
        angular = self.wheel_radius * (right - left) / self.wheel_separation
        return linear, angular


def yaw_from_quat(quat_wxyz: NDArray[np.float64]) -> float:
    """Heading (rotation about +z, radians in (-pi, pi]) of a unit quaternion (w, x, y, z)."""
    w, x, y, z = (float(v) for v in quat_wxyz)
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
