"""Wheel odometry: the pose a robot believes from its wheel encoders, drifting from the truth.

Each control step, each wheel's travel is the mean of its measured speeds (rad/s, the
``wheel_speeds`` of ``info``) at the start and at the end of the step, times the wheel radius and
the step's duration (the trapezoidal rule). With ``odometry_noise = s > 0`` each wheel's travel is
then multiplied by ``1 + s * e``, ``e`` a standard normal draw per wheel and step from the
episode's generator (``env.np_random``): a relative wheel-slip error per control step, as Stage's
``odom_error`` and Gazebo's encoder noise model it. The travels move the pose along an arc
(differential-drive dead reckoning, the midpoint heading), as ``diff_drive_controller`` integrates.

Odometry starts each episode at the true start pose, so the ``odom`` frame coincides with ``map``
at the start and ``map -> odom`` is what the drift has accumulated since. Even without noise the
odometry is not the truth: MuJoCo's wheels slip a little on turns and the rule above is
approximate, as a real robot's encoders are.

The integration is a numba loop, one robot at a time with scalar ``math`` functions, so a row's
result does not depend on how many rows a call integrates: a batch of robots gets bit for bit what
a single env gets.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from bubblerob_env.kinematics import DiffDrive

__all__ = ["Odometry", "draw_slip", "integrate_wheels"]

POSE, LAST_SPEEDS = 3, 2  # widths of the state's parts: (x, y, yaw), (left, right) rad/s


@njit(cache=True, nogil=True)
def integrate_wheels(
    state: NDArray[np.float64],
    rows: NDArray[np.int64],
    wheel_speeds: NDArray[np.float64],
    slip: NDArray[np.float64],
    geometry: NDArray[np.float64],
) -> None:
    """Advance ``state[rows]`` (x, y, yaw, last left and right speeds) by one control step.

    ``wheel_speeds[k]`` is row ``rows[k]``'s measured (left, right) at the step's end, ``slip[k]``
    the relative error of each wheel's travel (zeros: none); ``geometry`` is (wheel radius, wheel
    separation, step duration).
    """
    radius, separation, dt = geometry[0], geometry[1], geometry[2]
    for k in range(rows.shape[0]):
        row = state[rows[k]]
        left, right = wheel_speeds[k, 0], wheel_speeds[k, 1]
        travel_left = 0.5 * (row[3] + left) * radius * dt * (1.0 + slip[k, 0])
        travel_right = 0.5 * (row[4] + right) * radius * dt * (1.0 + slip[k, 1])
        distance = 0.5 * (travel_left + travel_right)
        turn = (travel_right - travel_left) / separation
        heading = row[2] + 0.5 * turn
        row[0] += distance * math.cos(heading)
        row[1] += distance * math.sin(heading)
        yaw = row[2] + turn
        row[2] = math.atan2(math.sin(yaw), math.cos(yaw))
        row[3], row[4] = left, right


def draw_slip(generator: np.random.Generator, noise: float) -> NDArray[np.float64]:
    """One step's relative (left, right) wheel-travel errors: ``noise`` times standard normals."""
    return noise * generator.standard_normal(2)


class Odometry:
    """The odometry of ``n`` robots: their believed poses and last measured wheel speeds."""

    def __init__(self, n: int, drive: DiffDrive, dt: float, noise: float) -> None:
        """``n`` robots with ``drive``'s wheels, stepped every ``dt`` s, slip error ``noise``."""
        self.state = np.zeros((n, POSE + LAST_SPEEDS))
        self.noise = float(noise)
        self._geometry = np.array([drive.wheel_radius, drive.wheel_separation, dt])
        self._no_slip = np.zeros((n, 2))

    @property
    def poses(self) -> NDArray[np.float64]:
        """``(n, 3)`` view: each robot's odometry x (m), y (m) and yaw (rad, in [-pi, pi])."""
        return self.state[:, :POSE]

    def reset(self, row: int, x: float, y: float, yaw: float) -> None:
        """Start robot ``row``'s odometry at the pose ``(x, y, yaw)``, at rest."""
        self.state[row] = (x, y, yaw, 0.0, 0.0)

    def advance(
        self,
        rows: NDArray[np.int64],
        wheel_speeds: NDArray[np.float64],
        slip: NDArray[np.float64] | None = None,
    ) -> None:
        """One control step of ``rows`` with their measured ``(len(rows), 2)`` wheel speeds.

        ``slip``: each row's (left, right) relative travel error (:func:`draw_slip`); None: none.
        """
        no_slip = self._no_slip[: len(rows)] if slip is None else slip
        integrate_wheels(
            self.state, rows, np.ascontiguousarray(wheel_speeds), no_slip, self._geometry
        )
