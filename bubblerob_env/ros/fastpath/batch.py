"""Batched recording: gather raw step frames cheaply, convert and pack many of them at once.

Converting and packing one frame costs ~5 us with warm caches but ~20 us inside an env loop,
where each physics step has evicted the interpreter's and numpy's working set. So bag sinks that
pack frames (MCAP, ROS 1) take steps in batches: :meth:`FrameBatch.add` only copies a step's
numbers into one ``float64`` row (one ``numpy`` call); when the batch is full,
:meth:`FrameBatch.columns` computes every field value of every frame with column-wise ``numpy``,
and :class:`BatchPacker` lays all frames out at once in a structured array whose layout is the
frame's (record headers, constants, padding), writing ``n`` frames as one buffer.

The values are those of :meth:`~bubblerob_env.ros.values.FrameValues.frame_args`, computed with
the same operations on the same dtypes, so the bags are byte for byte those of the frame-by-frame
path (``tests/ros/test_packed_frames.py`` checks).
"""

from __future__ import annotations

import math
import struct
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, SupportsFloat

import numpy as np
from numpy.typing import NDArray

from bubblerob_env.ros.encode import PAD, Item, Slot

if TYPE_CHECKING:
    from bubblerob_env.ros.convert import EnvSpecs

__all__ = ["BatchPacker", "FrameBatch"]

# Columns of a gathered row: info arrays, the proximity reading, the action, then the scan.
_POSITION, _QUATERNION_WXYZ, _TWIST, _WHEELS, _PROXIMITY, _ACTION, _SCAN = (
    0, 3, 7, 13, 15, 16, 18,
)  # fmt: skip


class FrameBatch:
    """Frames after steps, gathered as raw numbers until :meth:`columns` converts them all.

    Args:
        specs: The env's sensor and drive specs (as for
            :class:`~bubblerob_env.ros.values.FrameValues`).
        capacity: Frames per batch; :meth:`add` says when it is reached.
    """

    def __init__(self, specs: EnvSpecs, capacity: int) -> None:
        if capacity < 1:
            raise ValueError(f"a batch holds at least one frame, got capacity={capacity}")
        self.specs = specs
        self.capacity = capacity
        self._laser = specs.laser is not None
        self._camera = specs.camera is not None
        width = _SCAN + (specs.laser.num_rays if specs.laser is not None else 0)
        self._rows = np.empty((capacity, width), dtype=np.float64)
        self._count = 0
        self._scalars: list[tuple[Any, ...]] = []
        self._images: list[bytes] = []

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
        # Called every step: one concatenate copies every array into the next row of the buffer
        # (float32 values are exact in float64; "unsafe" casts the action as the env's own
        # np.asarray(action, float64) does), a tuple keeps the scalars; the conversion waits for
        # the whole batch.
        scalars = (
            stamp_ns, seq, action_stamp_ns, float(reward), bool(terminated), bool(truncated),
            bool(info["proximity_triggered"]),
        )  # fmt: skip
        image = None
        if self._camera:
            image = np.ascontiguousarray(obs["camera"], dtype=np.uint8).tobytes()
        parts: tuple[Any, ...] = (
            info["position"], info["quaternion_wxyz"], info["body_twist"], info["wheel_command"],
            obs["proximity"], action,
        )  # fmt: skip
        if self._laser:
            parts += (obs["laser"],)
        np.concatenate(parts, out=self._rows[self._count], casting="unsafe")
        self._count += 1  # the frame is complete: only now does the batch hold it
        self._scalars.append(scalars)
        if image is not None:
            self._images.append(image)
        return self._count >= self.capacity

    def columns(self) -> dict[str, NDArray[Any]]:
        """Every value of every frame gathered so far, by value and log-time slot name; empties.

        Scalars are 1-D arrays; ``ranges``, ``image`` and ``action`` are 2-D arrays of their
        serialised element type (``<f4``, ``u1``, ``<f8``), one row per frame. Some are views of
        the batch's buffer: use them before the next :meth:`add`.
        """
        rows = self._rows[: self._count]
        stamp, seq, action_stamp, reward, terminated, truncated, triggered = zip(
            *self._scalars, strict=True
        )
        images, self._count, self._scalars, self._images = self._images, 0, [], []
        stamps = np.array(stamp, dtype=np.int64)
        action_stamps = np.array(action_stamp, dtype=np.int64)
        specs = self.specs
        sec, nanosec = np.divmod(stamps, 1_000_000_000)
        action_sec, action_nsec = np.divmod(action_stamps, 1_000_000_000)
        proximity = rows[:, _PROXIMITY]
        proximity = np.where(proximity >= specs.proximity.range_max, math.inf, proximity)
        proximity = np.where(proximity < specs.proximity.range_min, -math.inf, proximity)
        raw = np.ascontiguousarray(rows[:, _ACTION:_SCAN], dtype="<f8")
        left, right = rows[:, _WHEELS], rows[:, _WHEELS + 1]
        if specs.action_type == "twist":
            clipped = np.clip(raw, -1.0, 1.0)
            linear = clipped[:, 0] * specs.max_linear_speed
            angular = clipped[:, 1] * specs.max_angular_speed
        else:
            linear, angular = specs.drive.body_twist(left, right)  # type: ignore[arg-type]
        columns: dict[str, NDArray[Any]] = {
            "sec": sec, "nanosec": nanosec, "seq": np.array(seq, dtype=np.int64) & 0xFFFFFFFF,
            "sim_time": stamps * 1e-9, "proximity": proximity,
            "triggered": np.array(triggered, dtype=bool),
            "px": rows[:, _POSITION], "py": rows[:, _POSITION + 1], "pz": rows[:, _POSITION + 2],
            "qw": rows[:, _QUATERNION_WXYZ], "qx": rows[:, _QUATERNION_WXYZ + 1],
            "qy": rows[:, _QUATERNION_WXYZ + 2], "qz": rows[:, _QUATERNION_WXYZ + 3],
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
        for index, name in enumerate(("vx", "vy", "vz", "wx", "wy", "wz")):
            columns[name] = rows[:, _TWIST + index]
        if specs.laser is not None:
            # float32 masks, as frame_args: a Python float threshold compares as float32
            ranges = rows[:, _SCAN:].astype("<f4")
            ranges[ranges >= specs.laser.range_max] = np.inf
            ranges[ranges < specs.laser.range_min] = -np.inf
            columns["ranges"] = ranges
        if specs.camera is not None:
            columns["image"] = np.frombuffer(b"".join(images), dtype=np.uint8).reshape(
                len(stamps), -1
            )
        return columns


class BatchPacker:
    """Many frames laid out at once: a structured ``numpy`` dtype of one packed frame.

    Built from the ``struct`` items of a :class:`~bubblerob_env.ros.serialize.FramePacker`
    (headers and messages of every record): constants and padding go into a template row once,
    and each :class:`~bubblerob_env.ros.encode.Slot` becomes a field at its byte offset, filled
    column-wise from :meth:`FrameBatch.columns`.
    """

    def __init__(self, items: Sequence[Item], size: int) -> None:
        template = bytearray()
        names: list[str] = []
        formats: list[Any] = []
        offsets: list[int] = []
        self._fields: list[tuple[str, str, bool]] = []  # (field, slot, raw bytes)
        for code, value in items:
            width = struct.calcsize("<" + code)
            if isinstance(value, Slot):
                field = f"f{len(names)}"
                blob = code.endswith("s")
                names.append(field)
                formats.append(("u1", (width,)) if blob else np.dtype("<" + code))
                offsets.append(len(template))
                self._fields.append((field, value.name, blob))
                template += bytes(width)
            elif value is PAD:
                template += bytes(width)
            else:
                template += struct.pack("<" + code, value)
        if len(template) != size:
            raise ValueError(f"items pack {len(template)} bytes, the frame has {size}")
        self.size = size
        self.slot_names = tuple(sorted({slot for _, slot, _ in self._fields}))
        self._dtype = np.dtype(
            {"names": names, "formats": formats, "offsets": offsets, "itemsize": size}
        )
        self._template = np.frombuffer(bytes(template), dtype=np.uint8)

    def pack(self, columns: Mapping[str, NDArray[Any]], count: int) -> NDArray[np.uint8]:
        """``count`` frames, one after the other, as a flat ``uint8`` array."""
        data = np.tile(self._template, count)
        frames = data.view(self._dtype)
        for field, slot, blob in self._fields:
            column = columns[slot]
            if blob:  # serialised elements: their little-endian bytes
                frames[field] = np.ascontiguousarray(column).view(np.uint8).reshape(count, -1)
            else:
                frames[field] = column
        return data
