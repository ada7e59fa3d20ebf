"""Any RL loop live in Foxglove: FoxglovePublisher, evaluate --foxglove and demo --foxglove."""

from __future__ import annotations

import re
import subprocess
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
from conftest import DT_NS, START_NS, finish_client, received, start_client

from bubblerob_cli.demo import run_demo
from bubblerob_env.ros.live.foxglove_publisher import FoxglovePublisher

STEPS = 60


def test_a_loop_is_published_with_its_own_readings_and_stamps() -> None:
    env = FoxglovePublisher(gym.make("BubbleRob-v0"), port=0, start_time=START_NS / 1e9)
    obs, _ = env.reset(seed=7)
    readings = {0: obs["laser"]}
    client = start_client(
        env.url,
        [
            {"op": "subscribe", "topics": ["/scan"]},
            {"op": "waitFor", "topic": "/scan", "count": 20},
        ],
    )
    deadline = time.monotonic() + 10
    while env.backend.subscribers("/scan") == 0:  # type: ignore[attr-defined]
        assert time.monotonic() < deadline, "the client did not subscribe within 10 s"
        time.sleep(0.01)
    for step in range(1, STEPS + 1):
        obs, *_ = env.step(np.array([0.3, 0.1], dtype=np.float32))
        readings[step] = obs["laser"]
        time.sleep(0.005)
    report = finish_client(client)
    env.close()
    scans = received(report, "/scan", "sensor_msgs/msg/LaserScan")
    assert len(scans) >= 20
    for log_time, scan in scans:
        step, rest = divmod(log_time - START_NS, DT_NS)
        assert rest == 0 and scan.header.stamp.sec * 10**9 + scan.header.stamp.nanosec == log_time
        laser = readings[step].astype(np.float32)
        laser[laser >= scan.range_max] = np.inf
        laser[laser < scan.range_min] = -np.inf
        np.testing.assert_array_equal(scan.ranges, laser)


def test_a_budget_publishes_whole_episodes_within_it() -> None:
    env = FoxglovePublisher(gym.make("BubbleRob-v0", max_episode_steps=10), port=0, budget=0.05)
    began = time.perf_counter()
    costs = []
    for episode in range(60):
        spent = env.overhead
        env.reset(seed=episode)
        for _ in range(10):
            env.step(np.zeros(2, dtype=np.float32))
        costs.append(env.overhead - spent)
    elapsed = time.perf_counter() - began
    env.close()
    assert env.published_episodes + env.skipped_episodes == 60
    assert 1 <= env.published_episodes < 60 and env.skipped_episodes > 0
    # Never more than the budget, but for the one episode that was started within it.
    assert env.overhead <= 0.05 * elapsed + max(costs)


def test_watched_only_publishes_nothing_until_a_client_subscribes() -> None:
    env = FoxglovePublisher(
        gym.make("BubbleRob-v0", max_episode_steps=10), port=0, budget=0.5, watched_only=True
    )
    still = np.zeros(2, dtype=np.float32)
    env.reset(seed=0)
    for _ in range(10):
        env.step(still)
    assert (env.published_episodes, env.skipped_episodes, env.overhead) == (0, 1, 0.0)
    client = start_client(
        env.url,
        [
            {"op": "subscribe", "topics": ["/scan"]},
            {"op": "waitFor", "topic": "/scan", "count": 11},
        ],
    )
    deadline = time.monotonic() + 10
    while env.backend.subscribers("/scan") == 0:  # type: ignore[attr-defined]
        assert time.monotonic() < deadline, "the client did not subscribe within 10 s"
        time.sleep(0.01)
    env.reset(seed=1)  # the next episode is published whole: its reset's scan and 10 steps'
    for _ in range(10):
        env.step(still)
        time.sleep(0.005)
    report = finish_client(client)
    env.close()
    assert (env.published_episodes, env.skipped_episodes) == (1, 1)
    assert len(received(report, "/scan", "sensor_msgs/msg/LaserScan")) == 11


def test_evaluate_and_demo_serve_their_episodes(tmp_path: Path) -> None:
    evaluate = subprocess.run(
        [sys.executable, "-m", "bubblerob_cli", "evaluate", "--policy", "reactive",
         "--episodes", "1", "--foxglove", "0"],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert evaluate.returncode == 0, evaluate.stderr
    assert re.match(
        r"bubblerob evaluate: Foxglove at ws://127\.0\.0\.1:\d+ \(subprotocol foxglove\.sdk\.v1\)\n"
        r"policy ",
        evaluate.stdout,
    ), evaluate.stdout
    demo = run_demo("reactive", 1, out=tmp_path, video=False, progress=False,
                    foxglove=("127.0.0.1", 0))  # fmt: skip
    assert demo.bag.exists() and demo.result.episodes == 1
