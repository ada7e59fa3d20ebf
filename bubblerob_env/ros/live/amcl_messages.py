"""The live localiser's messages, as ``amcl`` sends and takes them, serialised for a distro.

Out: ``/amcl_pose`` (``geometry_msgs/PoseWithCovarianceStamped``: the estimate in ``map`` and the
particles' covariance of x, y and yaw, the rest zero, as AMCL fills it), ``/particlecloud``
(``geometry_msgs/PoseArray``) and ``map -> odom`` on ``/tf``. In: ``/initialpose``
(``PoseWithCovarianceStamped``, as rviz's "2D Pose Estimate" sends it; AMCL takes the diagonal's
x, y and yaw variances as the spread of the new particles).

A particle cloud has up to thousands of poses every update: building a ``rosbags`` object per
pose would cost more than the filter, so the poses are packed with NumPy after the serialised
header of an empty ``PoseArray`` (the field layout both encodings share: a count, then seven
float64 per pose; CDR aligns them to 8 bytes). ``tests/live/test_localize_live.py`` checks these
bytes against ``rosbags``' serialisation.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bubblerob_env.ros.messages.distros import deserialize, get_distro, serialize, typestore

__all__ = [
    "INITIAL_POSE",
    "PARTICLE_CLOUD",
    "POSE_WITH_COVARIANCE",
    "InitialPoseError",
    "amcl_pose",
    "decode_initial_pose",
    "particle_cloud",
    "transform",
]

POSE_WITH_COVARIANCE = "geometry_msgs/msg/PoseWithCovarianceStamped"
PARTICLE_CLOUD = "geometry_msgs/msg/PoseArray"
INITIAL_POSE = POSE_WITH_COVARIANCE
TF = "tf2_msgs/msg/TFMessage"

Pose = tuple[float, float, float]


class InitialPoseError(ValueError):
    """An ``/initialpose`` that cannot be used: ``reason`` in a word or two, the message why."""

    def __init__(self, reason: str, detail: str) -> None:
        super().__init__(detail)
        self.reason = reason


def _stamp(types: dict[str, Any], stamp_ns: int) -> Any:
    sec, nanosec = divmod(stamp_ns, 1_000_000_000)
    return types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec)


def _header(distro: str, stamp_ns: int, frame_id: str, seq: int = 0) -> Any:
    types = typestore(distro).types
    fields: dict[str, Any] = {"stamp": _stamp(types, stamp_ns), "frame_id": frame_id}
    if get_distro(distro).ros_version == 1:
        fields["seq"] = seq
    return types["std_msgs/msg/Header"](**fields)


def _pose(types: dict[str, Any], pose: Pose) -> Any:
    x, y, yaw = pose
    return types["geometry_msgs/msg/Pose"](
        position=types["geometry_msgs/msg/Point"](x=float(x), y=float(y), z=0.0),
        orientation=types["geometry_msgs/msg/Quaternion"](
            x=0.0, y=0.0, z=math.sin(yaw / 2.0), w=math.cos(yaw / 2.0)
        ),
    )


def amcl_pose(
    distro: str, stamp_ns: int, frame_id: str, pose: Pose, covariance: NDArray[np.float64]
) -> bytes:
    """``/amcl_pose``: ``pose`` (x, y, yaw) with the 3x3 ``covariance`` of x, y, yaw."""
    types = typestore(distro).types
    full = np.zeros((6, 6))
    full[np.ix_([0, 1, 5], [0, 1, 5])] = covariance
    message = types[POSE_WITH_COVARIANCE](
        header=_header(distro, stamp_ns, frame_id),
        pose=types["geometry_msgs/msg/PoseWithCovariance"](
            pose=_pose(types, pose), covariance=full.ravel()
        ),
    )
    return serialize(distro, message, POSE_WITH_COVARIANCE)


def particle_cloud(
    distro: str, stamp_ns: int, frame_id: str, particles: NDArray[np.float64]
) -> bytes:
    """``/particlecloud``: every particle (``(n, 3)``: x, y, yaw) as a pose."""
    types = typestore(distro).types
    empty = types[PARTICLE_CLOUD](header=_header(distro, stamp_ns, frame_id), poses=[])
    head = serialize(distro, empty, PARTICLE_CLOUD)[:-4]  # without the count (0)
    poses = np.zeros((len(particles), 7))
    poses[:, 0:2] = particles[:, 0:2]
    poses[:, 5] = np.sin(particles[:, 2] / 2.0)
    poses[:, 6] = np.cos(particles[:, 2] / 2.0)
    count = len(particles).to_bytes(4, "little")
    padding = b""
    if get_distro(distro).ros_version == 2 and len(particles):
        # CDR aligns float64s to 8 bytes counted after the 4-byte encapsulation header, which
        # ``head`` holds: the count's 4 bytes after it make up for it.
        padding = bytes((-len(head)) % 8)
    return head + count + padding + poses.astype("<f8").tobytes()


def transform(
    distro: str, stamp_ns: int, parent: str, child: str, pose: Pose
) -> bytes:  # fmt: skip
    """``/tf`` with one transform: ``parent -> child`` of ``pose`` (x, y, yaw)."""
    types = typestore(distro).types
    x, y, yaw = pose
    stamped = types["geometry_msgs/msg/TransformStamped"](
        header=_header(distro, stamp_ns, parent),
        child_frame_id=child,
        transform=types["geometry_msgs/msg/Transform"](
            translation=types["geometry_msgs/msg/Vector3"](x=float(x), y=float(y), z=0.0),
            rotation=types["geometry_msgs/msg/Quaternion"](
                x=0.0, y=0.0, z=math.sin(yaw / 2.0), w=math.cos(yaw / 2.0)
            ),
        ),
    )
    return serialize(distro, types[TF](transforms=[stamped]), TF)


def decode_initial_pose(distro: str, raw: bytes, map_frame: str) -> tuple[Pose, Pose]:
    """``(pose, std)`` of an ``/initialpose``: x, y, yaw and their standard deviations.

    Raises:
        InitialPoseError: Undecodable bytes, a frame other than ``map_frame`` (AMCL ignores
            those too; an empty frame is taken as the map, as AMCL does with a warning),
            non-finite numbers, a zero quaternion or a negative variance.
    """
    try:
        message: Any = deserialize(distro, raw, INITIAL_POSE)
    except Exception as error:  # noqa: BLE001 - whatever a malformed buffer raises
        raise InitialPoseError("undecodable", f"undecodable {INITIAL_POSE} ({error})") from None
    frame = str(message.header.frame_id)
    if frame not in ("", map_frame):
        raise InitialPoseError(
            "wrong frame", f"frame {frame!r}: initial poses must be in {map_frame!r}"
        )
    p, q = message.pose.pose.position, message.pose.pose.orientation
    covariance = np.asarray(message.pose.covariance, dtype=np.float64)
    values = [p.x, p.y, q.x, q.y, q.z, q.w]
    if not (all(math.isfinite(v) for v in values) and np.isfinite(covariance).all()):
        raise InitialPoseError("non-finite", "non-finite pose or covariance")
    norm = math.sqrt(q.x**2 + q.y**2 + q.z**2 + q.w**2)
    if norm < 1e-9:
        raise InitialPoseError("zero quaternion", "the orientation is a zero quaternion")
    variances = covariance[[0, 7, 35]]
    if (variances < 0).any():
        raise InitialPoseError("negative variance", f"negative variance in {variances.tolist()}")
    yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
    std = np.sqrt(variances)
    return (float(p.x), float(p.y), yaw), (float(std[0]), float(std[1]), float(std[2]))
