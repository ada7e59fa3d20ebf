"""Batched recording: gather raw step frames cheaply, convert and pack many of them at once.

Converting and packing one frame costs ~5 us with warm caches but ~20 us inside an env loop,
where each physics step has evicted the interpreter's and numpy's working set. So bag sinks that
pack frames (MCAP, ROS 1) take steps in batches: :meth:`FrameBatch.add` only copies a step's
numbers into one ``float64`` row (one ``numpy`` call); when the batch is full,
:meth:`FrameBatch.columns` computes every field value of every frame with column-wise ``numpy``,
and :meth:`~bubblerob_env.ros.fastpath.packer.Packer.pack_many` lays all frames out at once in a
structured array whose layout is the frame's (record headers, constants, padding), writing ``n``
frames as one buffer. Where each number lies in the gathered row comes from one table,
:data:`~bubblerob_env.ros.messages.values.ROW`.

The values are those of
:meth:`~bubblerob_env.ros.messages.values.FrameValues.frame_args`, computed with
the same operations on the same dtypes, so the bags are byte for byte those of the frame-by-frame
path (``tests/ros/test_packed_frames.py`` checks).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, NamedTuple, SupportsFloat

import numpy as np
from numpy.typing import NDArray

from bubblerob_env.ros.messages.values import (
    ROW,
    commanded_twist,
    rep117,
    row_columns,
    split_stamp,
)

if TYPE_CHECKING:
    from bubblerob_env.specs import EnvSpecs

__all__ = ["FrameBatch", "Gathered"]


class Gathered(NamedTuple):
    """A batch's frames as gathered: raw numbers, before :meth:`FrameBatch.convert`."""

    rows: NDArray[np.float64]
    """One row per frame of the small arrays, in ``ROW`` order."""
    lasers: NDArray[np.float32]
    """One scan per frame (no rows without a laser)."""
    images: NDArray[np.uint8]
    """One image's bytes per frame (no rows without a camera)."""
    scalars: list[tuple[Any, ...]]
    """Stamp, seq, action stamp, reward, terminated, truncated, triggered, sim time per frame."""


class FrameBatch:
    """Frames after steps, gathered as raw numbers until :meth:`columns` converts them all.

    Args:
        specs: The env's sensor and drive specs (as for
            :class:`~bubblerob_env.ros.messages.values.FrameValues`).
        capacity: Frames per batch; :meth:`add` says when it is reached.
    """

    def __init__(self, specs: EnvSpecs, capacity: int) -> None:
        if capacity < 1:
            raise ValueError(f"a batch holds at least one frame, got capacity={capacity}")
        self.specs = specs
        self.capacity = capacity
        self._laser = specs.laser is not None
        self._camera = specs.camera is not None
        self._odometry = specs.odometry_noise > 0.0
        nray = specs.laser.num_rays if specs.laser is not None else 0
        self._at = row_columns(nray)
        # The laser apart, in its serialised dtype: float32 readings as they come (half the
        # bytes of float64 rows; float64 ones round to float32 here as astype would later).
        self._rows = np.empty((capacity, self._at["laser"].start), dtype=np.float64)
        self._lasers = np.empty((capacity if self._laser else 0, nray), dtype="<f4")
        self._count = 0
        self._scalars: list[tuple[Any, ...]] = []
        camera = specs.camera
        pixels = 0 if camera is None else camera.height * camera.width * 3
        self._images = np.empty((capacity if camera is not None else 0, pixels), dtype=np.uint8)

    def __len__(self) -> int:
        return self._count

    def add(
        self,
        obs: Mapping[str, NDArray[Any]],
        info: Mapping[str, Any],
        stamp_ns: int,
        seq: int,
        action: Any,
        action_stamp_ns: int,
        reward: SupportsFloat,
        terminated: bool,
        truncated: bool,
    ) -> bool:
        """Copy one step's frame (the env may reuse its arrays); True once the batch is full.

        All or nothing: a frame that ``frame_args`` would reject (a missing key, a reward that is
        not a number) raises here, at its step, and leaves the batch as it was.
        """
        # Called every step: one concatenate copies the small arrays into the next row of the
        # buffer (float32 values are exact in float64; "unsafe" casts the action as the env's own
        # np.asarray(action, float64) does), the scan goes to its own float32 row, a tuple keeps
        # the scalars; the conversion waits for the whole batch.
        scalars = (
            stamp_ns, seq, action_stamp_ns, float(reward), bool(terminated), bool(truncated),
            bool(info["proximity_triggered"]), float(info["sim_time"]),
        )  # fmt: skip
        if self._camera:  # into the next free row: the batch holds it only once counted
            self._images[self._count] = np.ravel(obs["camera"])
        odometry = (
            (info["odom_x"], info["odom_y"], info["odom_yaw"]) if self._odometry else _NO_ODOMETRY
        )
        parts = (  # in ROW order (checked below, at import)
            info["position"], info["quaternion_wxyz"], info["body_twist"], info["wheel_command"],
            obs["proximity"], action, odometry,
        )  # fmt: skip
        _concatenate(parts, out=self._rows[self._count], casting="unsafe")
        if self._laser:
            self._lasers[self._count] = obs["laser"]
        self._count += 1  # the frame is complete: only now does the batch hold it
        self._scalars.append(scalars)
        return self._count >= self.capacity

    def columns(self) -> dict[str, NDArray[Any]]:
        """Every value of every frame gathered so far, by value and log-time slot name; empties.

        Scalars are 1-D arrays; ``ranges``, ``image`` and ``action`` are 2-D arrays of their
        serialised element type (``<f4``, ``u1``, ``<f8``), one row per frame. Some are views of
        the batch's buffer: use them before the next :meth:`add`.
        """
        return self.convert(self.take())

    def take(self) -> Gathered:
        """The frames gathered so far, as they are; empties.

        The arrays are views of the buffers, valid until the next :meth:`add`. :meth:`convert` of
        them is :meth:`columns` (another process's ``FrameBatch`` of the same specs may convert
        them).
        """
        count = self._count
        gathered = Gathered(
            self._rows[:count], self._lasers[:count], self._images[:count], self._scalars
        )
        self._count, self._scalars = 0, []
        return gathered

    def convert(self, gathered: Gathered) -> dict[str, NDArray[Any]]:
        """:meth:`columns` of frames :meth:`take` gave."""
        rows, lasers, images, scalars = gathered
        stamp, seq, action_stamp, reward, terminated, truncated, triggered, sim_time = zip(
            *scalars, strict=True
        )
        stamps = np.array(stamp, dtype=np.int64)
        action_stamps = np.array(action_stamp, dtype=np.int64)
        specs = self.specs
        sec, nanosec = split_stamp(stamps)
        action_sec, action_nsec = split_stamp(action_stamps)
        at = self._at
        proximity = rep117(
            rows[:, at["proximity"].start].copy(),
            specs.proximity.range_min,
            specs.proximity.range_max,
        )
        raw = np.ascontiguousarray(rows[:, at["action"]], dtype="<f8")
        left, right = rows[:, at["wheel_command"]].T
        position, quaternion_wxyz = rows[:, at["position"]].T, rows[:, at["quaternion_wxyz"]].T
        linear, angular = commanded_twist(specs, raw, left, right)
        columns: dict[str, NDArray[Any]] = {
            "sec": sec, "nanosec": nanosec, "seq": np.array(seq, dtype=np.int64) & 0xFFFFFFFF,
            "sim_time": np.array(sim_time, dtype=np.float64), "proximity": proximity,
            "triggered": np.array(triggered, dtype=bool),
            "px": position[0], "py": position[1], "pz": position[2],
            "qw": quaternion_wxyz[0], "qx": quaternion_wxyz[1],
            "qy": quaternion_wxyz[2], "qz": quaternion_wxyz[3],
            "action": raw, "left": left, "right": right,
            "linear_x": np.asarray(linear, dtype=np.float64),
            "angular_z": np.asarray(angular, dtype=np.float64),
            "reward": np.array(reward, dtype=np.float64),
            "terminated": np.array(terminated, dtype=bool),
            "truncated": np.array(truncated, dtype=bool),
            "log_ns": stamps, "log_sec": sec, "log_nsec": nanosec,
            "action_log_ns": action_stamps, "action_log_sec": action_sec,
            "action_log_nsec": action_nsec,
        }  # fmt: skip
        twist = rows[:, at["body_twist"]].T
        for index, name in enumerate(("vx", "vy", "vz", "wx", "wy", "wz")):
            columns[name] = twist[index]
        columns.update(self._odometry_columns(columns, rows[:, at["odometry"]].T))
        if specs.laser is not None:
            # float32 masks, as frame_args: a Python float threshold compares as float32
            columns["ranges"] = rep117(lasers, specs.laser.range_min, specs.laser.range_max)
        if specs.camera is not None:
            columns["image"] = images  # a writable view: the recogniser takes it as it is
        return columns

    def _odometry_columns(
        self, columns: Mapping[str, NDArray[Any]], odometry: NDArray[np.float64]
    ) -> dict[str, NDArray[Any]]:
        """The ``o*`` values, as ``frame_args`` computes them: the truth, or the 2D odometry."""
        truth = ("px", "py", "pz", "qx", "qy", "qz", "qw")
        names = ("ox", "oy", "oz", "oqx", "oqy", "oqz", "oqw")
        if not self._odometry:
            return {name: columns[source] for name, source in zip(names, truth, strict=True)}
        # math's sin and cos, as frame_args: numpy's vectorised ones may differ in the last bit.
        half_yaw = (0.5 * odometry[2]).tolist()
        sin = np.array([math.sin(h) for h in half_yaw])
        cos = np.array([math.cos(h) for h in half_yaw])
        zeros = np.zeros(len(half_yaw))
        values = (odometry[0], odometry[1], columns["pz"], zeros, zeros, sin, cos)
        return dict(zip(names, values, strict=True))


_NO_ODOMETRY = np.zeros(3)  # the odometry columns of an env without odometry noise (an array:
# concatenate would convert a tuple every step)
_concatenate: Any = getattr(np.concatenate, "_implementation", np.concatenate)
"""``np.concatenate`` without NumPy's ``__array_function__`` dispatch (NEP 18), which checks each
of the 8 arrays for an override: ~20% of its time a step here; the arrays are NumPy's own."""

# FrameBatch.add gathers a row with a tuple literal (the cheapest per step): keep it in ROW order.
assert [key for _, key, _ in ROW] == [
    "position", "quaternion_wxyz", "body_twist", "wheel_command", "proximity", "action",
    "odometry", "laser",
], "FrameBatch.add gathers in ROW order"  # fmt: skip
