"""An occupancy grid from a recorded bag's ``/scan`` and ``/tf`` (``bubblerob map BAG``).

The scans are placed with ``odom -> base_link`` from ``/tf`` and ``base_link -> laser_link`` from
``/tf_static`` and folded into a :class:`~bubblerob_env.mapping.LogOddsMapper`. The ground truth
is the episode's ``/map`` in the bag (written at the episode's start) when it has the resolution
asked for; otherwise it comes from the episode's metadata: the env is re-created from the recorded
env id and kwargs and reset with the recorded seed, as replay does. ``map`` and ``odom`` coincide
(the identity on ``/tf_static``): the simulation's world frame.

The IoU printed is that of the occupied cells over the cells the scans observed (free or
occupied): the insides of obstacles and walls are never seen by a laser, so they are left out.
An IoU over nothing (no scan placed, no occupied cell on either side) is ``None``, with the
reason in :attr:`MapResult.missing`: never a score of 1. Topics are found as ``localize`` finds
them (:mod:`~bubblerob_env.ros.bag_topics`): ``--topics vrep`` and namespaced bags map too.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bubblerob_env.mapping import (
    DEFAULT_RESOLUTION,
    OCCUPIED,
    UNKNOWN,
    Grid,
    LogOddsMapper,
    episode_grid,
    occupied_iou,
)
from bubblerob_env.png import write_png  # stdlib zlib: the [ros] extra brings no image library
from bubblerob_env.ros.bag_robots import robot_episodes
from bubblerob_env.ros.bag_topics import BagTopicsError, bag_topic_names
from bubblerob_env.ros.readback.episode_env import make_episode_env
from bubblerob_env.ros.readback.summary import bag_root, find_episodes, open_reader

__all__ = ["MapError", "MapResult", "map_bag", "map_png"]


class MapError(ValueError):
    """The bag cannot be mapped as asked (no episode metadata, no such episode, ...)."""


class MapResult:
    """The mapped grid, the ground truth and the IoU of occupied cells over observed cells."""

    def __init__(self, mapped: Grid, truth: Grid, scans: int, truth_source: str = "") -> None:
        """Compare ``mapped`` with ``truth`` on the cells the mapper observed."""
        self.mapped, self.truth, self.scans = mapped, truth, scans
        self.truth_source = truth_source
        """Where the ground truth came from: the bag's ``/map`` or the re-simulated episode."""
        observed = mapped.data != UNKNOWN
        seen_truth = np.where(observed, truth.data, 0).astype(np.int8)
        seen = Grid(seen_truth, truth.origin, truth.resolution)
        self.missing = _missing(mapped, truth, seen, scans)
        """Why the IoUs are ``None`` (empty when they are numbers)."""
        self.iou = None if self.missing else occupied_iou(mapped, seen)
        self.iou_all = None if self.missing else occupied_iou(mapped, truth)


def _missing(mapped: Grid, truth: Grid, seen: Grid, scans: int) -> str:
    """Why no IoU can be computed, or ``""``: its union must hold a cell."""
    if scans == 0:
        return "no scan was placed: the bag has no laser scans at odometry stamps"
    if not np.any(truth.data == OCCUPIED):
        return "the ground truth has no occupied cell"
    if not np.any((mapped.data == OCCUPIED) | (seen.data == OCCUPIED)):
        return "no occupied cell was observed or mapped"
    return ""


def _yaw(q: Any) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def _stamp(header: Any) -> int:
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)


def _check_episode(path: str | Path, episode: int, count: int) -> None:
    if not count:
        raise MapError(f"{path} holds no bubblerob episode metadata: nothing to map")
    if isinstance(episode, bool) or not 0 <= episode < count:
        raise MapError(
            f"--episode must be an episode index from 0 to {count - 1} (the bag holds {count}), "
            f"got {episode!r}"
        )


def map_bag(
    path: str | Path,
    episode: int = 0,
    resolution: float = DEFAULT_RESOLUTION,
    env_id: str | None = None,
    env_kwargs: dict[str, Any] | None = None,
    robot: str | None = None,
) -> MapResult:
    """Map episode ``episode`` (its index in the bag) of the bag at ``path``.

    ``robot``: which robot of a ``record --robots`` bag (``robot_1``;
    :func:`~bubblerob_env.ros.bag_robots.robot_episodes`).

    The ground truth is the bag's ``/map`` at ``resolution`` if it has one and neither
    ``env_id`` nor ``env_kwargs`` is given, else the episode re-simulated: its env made from the
    metadata's id and kwargs, or from ``env_id`` and ``env_kwargs`` where given (a bag of an env
    registered under another name here).

    Raises:
        MapError: The bag holds no episode metadata or no episode ``episode``, its metadata
            does not make an env, or ``env_id`` / ``env_kwargs`` do not make one.
        OSError: Not a bag, or a damaged one (``CorruptBagError``).
    """
    with open_reader(bag_root(path)) as reader:
        _, episodes = find_episodes(reader)
        try:
            episodes, frame_prefix = robot_episodes(path, episodes, robot)
        except ValueError as error:
            raise MapError(str(error)) from None
        _check_episode(path, episode, len(episodes))
        meta = episodes[episode]
        start = int(meta["start_time_ns"])
        end = int(episodes[episode + 1]["start_time_ns"]) if episode + 1 < len(episodes) else None
        try:
            names = bag_topic_names((c.topic for c in reader.connections), episodes)
        except BagTopicsError as error:
            raise MapError(f"{path}: {error}") from None
        recorded, scans, poses, laser_offset = _read_episode(
            reader, names, (start, end), resolution, frame_prefix
        )
    if recorded is None or env_id is not None or env_kwargs is not None:
        truth, source = _simulated(meta, resolution, env_id, env_kwargs), ""
    else:
        truth, source = recorded, "the bag's /map"
    mapper = LogOddsMapper(truth)
    used = 0
    for stamp, scan in scans:
        base = poses.get(stamp)
        if base is None:
            continue
        x, y, yaw = base
        ox, oy, oyaw = laser_offset
        laser = (
            x + ox * math.cos(yaw) - oy * math.sin(yaw),
            y + ox * math.sin(yaw) + oy * math.cos(yaw),
            yaw + oyaw,
        )
        ranges = np.asarray(scan.ranges, dtype=np.float64)
        angles = scan.angle_min + np.arange(len(ranges)) * scan.angle_increment
        mapper.add_scan(laser, angles, ranges, float(scan.range_max))
        used += 1
    return MapResult(mapper.grid(), truth, used, source or "the re-simulated episode")


Pose = tuple[float, float, float]
"""``(x, y, yaw)``."""


def _read_episode(
    reader: Any,
    names: dict[str, str],
    span: tuple[int, int | None],
    resolution: float,
    frame_prefix: str = "",
) -> tuple[Grid | None, list[tuple[int, Any]], dict[int, Pose], Pose]:
    """What :func:`map_bag` reads of one episode, from ``start`` to before ``end`` (ns).

    Its ``/map`` at ``resolution`` (or None), its scans, ``odom -> base_link`` poses by stamp and
    ``base_link -> laser_link``; ``names``: the bag's topic of each key.
    """
    start, end = span
    laser_offset = (0.0, 0.0, 0.0)
    poses: dict[int, Pose] = {}
    scans: list[tuple[int, Any]] = []
    recorded: Grid | None = None
    role = {names[key]: key for key in ("tf", "tf_static", "scan", "map") if key in names}
    wanted = [c for c in reader.connections if c.topic in role]
    for connection, _, raw in reader.messages(connections=wanted):
        message = reader.deserialize(raw, connection.msgtype)
        if role[connection.topic] == "map":
            if _stamp(message.header) == start:
                recorded = _grid(message, resolution)
            continue
        if role[connection.topic] == "scan":
            stamp = _stamp(message.header)
            if stamp >= start and (end is None or stamp < end):
                scans.append((stamp, message))
            continue
        for transform in message.transforms:
            if not transform.child_frame_id.startswith(frame_prefix):  # another robot's
                continue
            t, q = transform.transform.translation, transform.transform.rotation
            pose = (float(t.x), float(t.y), _yaw(q))
            if transform.child_frame_id.endswith("laser_link"):
                laser_offset = pose
            elif transform.child_frame_id.endswith("base_link"):
                poses[_stamp(transform.header)] = pose
    return recorded, scans, poses, laser_offset


def _grid(message: Any, resolution: float) -> Grid | None:
    """A ``nav_msgs/OccupancyGrid`` as a :class:`Grid`, if it has ``resolution`` m cells."""
    info = message.info
    if not math.isclose(float(info.resolution), resolution, rel_tol=1e-6):  # a float32
        return None
    data = np.asarray(message.data, dtype=np.int8).reshape(int(info.height), int(info.width))
    origin = (float(info.origin.position.x), float(info.origin.position.y))
    return Grid(data.copy(), origin, resolution)


def _simulated(
    meta: dict[str, Any],
    resolution: float,
    env_id: str | None = None,
    env_kwargs: dict[str, Any] | None = None,
) -> Grid:
    """The ground truth of the episode ``meta`` describes, from its env re-created and reset."""
    try:
        env = make_episode_env(meta, MapError, env_id, env_kwargs)
    except MapError as error:
        raise MapError(f"{error}; --env ID and --env-kwargs JSON name one that can") from None
    try:
        env.reset(seed=meta.get("seed"), options=meta.get("options"))
        return episode_grid(env, resolution)
    finally:
        env.close()


def _image(grid: Grid) -> NDArray[np.uint8]:
    """Grey levels: occupied black, free white, unknown grey; north up."""
    picture = np.full(grid.data.shape, 160, dtype=np.uint8)
    picture[grid.data == OCCUPIED] = 0
    picture[grid.data == 0] = 255
    return picture[::-1]


def map_png(result: MapResult, out: str | Path, scale: int = 4) -> Path:
    """Write the mapped grid (left) beside the ground truth (right) as a PNG."""
    left, right = _image(result.mapped), _image(result.truth)
    gap = np.full((left.shape[0], 4), 96, dtype=np.uint8)
    picture = np.hstack([left, gap, right]).repeat(scale, axis=0).repeat(scale, axis=1)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_png(out, picture)
    return out
