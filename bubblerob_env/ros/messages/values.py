"""Env frames -> flat field values: the first stage of :mod:`~bubblerob_env.ros.messages.convert`.

:class:`FrameValues` (a base of :class:`~bubblerob_env.ros.messages.convert.RosConverter`) turns
one env
frame, the observation and info of a ``reset`` or ``step`` plus the action that led to it, into
field values in ROS units and conventions. The recorder's fast path takes them as a tuple
(:meth:`FrameValues.frame_args`), which the generated packer reads by position without building a
dict; message builders take them as a dict (:meth:`FrameValues.frame_values`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, SupportsFloat

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from bubblerob_env.specs import EnvSpecs

__all__ = [
    "ROW",
    "SCALAR_NAMES",
    "STEP_NAMES",
    "FrameValues",
    "Slot",
    "commanded_twist",
    "rep117",
    "row_columns",
    "split_stamp",
]

SCALAR_NAMES = (
    "sec", "nanosec", "seq", "sim_time", "proximity", "triggered",
    "px", "py", "pz", "qx", "qy", "qz", "qw", "vx", "vy", "vz", "wx", "wy", "wz",
    "ox", "oy", "oz", "oqx", "oqy", "oqz", "oqw",
)  # fmt: skip
"""Scalar values of every frame: ``p*``/``q*`` the true pose, ``o*``/``oq*`` the odometry's
(the truth itself without ``odometry_noise``; else the drifting 2D pose at the true height)."""
# Values of a frame after a step, after those of SCALAR_NAMES, the scan and the image.
STEP_NAMES = (
    "action", "left", "right", "linear_x", "angular_z", "reward", "terminated", "truncated",
)  # fmt: skip


ROW = (
    ("info", "position", 3), ("info", "quaternion_wxyz", 4), ("info", "body_twist", 6),
    ("info", "wheel_command", 2), ("obs", "proximity", 1), ("action", "action", 2),
    ("info", "odometry", 3), ("obs", "laser", None),
)  # fmt: skip
"""The numbers of a frame after a step, as a batch gathers them into one ``float64`` row:
``(source, key, width)``, in row order (the laser last, ``num_rays`` wide, if the env has one);
``odometry`` is ``info``'s ``odom_x``, ``odom_y``, ``odom_yaw`` (zeros without odometry noise)."""


def row_columns(num_rays: int) -> dict[str, slice]:
    """Where each key of :data:`ROW` lies in a gathered row."""
    columns, start = {}, 0
    for _, key, width in ROW:
        width = num_rays if width is None else width
        columns[key] = slice(start, start + width)
        start += width
    return columns


def rep117(ranges: NDArray[Any], range_min: float, range_max: float) -> NDArray[Any]:
    """REP 117, in place, the one place it is written; returns ``ranges``.

    Readings at or beyond ``range_max`` (no return) become ``+inf``, those below ``range_min``
    (too close) ``-inf``. The comparisons are in ``ranges``' dtype.
    """
    ranges[ranges >= range_max] = np.inf
    ranges[ranges < range_min] = -np.inf
    return ranges


@dataclass(frozen=True)
class Slot:
    """A placeholder for a value filled in at encode time.

    A scalar slot stands for one number; a slot with ``count`` stands for a fixed-length array or a
    sequence of ``count`` elements, and is filled with their little-endian bytes.
    """

    name: str
    count: int | None = None


def split_stamp(stamp_ns: Any) -> tuple[Any, Any]:
    """Nanoseconds -> ``(sec, nanosec)``: of one stamp (ints) or of many (``int64`` arrays)."""
    return stamp_ns // 1_000_000_000, stamp_ns % 1_000_000_000


def commanded_twist(specs: EnvSpecs, action: Any, left: Any, right: Any) -> tuple[Any, Any]:
    """``(linear x, angular z)`` a step commanded, in m/s and rad/s.

    ``twist`` actions are clipped and scaled as the env does, ``wheels`` actions go through the
    drive's forward kinematics (``left``, ``right``: the wheel command, rad/s). One frame: an
    action of shape ``(2,)`` and floats; many: ``(n, 2)`` and arrays.
    """
    if specs.action_type == "twist":
        clipped = np.clip(action, -1.0, 1.0)
        return clipped[..., 0] * specs.max_linear_speed, clipped[..., 1] * specs.max_angular_speed
    return specs.drive.body_twist(left, right)


class FrameValues:
    """Field values of env frames (see the module docstring)."""

    specs: EnvSpecs

    def __init__(self, specs: EnvSpecs) -> None:
        """The value names of ``specs``' frames (a subclass calls it from its own ``__init__``)."""
        self.specs = specs
        self._odometry_noise = specs.odometry_noise > 0.0
        self._proximity_min = specs.proximity.range_min
        self._proximity_max = specs.proximity.range_max
        names = [*SCALAR_NAMES]
        names += ["ranges"] if specs.laser is not None else []
        names += ["image"] if specs.camera is not None else []
        self._reset_count = len(names)
        self._names = (*names, *STEP_NAMES)

    def value_names(self, stepped: bool) -> tuple[str, ...]:
        """Names of the values of :meth:`frame_args`, in order (a reset's are a prefix)."""
        return self._names if stepped else self._names[: self._reset_count]

    def frame_args(
        self,
        obs: Mapping[str, NDArray[Any]],
        info: Mapping[str, Any],
        stamp_ns: int,
        seq: int = 0,
        action: NDArray[Any] | None = None,
        reward: SupportsFloat = 0.0,
        terminated: bool = False,
        truncated: bool = False,
    ) -> tuple[Any, ...]:
        """Field values of one frame as a tuple named by :meth:`value_names` (the fast path).

        ``action`` is ``None`` after a ``reset``.
        """
        # Called every step while recording: plain calls, a tuple (no dict), numpy for the scan.
        sec, nanosec = split_stamp(stamp_ns)
        qw, qx, qy, qz = info["quaternion_wxyz"].tolist()
        proximity = rep117(
            obs["proximity"].astype(np.float64), self._proximity_min, self._proximity_max
        ).item(0)
        px, py, pz = info["position"].tolist()
        odometry = (px, py, pz, qx, qy, qz, qw)
        if self._odometry_noise:
            half_yaw = 0.5 * info["odom_yaw"]
            odometry = (
                info["odom_x"], info["odom_y"], pz, 0.0, 0.0, math.sin(half_yaw), math.cos(half_yaw)
            )  # fmt: skip
        args: tuple[Any, ...] = (
            sec, nanosec, seq & 0xFFFFFFFF, float(info["sim_time"]), proximity,
            bool(info["proximity_triggered"]), px, py, pz, qx, qy, qz, qw,
            *info["body_twist"].tolist(), *odometry,
        )  # fmt: skip
        laser = self.specs.laser
        if laser is not None:
            ranges = rep117(obs["laser"].astype("<f4"), laser.range_min, laser.range_max)
            args += (ranges.tobytes(),)
        if self.specs.camera is not None:
            args += (np.ascontiguousarray(obs["camera"], dtype=np.uint8).tobytes(),)
        if action is None:
            return args
        raw = np.asarray(action, dtype="<f8").reshape(-1)
        left, right = info["wheel_command"].tolist()
        linear, angular = commanded_twist(self.specs, raw, left, right)
        return (
            *args, raw.tobytes(), left, right, float(linear), float(angular),
            float(reward), bool(terminated), bool(truncated),
        )  # fmt: skip

    def frame_values(
        self,
        obs: Mapping[str, NDArray[Any]],
        info: Mapping[str, Any],
        stamp_ns: int,
        seq: int = 0,
        action: NDArray[Any] | None = None,
        reward: SupportsFloat = 0.0,
        terminated: bool = False,
        truncated: bool = False,
    ) -> dict[str, Any]:
        """Field values of one frame by name (:meth:`frame_args` as a dict)."""
        args = self.frame_args(obs, info, stamp_ns, seq, action, reward, terminated, truncated)
        return dict(zip(self.value_names(action is not None), args, strict=True))
