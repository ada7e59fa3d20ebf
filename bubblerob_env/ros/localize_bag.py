"""A bag's episodes as the particle filter reads them: scans, odometry, the map, and the truth.

What ``amcl`` reads from a ROS graph, read from a bag with the project's readers
(:mod:`~bubblerob_env.ros.readback`): ``/scan``, ``odom -> base_link`` from ``/tf`` (or ``/odom``
where ``/tf`` lacks it), the laser's pose on ``base_link`` from ``/tf_static``, and ``/map``. An
episode begins at each ``/map`` (every episode's map is written at its first stamp, in bags and
live alike, so a ``rosbag record`` of a live node splits the same way) and ends at the next.
The truth, kept to score the filter, is ``/base_pose_ground_truth``; a bag without it was recorded
without ``odometry_noise``, whose ``/odom`` is the truth itself. A bag whose metadata says its
odometry drifts but that lacks the truth is refused: its ``/odom`` is no truth to score against.
Topics are found by :mod:`~bubblerob_env.ros.bag_topics` (the metadata's names, else the last part
of each name), so ``--topics vrep`` and a namespaced robot's ``/robot2/scan`` are read too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from bubblerob_env.localisation.evaluation import RecordedEpisode
from bubblerob_env.localisation.laser_model import ScanGeometry
from bubblerob_env.mapping import Grid

__all__ = ["BagEpisodes", "LocalizeBagError", "read_bag_episodes"]

Pose = tuple[float, float, float]


class LocalizeBagError(ValueError):
    """The bag lacks what localisation needs (the message says what)."""


@dataclass(frozen=True)
class BagEpisodes:
    """The episodes of a bag, and where their truth came from."""

    episodes: tuple[RecordedEpisode, ...]
    truth_topic: str
    """``/base_pose_ground_truth``, or ``/odom`` where the odometry is the truth (no noise)."""


def _yaw(q: Any) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def _stamp(header: Any) -> int:
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)


def _pose(p: Any, q: Any) -> Pose:
    return (float(p.x), float(p.y), _yaw(q))


_ROLES = ("tf", "tf_static", "scan", "odom", "map", "base_pose_ground_truth")


class _Collected:
    """Everything the episodes are made of, keyed by stamp (ns)."""

    def __init__(self, frame_prefix: str = "") -> None:
        self.frame_prefix = frame_prefix
        """Only frames under it (one robot of a ``record --robots`` bag); ``""``: all."""
        self.maps: list[tuple[int, Grid]] = []
        self.scans: dict[int, Any] = {}
        self.tf_odom: dict[int, Pose] = {}
        self.odom: dict[int, Pose] = {}
        self.truth: dict[int, Pose] = {}
        self.statics: dict[str, Pose] = {}

    def add(self, role: str, message: Any) -> None:
        if role == "map":
            self.maps.append((_stamp(message.header), _grid(message)))
        elif role == "scan":
            self.scans[_stamp(message.header)] = message
        elif role in ("odom", "base_pose_ground_truth"):
            into = self.odom if role == "odom" else self.truth
            pose = message.pose.pose
            into[_stamp(message.header)] = _pose(pose.position, pose.orientation)
        else:
            for t in message.transforms:
                if not t.child_frame_id.startswith(self.frame_prefix):  # another robot's
                    continue
                pose = _pose(t.transform.translation, t.transform.rotation)
                if role == "tf_static":
                    self.statics[t.child_frame_id] = pose
                elif t.header.frame_id.endswith("odom") and t.child_frame_id.endswith("base_link"):
                    self.tf_odom[_stamp(t.header)] = pose


def _grid(message: Any) -> Grid:
    info = message.info
    data = np.asarray(message.data, dtype=np.int8).reshape(int(info.height), int(info.width))
    origin = (float(info.origin.position.x), float(info.origin.position.y))
    return Grid(data.copy(), origin, float(info.resolution))


def _collect(path: str | Path, robot: str | None) -> tuple[_Collected, list[dict[str, Any]]]:
    from bubblerob_env.ros.bag_robots import robot_episodes
    from bubblerob_env.ros.bag_topics import BagTopicsError, bag_topic_names
    from bubblerob_env.ros.readback.summary import bag_root, find_episodes, open_reader

    with open_reader(bag_root(path)) as reader:
        _, metadata = find_episodes(reader)
        try:
            metadata, frame_prefix = robot_episodes(path, metadata, robot)
        except ValueError as error:
            raise LocalizeBagError(str(error)) from None
        found = _Collected(frame_prefix)
        try:
            names = bag_topic_names((c.topic for c in reader.connections), metadata)
        except BagTopicsError as error:
            raise LocalizeBagError(f"{path}: {error}") from None
        role = {names[key]: key for key in _ROLES if key in names}
        wanted = [c for c in reader.connections if c.topic in role]
        for connection, _, raw in reader.messages(connections=wanted):
            found.add(role[connection.topic], reader.deserialize(raw, connection.msgtype))
    return found, metadata


def _drifting(metadata: list[dict[str, Any]]) -> bool:
    """Whether an episode was recorded with ``odometry_noise`` > 0 (its ``/odom`` drifts)."""
    for meta in metadata:
        noise = (meta.get("env_kwargs") or {}).get("odometry_noise")
        if isinstance(noise, int | float) and noise > 0:
            return True
    return False


def _geometry(scan: Any, statics: dict[str, Pose]) -> ScanGeometry:
    frame = str(scan.header.frame_id)
    if frame not in statics:
        raise LocalizeBagError(
            f"no transform to the scan's frame {frame!r} on /tf_static: the laser's pose on "
            "base_link is needed"
        )
    angles = float(scan.angle_min) + np.arange(len(scan.ranges), dtype=np.float64) * float(
        scan.angle_increment
    )
    return ScanGeometry(angles, float(scan.range_min), float(scan.range_max), statics[frame])


def read_bag_episodes(path: str | Path, robot: str | None = None) -> BagEpisodes:
    """The episodes of the bag at ``path`` (see the module docstring).

    ``robot``: which robot of a ``record --robots`` bag (``robot_1``).

    Raises:
        LocalizeBagError: No ``/map``, ``/scan`` or odometry, or no laser pose on ``/tf_static``.
        OSError: Not a bag, or a damaged one (``CorruptBagError``).
    """
    found, metadata = _collect(path, robot)
    for what, present in (("/map", found.maps), ("/scan", found.scans)):
        if not present:
            raise LocalizeBagError(f"{path} has no {what}: localisation needs the map and scans")
    odometry = found.tf_odom or found.odom
    if not odometry:
        raise LocalizeBagError(f"{path} has neither odom -> base_link on /tf nor /odom")
    if not found.truth and _drifting(metadata):
        raise LocalizeBagError(
            f"{path} was recorded with odometry_noise but has no /base_pose_ground_truth: its "
            "drifting /odom is no truth to score against (n/a); record that topic too"
        )
    truth, truth_topic = (found.truth, "/base_pose_ground_truth") if found.truth else (
        found.odom, "/odom")  # fmt: skip
    seeds = {int(m["start_time_ns"]): m.get("seed") for m in metadata}
    maps = sorted(found.maps, key=lambda item: item[0])
    stamps = np.array(sorted(s for s in found.scans if s in odometry and s in truth))
    episodes = []
    for k, (start, grid) in enumerate(maps):
        end = maps[k + 1][0] if k + 1 < len(maps) else None
        inside = stamps[(stamps >= start) & (stamps < (end if end is not None else np.inf))]
        if len(inside) < 2:
            continue
        scans = [found.scans[int(s)] for s in inside]
        seed = seeds.get(start)
        episodes.append(
            RecordedEpisode(
                seed=int(seed) if seed is not None else k,
                dt=float(np.median(np.diff(inside))) * 1e-9,
                truth=np.array([truth[int(s)] for s in inside]),
                odometry=np.array([odometry[int(s)] for s in inside]),
                scans=np.array([np.asarray(s.ranges, dtype=np.float32) for s in scans]),
                grid=grid,
                geometry=_geometry(scans[0], found.statics),
            )
        )
    if not episodes:
        raise LocalizeBagError(f"{path} has no episode with two scans at odometry and truth stamps")
    return BagEpisodes(tuple(episodes), truth_topic)
