"""``record --robots``: one bag with every robot (their own names and frames), replayed exactly."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from rosbags.highlevel import AnyReader

import bubblerob_env
from bubblerob_env.ros.messages.robots import robot_topics
from bubblerob_env.ros.messages.topics import Topics
from bubblerob_env.ros.world_record import record_world, replay_world, world_robots

START = 1_700_000_000 * 10**9
STEPS = 25


def spin_driver(agent: str, obs, start: bool):
    """robot_1 turns on the spot, robot_0 creeps forward."""
    return np.array([-0.5, 0.5] if agent.endswith("_1") else [0.2, 0.2], dtype=np.float32)


def read(path) -> dict[str, list]:
    out: dict[str, list] = {}
    with AnyReader([path]) as reader:
        for connection, _, raw in reader.messages():
            out.setdefault(connection.topic, []).append(reader.deserialize(raw, connection.msgtype))
        connections = [c.topic for c in reader.connections]
    out["connections"] = connections
    return out


@pytest.mark.parametrize("fmt", ["ros1", "mcap"])
def test_one_bag_holds_every_robot_and_replays_exactly(tmp_path, fmt):
    env = bubblerob_env.parallel_env(num_robots=2, max_episode_steps=STEPS)
    topics = [robot_topics(Topics(), k) for k in range(2)]
    path, steps = record_world(
        tmp_path / "world", env, topics, spin_driver, [3, 4], START, 0.1, fmt=fmt
    )
    env.close()
    assert steps == 2 * STEPS  # nothing collides: each episode runs to the time limit
    bag = read(path)
    assert bag["connections"].count("/tf") == 1 and bag["connections"].count("/tf_static") == 1
    assert len(bag["/robot_0/scan"]) == len(bag["/robot_1/scan"]) == 2 * (STEPS + 1)
    clock = [m.clock.sec * 10**9 + m.clock.nanosec for m in bag["/clock"]]
    scans = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in bag["/robot_1/scan"]]
    assert clock == scans and clock[0] == START  # one world clock, a tick per frame
    odom = bag["/robot_1/odom"]
    assert {(m.header.frame_id, m.child_frame_id) for m in odom} == {
        ("robot_1/odom", "robot_1/base_link")
    }
    # An independent oracle: the world stepped directly with the same actions.
    direct = bubblerob_env.parallel_env(num_robots=2, max_episode_steps=STEPS)
    _, infos = direct.reset(seed=3)
    poses = []
    for _ in range(STEPS):
        actions = {a: spin_driver(a, None, False) for a in direct.agents}
        _, _, _, _, infos = direct.step(actions)
        poses.append((infos["bubblerob_1"]["odom_x"], infos["bubblerob_1"]["odom_y"]))
    direct.close()
    recorded = [(m.pose.pose.position.x, m.pose.pose.position.y) for m in odom[1 : STEPS + 1]]
    assert np.allclose(recorded, poses, atol=1e-12)
    assert world_robots(path) == ["bubblerob_0", "bubblerob_1"]
    assert replay_world(path) is None


def test_record_cli_robots_then_replay_and_info(tmp_path):
    def run(*args: str) -> subprocess.CompletedProcess[str]:
        command = [sys.executable, "-m", "bubblerob_cli", *args]
        return subprocess.run(command, capture_output=True, text=True, timeout=120, check=False)

    made = run(
        "record", "--robots", "2", "--policy", "reactive", "--format", "ros1", "--max-steps",
        "20", "--episodes", "2", "--out", str(tmp_path), "--no-progress",
    )  # fmt: skip
    assert made.returncode == 0, made.stderr
    (bag,) = tmp_path.glob("*.bag")
    replayed = run("replay", str(bag))
    assert replayed.returncode == 0, replayed.stdout + replayed.stderr
    assert "identical" in replayed.stdout
    one = run("replay", str(bag), "--robot", "robot_1")
    assert one.returncode == 0 and "every message of robot_1" in one.stdout, one.stdout + one.stderr
    info = run("info", str(bag), "--robot", "robot_1")
    assert info.returncode == 0, info.stderr
    assert "/robot_1/scan" in info.stdout and "/robot_0/scan" not in info.stdout
    wrong = run("info", str(bag), "--robot", "robot_7")
    assert wrong.returncode == 2 and "robot_7" in wrong.stderr and "robot_1" in wrong.stderr
    mapped = run("map", str(bag), "--robot", "robot_1", "--out", str(tmp_path / "m.png"))
    assert mapped.returncode == 0, mapped.stderr
    assert "/map" in mapped.stdout  # the recorded ground truth (robot_1's /robot_1/map)
    located = run(
        "localize", str(bag), "--robot", "bubblerob_0", "--json", "--out", str(tmp_path / "l.png")
    )
    assert located.returncode == 0, located.stderr
    scores = json.loads(located.stdout)
    # tracking robot_0's scans on robot_0's poses (another robot's frames would be metres off)
    assert scores["episodes"] == 2 and scores["position_error_mean_m"] < 0.05
    mixed = run("map", str(bag), "--out", str(tmp_path / "m2.png"))
    assert mixed.returncode == 2 and "choose one with --robot" in mixed.stderr


def test_replay_finds_a_changed_action(tmp_path, monkeypatch):
    import bubblerob_env.ros.world_record as world_record

    env = bubblerob_env.parallel_env(num_robots=2, max_episode_steps=10)
    topics = [robot_topics(Topics(), k) for k in range(2)]
    path, _ = record_world(tmp_path / "w", env, topics, spin_driver, [1], START, 0.1, fmt="ros1")
    env.close()
    recorded = world_record._actions

    def nudged(*args):
        actions = recorded(*args)
        actions["bubblerob_1"][4] = actions["bubblerob_1"][4] + np.float32(0.25)
        return actions

    monkeypatch.setattr(world_record, "_actions", nudged)
    difference = replay_world(path)
    # the earliest difference: robot_1's fifth action (stamped with the frame it was sent at)
    assert difference is not None and difference.startswith("/robot_1/bubblerob/action message 4")
