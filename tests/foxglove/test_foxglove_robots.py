"""``bubblerob node --robots 2 --foxglove``, seen through Foxglove's own client (``client.mjs``).

The command runs as users run it, on a port the OS picks (read from its "ready" line). Oracles:
the channel list itself, the robots' frames named in the test, and the poses the client decodes
with ``rosbags`` (an independent decoder): only the robot whose ``cmd_vel`` is driven moves (a
JSON twist, as the Teleop panel sends, and a CDR one).
"""

from __future__ import annotations

import base64
import math
import re
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from conftest import NODE_MISSING, received, rosbags_store, run_client

READY = re.compile(r"Foxglove at (ws://\S+) .*2 robots.*; ready")


@pytest.fixture
def world_url() -> Iterator[str]:
    """The URL of ``bubblerob node --robots 2 --foxglove --port 0`` (stopped after the test)."""
    if NODE_MISSING:
        pytest.skip(NODE_MISSING)
    command = [
        str(Path(sys.executable).with_name("bubblerob")),
        *("node", "--robots", "2", "--foxglove", "--port", "0"),
        *("--seed", "3", "--rate-factor", "4", "--duration", "60"),
    ]
    proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None and proc.stderr is not None
        line = proc.stdout.readline()
        ready = READY.search(line)
        assert ready, f"no ready line: {line!r} {proc.stderr.read() if proc.poll() else ''}"
        yield ready.group(1)
    finally:
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=20)
    assert proc.returncode == 0, f"exit {proc.returncode}: {out[-1000:]} {err[-1000:]}"


def _pose(odom: Any) -> tuple[float, float, float]:
    p, q = odom.pose.pose.position, odom.pose.pose.orientation
    return p.x, p.y, math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y**2 + q.z**2))


def test_each_robot_has_its_namespace_one_clock_and_its_own_cmd_vel(world_url: str) -> None:
    twist = {"linear": {"x": 0.2, "y": 0, "z": 0}, "angular": {"x": 0, "y": 0, "z": 0}}
    drive = {"op": "publish", "topic": "/robot_1/cmd_vel", "json": twist}
    store = rosbags_store()
    vector = store.types["geometry_msgs/msg/Vector3"]
    turn = store.types["geometry_msgs/msg/Twist"](linear=vector(0, 0, 0), angular=vector(0, 0, 1))
    turn_cdr = bytes(store.serialize_cdr(turn, "geometry_msgs/msg/Twist"))
    spin = {
        "op": "publish",
        "topic": "/robot_0/cmd_vel",
        "base64": base64.b64encode(turn_cdr).decode(),
    }
    odoms = ["/robot_0/odom", "/robot_1/odom"]
    report = run_client(
        world_url,
        [
            {"op": "subscribe", "topics": [*odoms, "/tf_static"]},
            *({"op": "waitFor", "topic": t, "count": 2} for t in odoms),
            {"op": "waitFor", "topic": "/tf_static", "count": 1},
            # What Foxglove's Teleop panel sends: JSON, its schema named ROS 1 style.
            {"op": "advertise", "topic": "/robot_1/cmd_vel", "encoding": "json",
             "schemaName": "geometry_msgs/Twist"},
            {"op": "mark"},
            *(s for _ in range(10) for s in (drive, {"op": "sleep", "ms": 50})),
            {"op": "sleep", "ms": 100}, {"op": "mark"},
            # A CDR twist (1 rad/s) on robot_0's cmd_vel turns robot_0 alone.
            {"op": "advertise", "topic": "/robot_0/cmd_vel", "encoding": "cdr",
             "schemaName": "geometry_msgs/msg/Twist"},
            *(s for _ in range(10) for s in (spin, {"op": "sleep", "ms": 50})),
            {"op": "sleep", "ms": 100}, {"op": "mark"},
            {"op": "call", "service": "/reset_simulation", "encoding": "cdr",
             "base64": base64.b64encode(bytes([0, 1, 0, 0, 0])).decode()},
        ],
    )  # fmt: skip
    topics = [channel["topic"] for channel in report["channels"]]
    assert {"/robot_0/scan", "/robot_1/scan", "/robot_0/bubblerob/robot_model"} <= set(topics)
    assert [t for t in topics if t.endswith("clock")] == ["/clock"]
    assert len(topics) == len(set(topics))

    # The latched /tf_static, sent again to this late subscriber, holds both robots' frames.
    *_, (_, static) = received(report, "/tf_static", "tf2_msgs/msg/TFMessage")
    parents = {t.child_frame_id.split("/")[0] for t in static.transforms}
    assert {"robot_0", "robot_1"} <= parents

    # Half a second of 0.2 m/s at rate factor 4 (2 simulated s): robot_1 moves, robot_0 does not;
    # then half a second of 1 rad/s: robot_0 turns, robot_1 (driven straight) does not.
    start, driven, turned = report["marks"]
    for topic, moves, turns in (("/robot_0/odom", False, True), ("/robot_1/odom", True, False)):
        index = [i for i, m in enumerate(report["messages"]) if m["topic"] == topic]
        poses = received(report, topic, "nav_msgs/msg/Odometry")
        timeline = list(zip(index, (_pose(odom) for _, odom in poses), strict=True))
        before, after, end = (
            next(pose for i, pose in reversed(timeline) if i < mark)
            for mark in (start, driven, turned)
        )
        assert (math.dist(before[:2], after[:2]) > 0.1) == moves, (topic, before, after)
        assert (abs(math.remainder(end[2] - after[2], math.tau)) > 0.5) == turns, (topic, end)

    # The services act on the world.
    (answer,) = report["responses"]
    assert base64.b64decode(answer["data"])[12:-1] == b"episode 2 queued"
