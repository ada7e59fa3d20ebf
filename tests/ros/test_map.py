"""``/map`` in bags, read back by independent readers and checked against the obstacle geometry.

The oracle is ``tests/test_solid_world.py``'s: obstacle footprints from the layout the env reports
(cylinders as circles, boxes as rotated rectangles) and the walls as the prisms its MJCF describes,
with their signed distance functions. A cell is expected occupied when its centre lies inside a
footprint or a wall (signed distance <= 0); cells whose centre is within half a cell of any
boundary are excluded (they are counted and reported). The grid's size and origin are derived here
from the arena's outer wall faces (``HALF`` + the wall thickness): the grid must cover them,
centred on the arena.

Readers: Debian's ``rosbag`` Python API under ``/usr/bin/python3`` (ROS 1), ``mcap_ros2``'s decoder
(MCAP, from the schema in the file), ``rosbags``' ``AnyReader`` (sqlite3).
"""

from __future__ import annotations

import json
import math
import textwrap
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from cli_usage import run
from ros_helpers import missing_debian_ros, run_debian
from rosbags.highlevel import AnyReader
from test_solid_world import HALF, WALL_HALF_THICKNESS, obstacle_shape, shape_sdf, wall_prisms

import bubblerob_env  # noqa: F401 - registers BubbleRob-v0
from bubblerob_env.ros import RosBagRecorder

SEEDS = (0, 1, 2)
START = 1_700_000_000.0

DEBIAN_READ_MAPS = textwrap.dedent(
    """
    import json, sys
    import rosbag

    out = {"maps": [], "tf_static": []}
    with rosbag.Bag(sys.argv[1]) as bag:
        for topic, msg, stamp in bag.read_messages(topics=["/map", "/tf_static"]):
            if topic == "/tf_static":
                out["tf_static"] += [[t.header.frame_id, t.child_frame_id] for t in msg.transforms]
                continue
            i = msg.info
            out["maps"].append({
                "log_ns": stamp.to_nsec(), "stamp_ns": msg.header.stamp.to_nsec(),
                "frame_id": msg.header.frame_id, "resolution": i.resolution,
                "width": i.width, "height": i.height,
                "origin": [i.origin.position.x, i.origin.position.y, i.origin.position.z,
                           i.origin.orientation.x, i.origin.orientation.y,
                           i.origin.orientation.z, i.origin.orientation.w],
                "data": list(msg.data),
            })
    print(json.dumps(out))
    """
)


def _map_dict(log_ns: int, msg: Any) -> dict[str, Any]:
    i = msg.info
    o = i.origin
    stamp = msg.header.stamp
    return {
        "log_ns": log_ns,
        "stamp_ns": int(stamp.sec) * 10**9 + int(getattr(stamp, "nanosec", 0)),
        "frame_id": msg.header.frame_id,
        "resolution": i.resolution,
        "width": i.width,
        "height": i.height,
        "origin": [
            o.position.x,
            o.position.y,
            o.position.z,
            o.orientation.x,
            o.orientation.y,
            o.orientation.z,
            o.orientation.w,
        ],  # fmt: skip
        "data": list(np.asarray(msg.data, dtype=np.int8).tolist()),
    }


def read_with_debian(path: Path) -> dict[str, Any]:
    reason = missing_debian_ros()
    if reason is not None:
        pytest.skip(reason)
    script = path.parent / "read_maps.py"
    script.write_text(DEBIAN_READ_MAPS)
    result = run_debian("/usr/bin/python3", str(script), str(path))
    assert result.returncode == 0, result.stderr
    return dict(json.loads(result.stdout))


def read_with_mcap_ros2(path: Path) -> dict[str, Any]:
    reader = pytest.importorskip("mcap_ros2.reader")
    (file,) = sorted(path.glob("*.mcap"))
    out: dict[str, Any] = {"maps": [], "tf_static": []}
    for item in reader.read_ros2_messages(str(file), topics=["/map", "/tf_static"]):
        msg = item.ros_msg
        if item.channel.topic == "/tf_static":
            out["tf_static"] += [[t.header.frame_id, t.child_frame_id] for t in msg.transforms]
        else:
            out["maps"].append(_map_dict(item.log_time_ns, msg))
    return out


def read_with_rosbags(path: Path) -> dict[str, Any]:
    out: dict[str, Any] = {"maps": [], "tf_static": []}
    with AnyReader([path]) as reader:
        wanted = [c for c in reader.connections if c.topic in ("/map", "/tf_static")]
        for connection, log_ns, raw in reader.messages(connections=wanted):
            msg = reader.deserialize(raw, connection.msgtype)
            if connection.topic == "/tf_static":
                out["tf_static"] += [[t.header.frame_id, t.child_frame_id] for t in msg.transforms]
            else:
                out["maps"].append(_map_dict(log_ns, msg))
    return out


READERS = {"ros1": read_with_debian, "mcap": read_with_mcap_ros2, "sqlite3": read_with_rosbags}


def expected_geometry(resolution: float) -> tuple[int, tuple[float, float]]:
    """Cells a side and origin of a grid of the arena and its walls, centred on the arena."""
    outer = HALF + 2 * WALL_HALF_THICKNESS
    cells = math.ceil(2 * outer / resolution - 1e-9)
    return cells, (-cells * resolution / 2, -cells * resolution / 2)


def oracle(layout: Any, cells: int, origin: tuple[float, float], resolution: float) -> Any:
    """``(occupied, excluded)`` boolean arrays ``[row, col]`` from the layout's geometry."""
    shapes = [*wall_prisms(), *(obstacle_shape(o) for o in layout.obstacles)]
    occupied = np.zeros((cells, cells), dtype=bool)
    excluded = np.zeros((cells, cells), dtype=bool)
    for row in range(cells):
        y = origin[1] + (row + 0.5) * resolution
        for col in range(cells):
            x = origin[0] + (col + 0.5) * resolution
            distances = [shape_sdf(shape, x, y) for shape in shapes]
            occupied[row, col] = min(distances) <= 0.0
            excluded[row, col] = min(abs(d) for d in distances) < resolution / 2
    return occupied, excluded


def _record(tmp_path: Path, fmt: str, seeds: tuple[int, ...], **kwargs: Any) -> Path:
    env = gym.make("BubbleRob-v0", max_episode_steps=4, laser_num_rays=8)
    with RosBagRecorder(
        env, tmp_path / f"bag_{fmt}", format=fmt, start_time=START, **kwargs
    ) as recorder:
        for seed in seeds:
            recorder.reset(seed=seed)
            done = False
            while not done:
                _, _, terminated, truncated, _ = recorder.step(np.zeros(2, dtype=np.float32))
                done = terminated or truncated
    return recorder.bag_paths[0]


def _layouts(seeds: tuple[int, ...]) -> list[Any]:
    env = gym.make("BubbleRob-v0", max_episode_steps=4, laser_num_rays=8)
    layouts = []
    for seed in seeds:
        env.reset(seed=seed)
        layouts.append(env.unwrapped.layout)
    env.close()
    return layouts


def check_maps(
    report: dict[str, Any], seeds: tuple[int, ...], resolution: float, dt_ns: int
) -> tuple[int, int, int]:
    """Assert every map of ``report``; ``(cells compared, cells excluded, occupied compared)``."""
    maps = report["maps"]
    assert len(maps) == len(seeds)  # exactly one per episode
    assert ["map", "odom"] in report["tf_static"]
    cells, origin = expected_geometry(resolution)
    compared = excluded_total = occupied_total = 0
    start_ns = round(START * 1e9)
    for index, (message, layout) in enumerate(zip(maps, _layouts(seeds), strict=True)):
        # Episodes of 4 steps, back to back, one step apart: episode k starts at 5 k steps.
        assert message["log_ns"] == message["stamp_ns"] == start_ns + index * 5 * dt_ns
        assert message["frame_id"] == "map"
        assert message["resolution"] == pytest.approx(resolution, rel=1e-6)
        assert (message["width"], message["height"]) == (cells, cells)
        assert message["origin"] == pytest.approx([*origin, 0.0, 0.0, 0.0, 0.0, 1.0], abs=1e-9)
        data = np.array(message["data"], dtype=np.int8).reshape(cells, cells)
        assert set(np.unique(data).tolist()) <= {0, 100}
        occupied, excluded = oracle(layout, cells, origin, resolution)
        keep = ~excluded
        wrong = np.argwhere(keep & ((data == 100) != occupied))
        assert len(wrong) == 0, f"seed {seeds[index]}: {len(wrong)} cells differ, e.g. {wrong[:5]}"
        assert np.count_nonzero(occupied & keep & ~_walls(cells, origin, resolution)) > 0
        compared += int(np.count_nonzero(keep))
        excluded_total += int(np.count_nonzero(excluded))
        occupied_total += int(np.count_nonzero(keep & occupied))
    return compared, excluded_total, occupied_total


def _walls(cells: int, origin: tuple[float, float], resolution: float) -> Any:
    centres = origin[0] + (np.arange(cells) + 0.5) * resolution
    x, y = np.meshgrid(centres, centres)
    return (np.abs(x) >= HALF) | (np.abs(y) >= HALF)


@pytest.mark.parametrize("fmt", ["ros1", "mcap", "sqlite3"])
def test_map_agrees_with_the_obstacle_footprints_cell_by_cell(tmp_path, fmt):
    path = _record(tmp_path, fmt, SEEDS)
    report = READERS[fmt](path)
    compared, excluded, occupied = check_maps(report, SEEDS, 0.05, 50_000_000)
    print(f"{fmt}: seeds {SEEDS}, 0.05 m: {compared} cells compared ({occupied} occupied), "
          f"{excluded} excluded, 0 mismatches")  # fmt: skip


@pytest.mark.parametrize("fmt", ["ros1", "mcap"])
def test_map_at_a_non_default_resolution(tmp_path, fmt):
    seeds = (3, 4)
    path = _record(tmp_path, fmt, seeds, map_resolution=0.08)
    report = READERS[fmt](path)
    assert expected_geometry(0.08) == (53, (-2.12, -2.12))  # 4.2 m / 0.08 m = 52.5 cells
    compared, excluded, occupied = check_maps(report, seeds, 0.08, 50_000_000)
    print(f"{fmt}: seeds {seeds}, 0.08 m: {compared} cells compared ({occupied} occupied), "
          f"{excluded} excluded, 0 mismatches")  # fmt: skip


def test_per_episode_bags_hold_one_map_each(tmp_path):
    env = gym.make("BubbleRob-v0", max_episode_steps=3, laser_num_rays=8)
    with RosBagRecorder(env, tmp_path / "eps", per_episode=True, start_time=START) as recorder:
        for seed in (0, 1):
            recorder.reset(seed=seed)
            for _ in range(3):
                recorder.step(np.zeros(2, dtype=np.float32))
    for path in recorder.bag_paths:
        report = read_with_rosbags(path)
        assert len(report["maps"]) == 1
        assert report["maps"][0]["log_ns"] == round(START * 1e9)  # every bag starts at START


def test_a_topic_set_without_map_writes_none(tmp_path):
    from bubblerob_env.ros.messages.topics import Topics

    env = gym.make("BubbleRob-v0", max_episode_steps=3, laser_num_rays=8)
    with RosBagRecorder(env, tmp_path / "nomap", topics=Topics(map=None)) as recorder:
        recorder.reset(seed=0)
        recorder.step(np.zeros(2, dtype=np.float32))
    report = read_with_rosbags(recorder.bag_paths[0])
    assert report["maps"] == []
    assert ["map", "odom"] in report["tf_static"]


@pytest.mark.parametrize(
    ("command", "value"),
    [("record", "0"), ("record", "-0.05"), ("record", "2"), ("record", "nan"),
     ("record", "abc"), ("node", "0.001"), ("node", "x")],
)  # fmt: skip
def test_bad_map_resolution_is_one_line(tmp_path, capsys, command, value):
    args = ["--policy", "reactive", "--out", str(tmp_path), "--no-progress"]
    if command == "node":
        args = ["--master-timeout", "0.1"]  # the value is checked before ROS starts
    result = run([command, *args, "--map-resolution", value], capsys)  # in process: cli_usage
    assert result.code == 2, result.err
    assert "Traceback" not in result.err
    assert len(result.lines) == 1, result.err
    line = result.lines[0]
    assert value in line and "0.005" in line and "1" in line, line
    assert not list(tmp_path.iterdir())  # no bag left behind


@pytest.mark.parametrize("distro", ["noetic", "humble", "jazzy"])
def test_map_packer_bytes_equal_rosbags_serialisation(distro):
    from bubblerob_env.mapping import episode_grid
    from bubblerob_env.ros.fastpath.serializer import FrameSerializer
    from bubblerob_env.ros.messages.distros import serialize
    from bubblerob_env.ros.messages.topics import Topics
    from bubblerob_env.specs import EnvSpecs

    env = gym.make("BubbleRob-v0", laser_num_rays=8)
    env.reset(seed=2)
    serializer = FrameSerializer(EnvSpecs.from_env(env), distro, Topics(namespace="r3"))
    for resolution in (0.05, 0.07):
        grid = episode_grid(env, resolution)
        stamp = 1_700_000_123_456_789_012
        ((topic, log_ns, data),) = serializer.map(grid, stamp)
        values = {"sec": stamp // 10**9, "nanosec": stamp % 10**9, "seq": 0}
        message = serializer.converter.occupancy_grid(
            {**values, "cells": grid.data.tobytes()}, grid.data.shape, grid.origin, resolution
        )
        assert message.header.frame_id == "r3/map"
        assert (topic, log_ns) == ("/r3/map", stamp)
        assert data == serialize(distro, message, "nav_msgs/msg/OccupancyGrid")
    env.close()


def test_record_cli_takes_a_map_resolution(tmp_path, capsys):
    result = run(
        ["record", "--policy", "reactive", "--max-steps", "3", "--format", "ros1",
         "--out", str(tmp_path), "--no-progress", "--map-resolution", "0.1"],
        capsys,
    )  # fmt: skip
    assert result.code == 0, result.err
    report = read_with_rosbags(tmp_path / "bubblerob_reactive_seed0.bag")
    ((message,),) = [report["maps"]]
    assert (message["width"], message["height"]) == (42, 42)
    assert message["resolution"] == pytest.approx(0.1)
