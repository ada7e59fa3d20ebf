"""Sync mode: the tutorial's rosBubbleRob2 loop, ``rosbag record`` vs the recorder, triggers."""

from __future__ import annotations

import signal
import subprocess
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from live_helpers import requires_ros, stop, wait_for
from rosbags.highlevel import AnyReader

from bubblerob_env.ros import RosBagRecorder

pytestmark = requires_ros

# The first seed from 0 whose default arena rosBubbleRob2 drives for 600 steps (30 s) without
# touching anything, found by running its loop on the env offline (seed 0 was, before resets
# started at rest, issue #41; since then it touches twice, as the loop is only reactive).
SEED = 6
STEPS = 600
DT_NS = 50_000_000
NODE_TOPICS = [
    "/scan", "/proximity", "/sensorTrigger", "/odom", "/tf", "/tf_static", "/clock",
    "/simulationTime", "/reward", "/terminated", "/truncated", "/bubblerob/action",
    "/bubblerob/episode",
]  # fmt: skip


@pytest.fixture(scope="module")
def tutorial_node(start_node):
    """The tutorial scene, stopped, in sync mode: the recording starts with the first frame."""
    return start_node("--sync", "--start", "stopped", "--seed", str(SEED))


def read_bag(path: Path) -> dict[str, list[Any]]:
    messages: dict[str, list[Any]] = {}
    with AnyReader([path]) as reader:
        for connection, _, raw in reader.messages():
            msg = reader.deserialize(raw, connection.msgtype)
            messages.setdefault(connection.topic, []).append(msg)
    return messages


def same(a: Any, b: Any, where: str) -> None:
    if hasattr(a, "__dataclass_fields__"):
        for name in a.__dataclass_fields__:
            same(getattr(a, name), getattr(b, name), f"{where}.{name}")
    elif isinstance(a, np.ndarray):
        assert np.array_equal(a, b), where
    elif isinstance(a, list):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            same(x, y, f"{where}[{i}]")
    else:
        assert a == b, f"{where}: {a!r} != {b!r}"


def test_tutorial_loop_drives_30_s_and_rosbag_record_matches_the_recorder(
    master, tutorial_node, tmp_path
):
    bag = tmp_path / "live.bag"
    recorder = master.popen(
        ["/usr/bin/rosbag", "record", "--tcpnodelay", "-O", str(bag), *NODE_TOPICS],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    try:
        result = master.client(
            "tutorialloop", "--steps", str(STEPS), "--wait-recorder", timeout=150
        )
    finally:
        stop(recorder, signal.SIGINT, timeout=20)
        # rosbag's wrapper exits at once; its `record` child renames .bag.active when done
        wait_for(lambda: bag.exists() and not Path(f"{bag}.active").exists(), 20.0)
    assert result["steps"] == STEPS and result["collisions"] == 0, result
    assert result["triggers"] > 5  # it did have to back away from things
    live = read_bag(bag)
    actions = np.array([m.data for m in live["/bubblerob/action"]], dtype=np.float32)
    assert len(actions) == STEPS
    used = {tuple(a) for a in np.round(actions.astype(np.float64), 6).tolist()}
    assert used == {(0.8, 0.8), (-0.5, -0.25)}

    # The node's time starts at its wall-clock start, as a recorder's does.
    first = live["/clock"][0].clock
    assert abs(first.sec - time.time()) < 600
    start = f"{first.sec}.{first.nanosec:09d}"
    # What `bubblerob record` writes for the same seed, actions and start (its API, ROS 1 format).
    env = gym.make("BubbleRob-v0")
    with RosBagRecorder(env, tmp_path / "recorded", format="ros1", start_time=start) as rec:
        rec.reset(seed=SEED)
        for action in actions:
            rec.step(action)
    recorded = read_bag(tmp_path / "recorded.bag")
    assert set(live) == set(NODE_TOPICS)
    for topic in NODE_TOPICS:
        assert len(live[topic]) == len(recorded[topic]), topic
        if topic == "/bubblerob/episode":
            continue  # its JSON says how it was made (live or bag)
        for i, (a, b) in enumerate(zip(live[topic], recorded[topic], strict=True)):
            same(a, b, f"{topic}[{i}]")


@pytest.fixture(scope="module")
def robot2(start_node, tutorial_node):
    """A second robot in its own namespace, in sync mode, running."""
    return start_node(
        "--namespace", "robot2", "--sync", "--env-kwargs", '{"num_obstacles": [0, 0]}'
    )


def test_n_triggers_advance_exactly_n_steps(master, robot2):
    result = master.client("--ns", "/robot2", "sync", "--n", "25", "--settle", "0.5")
    assert result["done"] == 25
    assert result["t1"] - result["t0"] == 25 * DT_NS
    assert result["clocks"] == 25  # and nothing more while nobody triggers


def test_two_robots_in_namespaces(master, tutorial_node, robot2):
    assert tutorial_node.alive(), tutorial_node.output
    topics = master.run(["/usr/bin/rostopic", "list"]).stdout.split()
    for name in ("scan", "odom", "simulationState", "triggerNextStep", "cmd_vel"):
        assert f"/{name}" in topics and f"/robot2/{name}" in topics, name


def test_enable_sync_mode_toggles_free_running(master, robot2):
    master.client("pub", "/robot2/enableSyncMode", "bool", "false")
    assert master.client("count", "/robot2/odom", "--seconds", "1.0")["/robot2/odom"] >= 10
    master.client("pub", "/robot2/enableSyncMode", "bool", "true")
    assert wait_for(
        lambda: master.client("count", "/robot2/odom", "--seconds", "0.5")["/robot2/odom"] == 0,
        10.0,
    )
