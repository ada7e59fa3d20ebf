"""Observation + info + action + sensor specs -> ROS messages. Pure: no I/O, no clocks.

Conversion happens in two stages, so that the recorder's fast path and anyone who wants message
objects share one definition of every field:

1. :meth:`RosConverter.frame_values` (or ``frame_args``, see
   :mod:`~bubblerob_env.ros.messages.values`)
   turns one env frame (the observation and info of a ``reset`` or ``step``, plus the action that
   led to it) into flat field values in ROS units and conventions: REP 117 ``+inf``/``-inf``
   ranges, quaternions in ROS order (x, y, z, w), the action as a wheel speed command and a body
   twist.
2. :meth:`RosConverter.message` builds the ``rosbags`` message of one topic key from such a dict.
   Given :class:`~bubblerob_env.ros.messages.values.Slot` placeholders instead of values (see
   :meth:`RosConverter.slots`), it builds the template that
   :mod:`~bubblerob_env.ros.fastpath.encode`
   compiles.

Frames follow REP 103/105: ``odom -> base_link`` on ``/tf`` and in ``nav_msgs/Odometry`` (twist in
``base_link``), ``base_link -> <sensor>`` and the identity ``map -> odom`` on ``/tf_static``, the
camera image in ``camera_optical_frame``, the episode's occupancy grid (``/map``) in ``map``.
Without ``odometry_noise`` the odometry is the ground truth: it never drifts from the map. With
it, ``/odom`` and ``odom -> base_link`` are the env's drifting odometry and the truth is on
``/base_pose_ground_truth`` (``nav_msgs/Odometry``, frame ``map``, as Stage's ROS driver has it);
a localiser (AMCL) estimates the ``map -> odom`` that the drift makes.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from rosbags.typesys.store import Typestore

from bubblerob_env.ros.messages.detections import detection_array
from bubblerob_env.ros.messages.distros import get_distro, typestore
from bubblerob_env.ros.messages.navigation import goal_pose, path_message
from bubblerob_env.ros.messages.topics import MSGTYPES
from bubblerob_env.ros.messages.values import (
    SCALAR_NAMES,
    STEP_NAMES,
    FrameValues,
    Slot,
    split_stamp,
)
from bubblerob_env.specs import EnvSpecs

__all__ = ["FRAME_KEYS", "MAP_SLOTS", "RosConverter"]

MAP_FRAME = "map"
ODOM_FRAME = "odom"
BASE_FRAME = "base_link"
MAP_SLOTS = ("sec", "nanosec", "seq", "cells")
"""Values of a ``/map`` message (:meth:`RosConverter.occupancy_grid`): stamp, ROS 1 sequence
number and the cells (``int8`` bytes, row-major)."""

FRAME_KEYS = (
    "scan",
    "proximity",
    "sensor_trigger",
    "image",
    "camera_info",
    "odom",
    "base_pose_ground_truth",
    "tf",
    "clock",
    "simulation_time",
    "cmd_vel",
    "left_motor_speed",
    "right_motor_speed",
    "action",
    "reward",
    "terminated",
    "truncated",
)
"""Keys of frame topics, in write order; see :meth:`RosConverter.frame_keys` for which apply."""

_RESULT_KEYS = ("cmd_vel", "left_motor_speed", "right_motor_speed", "action")
_STEP_KEYS = (*_RESULT_KEYS, "reward", "terminated", "truncated")
_RADIATION = {"ULTRASOUND": 0, "INFRARED": 1}


class RosConverter(FrameValues):
    """Builds the messages of one distro from env frames (see the module docstring).

    ``frame_prefix`` (e.g. ``"robot2/"``, as
    :attr:`~bubblerob_env.ros.messages.topics.Topics.frame_prefix`
    gives for a namespace) goes before every frame id, so that robots sharing one ROS graph keep
    separate tf trees on the shared ``/tf``; empty by default (``odom``, ``base_link``, ...).
    """

    def __init__(self, specs: EnvSpecs, distro: str = "jazzy", frame_prefix: str = "") -> None:
        if frame_prefix and (frame_prefix.startswith("/") or not frame_prefix.endswith("/")):
            raise ValueError(
                f"frame_prefix must look like 'robot2/' (no leading slash, REP 105 / tf2), "
                f"got {frame_prefix!r}"
            )
        self.specs = specs
        self.frame_prefix = frame_prefix
        self.shared_map = False
        """Keep ``map`` unprefixed: robots of one world (``bubblerob node --robots``) share it."""
        self.distro = get_distro(distro)
        self.store: Typestore = typestore(distro)
        self._types = self.store.types
        self._ros1 = self.distro.ros_version == 1
        self._camera_field = {
            n.lower(): n for n, _ in self.store.fielddefs["sensor_msgs/msg/CameraInfo"][1]
        }
        self._range_fields = {n for n, _ in self.store.fielddefs["sensor_msgs/msg/Range"][1]}
        self.static_map_to_odom = True
        """Whether ``/tf_static`` has the identity ``map -> odom``; False where a localiser
        (``bubblerob node --localize``, as AMCL) publishes ``map -> odom`` on ``/tf``."""
        super().__init__(specs)

    def frame_keys(self, stepped: bool) -> tuple[str, ...]:
        """Keys of the messages of a frame: after ``reset`` (``stepped=False``) or a ``step``."""
        keys = []
        for key in FRAME_KEYS:
            if key == "scan" and self.specs.laser is None:
                continue
            if key in ("image", "camera_info") and self.specs.camera is None:
                continue
            if key == "base_pose_ground_truth" and self.specs.odometry_noise <= 0.0:
                continue  # the odometry is the truth: /odom has it
            if key in _STEP_KEYS and not stepped:
                continue
            keys.append(key)
        return tuple(keys)

    @staticmethod
    def action_keys() -> tuple[str, ...]:
        """Keys that describe the action of a step (logged when it was sent, not after)."""
        return _RESULT_KEYS

    def slots(self) -> dict[str, Slot]:
        """Placeholders for every value :meth:`frame_values` returns, to build templates."""
        slots = {name: Slot(name) for name in (*SCALAR_NAMES, *STEP_NAMES) if name != "action"}
        slots["action"] = Slot("action", 2)
        if self.specs.laser is not None:
            slots["ranges"] = Slot("ranges", self.specs.laser.num_rays)
        if self.specs.camera is not None:
            camera = self.specs.camera
            slots["image"] = Slot("image", camera.width * camera.height * 3)
        return slots

    # -- messages -------------------------------------------------------------------------------

    def message(self, key: str, v: Mapping[str, Any]) -> Any:
        """The ``rosbags`` message of topic ``key`` for frame values ``v``."""
        return getattr(self, f"_{key}")(v)

    def _msg(self, key: str, **fields: Any) -> Any:
        return self._types[MSGTYPES[key]](**fields)

    def _time(self, sec: Any, nanosec: Any) -> Any:
        return self._types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec)

    def _header(self, v: Mapping[str, Any], frame_id: str) -> Any:
        stamp = self._time(v["sec"], v["nanosec"])
        shared = self.shared_map and frame_id == MAP_FRAME
        frame_id = frame_id if shared else self.frame_prefix + frame_id
        if self._ros1:
            return self._types["std_msgs/msg/Header"](seq=v["seq"], stamp=stamp, frame_id=frame_id)
        return self._types["std_msgs/msg/Header"](stamp=stamp, frame_id=frame_id)

    def _vector3(self, x: Any, y: Any, z: Any) -> Any:
        return self._types["geometry_msgs/msg/Vector3"](x=x, y=y, z=z)

    def _quaternion(self, x: Any, y: Any, z: Any, w: Any) -> Any:
        return self._types["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w)

    def _scan(self, v: Mapping[str, Any]) -> Any:
        spec = self.specs.laser
        assert spec is not None
        return self._msg(
            "scan",
            header=self._header(v, spec.frame_id),
            angle_min=spec.angle_min,
            angle_max=spec.angle_max,
            angle_increment=spec.angle_increment,
            time_increment=0.0,  # every ray is cast at the same instant
            scan_time=spec.scan_time,
            range_min=spec.range_min,
            range_max=spec.range_max,
            ranges=_array(v["ranges"], np.float32),
            intensities=np.zeros(0, dtype=np.float32),
        )

    def _proximity(self, v: Mapping[str, Any]) -> Any:
        spec = self.specs.proximity
        fields = {
            "header": self._header(v, spec.frame_id),
            "radiation_type": _RADIATION[spec.radiation_type],
            "field_of_view": spec.field_of_view,
            "min_range": spec.range_min,
            "max_range": spec.range_max,
            "range": v["proximity"],
        }
        if "variance" in self._range_fields:  # Jazzy and later
            fields["variance"] = 0.0
        return self._msg("proximity", **fields)

    def _sensor_trigger(self, v: Mapping[str, Any]) -> Any:
        return self._msg("sensor_trigger", data=v["triggered"])

    def _image(self, v: Mapping[str, Any]) -> Any:
        spec = self.specs.camera
        assert spec is not None
        return self._msg(
            "image",
            header=self._header(v, spec.frame_id),
            height=spec.height,
            width=spec.width,
            encoding="rgb8",
            is_bigendian=0,
            step=3 * spec.width,
            data=_array(v["image"], np.uint8),
        )

    def _camera_info(self, v: Mapping[str, Any]) -> Any:
        spec = self.specs.camera
        assert spec is not None
        k = spec.intrinsics()
        p = np.zeros((3, 4))
        p[:, :3] = k
        roi = self._types["sensor_msgs/msg/RegionOfInterest"](
            x_offset=0, y_offset=0, height=0, width=0, do_rectify=False
        )
        matrices = {"d": np.zeros(5), "k": k.ravel(), "r": np.eye(3).ravel(), "p": p.ravel()}
        return self._msg(
            "camera_info",
            header=self._header(v, spec.frame_id),
            height=spec.height,
            width=spec.width,
            distortion_model="plumb_bob",
            binning_x=0,
            binning_y=0,
            roi=roi,
            **{self._camera_field[name]: value for name, value in matrices.items()},
        )

    def _cmd_vel(self, v: Mapping[str, Any]) -> Any:
        return self._msg(
            "cmd_vel",
            linear=self._vector3(v["linear_x"], 0.0, 0.0),
            angular=self._vector3(0.0, 0.0, v["angular_z"]),
        )

    def _left_motor_speed(self, v: Mapping[str, Any]) -> Any:
        return self._msg("left_motor_speed", data=v["left"])

    def _right_motor_speed(self, v: Mapping[str, Any]) -> Any:
        return self._msg("right_motor_speed", data=v["right"])

    def _action(self, v: Mapping[str, Any]) -> Any:
        dim = self._types["std_msgs/msg/MultiArrayDimension"](label="action", size=2, stride=2)
        layout = self._types["std_msgs/msg/MultiArrayLayout"](dim=[dim], data_offset=0)
        return self._msg("action", layout=layout, data=_array(v["action"], np.float64))

    def _odom(self, v: Mapping[str, Any]) -> Any:
        return self._odometry(v, ODOM_FRAME, ("ox", "oy", "oz", "oqx", "oqy", "oqz", "oqw"))

    def _base_pose_ground_truth(self, v: Mapping[str, Any]) -> Any:
        return self._odometry(v, MAP_FRAME, ("px", "py", "pz", "qx", "qy", "qz", "qw"))

    def _odometry(self, v: Mapping[str, Any], frame: str, pose_names: tuple[str, ...]) -> Any:
        """A ``nav_msgs/Odometry`` of the pose named ``pose_names`` (x, y, z, qx, qy, qz, qw)."""
        t = self._types
        x, y, z, qx, qy, qz, qw = (v[name] for name in pose_names)
        pose = t["geometry_msgs/msg/Pose"](
            position=t["geometry_msgs/msg/Point"](x=x, y=y, z=z),
            orientation=self._quaternion(qx, qy, qz, qw),
        )
        twist = t["geometry_msgs/msg/Twist"](
            linear=self._vector3(v["vx"], v["vy"], v["vz"]),
            angular=self._vector3(v["wx"], v["wy"], v["wz"]),
        )
        zeros = np.zeros(36)  # no uncertainty reported (the truth, or odometry's unknown drift)
        return self._msg(
            "odom",
            header=self._header(v, frame),
            child_frame_id=self.frame_prefix + BASE_FRAME,
            pose=t["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=zeros),
            twist=t["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=zeros),
        )

    def _transform(self, v: Mapping[str, Any], parent: str, child: str, xyz: Any, xyzw: Any) -> Any:
        t = self._types
        transform = t["geometry_msgs/msg/Transform"](
            translation=self._vector3(*xyz), rotation=self._quaternion(*xyzw)
        )
        return t["geometry_msgs/msg/TransformStamped"](
            header=self._header(v, parent),
            child_frame_id=self.frame_prefix + child,
            transform=transform,
        )

    def _tf(self, v: Mapping[str, Any]) -> Any:
        pose = self._transform(
            v,
            ODOM_FRAME,
            BASE_FRAME,
            (v["ox"], v["oy"], v["oz"]),
            (v["oqx"], v["oqy"], v["oqz"], v["oqw"]),
        )
        return self._msg("tf", transforms=[pose])

    def _clock(self, v: Mapping[str, Any]) -> Any:
        return self._msg("clock", clock=self._time(v["sec"], v["nanosec"]))

    def _simulation_time(self, v: Mapping[str, Any]) -> Any:
        return self._msg("simulation_time", data=v["sim_time"])

    def _reward(self, v: Mapping[str, Any]) -> Any:
        return self._msg("reward", data=v["reward"])

    def _terminated(self, v: Mapping[str, Any]) -> Any:
        return self._msg("terminated", data=v["terminated"])

    def _truncated(self, v: Mapping[str, Any]) -> Any:
        return self._msg("truncated", data=v["truncated"])

    def tf_static(self, stamp_ns: int) -> Any:
        """``/tf_static``: ``map -> odom`` (identity, see :attr:`static_map_to_odom`), sensors."""
        sec, nanosec = split_stamp(stamp_ns)
        v = {"sec": sec, "nanosec": nanosec, "seq": 0}
        identity = self._transform(v, MAP_FRAME, ODOM_FRAME, (0.0, 0.0, 0.0), (0, 0, 0, 1.0))
        transforms = [identity] if self.static_map_to_odom else []
        transforms += [
            self._transform(v, s.parent, s.child, s.translation, s.rotation_xyzw)
            for s in self.specs.static_transforms
        ]
        return self._msg("tf_static", transforms=transforms)

    def occupancy_grid(
        self,
        v: Mapping[str, Any],
        shape: tuple[int, int],
        origin: tuple[float, float],
        resolution: float,
    ) -> Any:
        """``/map`` of values :data:`MAP_SLOTS` (or their slots): ``shape`` (rows, columns) cells.

        The grid's lower-left corner is at ``origin`` (x, y) in ``map``, axes aligned with it;
        loaded at the stamp.
        """
        t = self._types
        rows, cols = shape
        pose = t["geometry_msgs/msg/Pose"](
            position=t["geometry_msgs/msg/Point"](x=float(origin[0]), y=float(origin[1]), z=0.0),
            orientation=self._quaternion(0.0, 0.0, 0.0, 1.0),
        )
        info = t["nav_msgs/msg/MapMetaData"](
            map_load_time=self._time(v["sec"], v["nanosec"]),
            resolution=float(resolution),
            width=cols,
            height=rows,
            origin=pose,
        )
        return self._msg(
            "map", header=self._header(v, MAP_FRAME), info=info, data=_array(v["cells"], np.int8)
        )

    def detections(
        self, v: Mapping[str, Any], classes: Sequence[str], numbers: Sequence[Mapping[str, Any]]
    ) -> Any:
        """``/detections`` of the image of values ``v`` (``sec``, ``nanosec``, ``seq``).

        One detection per class in ``classes``, with its ``numbers``; see
        :mod:`~bubblerob_env.ros.messages.detections`.
        """
        spec = self.specs.camera
        assert spec is not None
        header = self._header(v, spec.frame_id)
        return detection_array(self._types, header, classes, numbers)

    def goal(self, stamp_ns: int, goal: tuple[float, float]) -> Any:
        """A Nav env's goal (x, y) in ``map`` (:mod:`~bubblerob_env.ros.messages.navigation`)."""
        sec, nanosec = split_stamp(stamp_ns)
        return goal_pose(
            self._types, self._header({"sec": sec, "nanosec": nanosec, "seq": 0}, MAP_FRAME), goal
        )

    def plan(self, stamp_ns: int, points: Sequence[Sequence[float]]) -> Any:
        """A Nav env's planned path ``(n, 2)`` in ``map`` as a ``nav_msgs/Path``."""
        sec, nanosec = split_stamp(stamp_ns)
        v = {"sec": sec, "nanosec": nanosec, "seq": 0}
        return path_message(self._types, lambda: self._header(v, MAP_FRAME), points)

    def episode(self, metadata: Mapping[str, Any]) -> Any:
        """``/bubblerob/episode``: the episode's metadata as a JSON ``std_msgs/String``."""
        return self._msg("episode", data=json.dumps(metadata, sort_keys=True))


def _array(value: Any, dtype: type[np.generic]) -> Any:
    """Bytes from :meth:`RosConverter.frame_values` as an array; slots pass through."""
    if isinstance(value, (bytes, bytearray, memoryview)):
        return np.frombuffer(value, dtype=np.dtype(dtype).newbyteorder("<")).astype(dtype)
    return value
