"""``/map`` on a live ROS 2 graph: a transient-local subscriber that joins late still gets it, and
``/tf_static`` holds ``map -> odom``. Real rclpy processes (``.venv-ros2``), DDS kept on the
loopback in this session's own domain (``ros2_helpers.ros2_env``).
"""

from __future__ import annotations

import time

import gymnasium as gym
import numpy as np
import pytest
from ros2_helpers import client

import bubblerob_env  # noqa: F401 - registers BubbleRob-v0
from bubblerob_env.mapping import episode_grid


def test_a_late_transient_local_subscriber_gets_the_map(start_node):
    node = start_node("--seed", "5", "--map-resolution", "0.1", "--watchdog", "0")
    time.sleep(2.0)  # join late: the map was published at the node's first reset
    got = client("map")
    assert node.alive(), node.output
    first = got["first"]
    assert first["frame_id"] == "map"
    assert (first["width"], first["height"], first["resolution"]) == (42, 42, pytest.approx(0.1))
    assert first["origin"] == pytest.approx([-2.1, -2.1, 1.0])
    env = gym.make("BubbleRob-v0")
    env.reset(seed=5)
    expected = episode_grid(env, 0.1).data
    env.close()
    assert np.array_equal(np.array(first["data"], dtype=np.int8).reshape(42, 42), expected)
    assert ["map", "odom"] in got["tf_static"]
    assert got["qos"] == [["RELIABLE", "TRANSIENT_LOCAL"]]
