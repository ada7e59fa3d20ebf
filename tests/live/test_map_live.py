"""``/map`` on a live ROS 1 graph: latched (a subscriber that connects late gets it), republished
at every reset, with ``map -> odom`` on ``/tf_static``.

The map's cells are compared with :func:`~bubblerob_env.mapping.episode_grid` of the same seed:
this checks the transport (``tests/ros/test_map.py`` checks the grid against the geometry).
"""

from __future__ import annotations

import time

import gymnasium as gym
import numpy as np
import pytest
from live_helpers import requires_ros

import bubblerob_env  # noqa: F401 - registers BubbleRob-v0
from bubblerob_env.mapping import episode_grid

pytestmark = requires_ros


def _grid(seed: int, resolution: float) -> np.ndarray:
    env = gym.make("BubbleRob-v0")
    env.reset(seed=seed)
    grid = episode_grid(env, resolution)
    env.close()
    return grid.data


def test_a_late_subscriber_gets_the_latched_map_and_map_to_odom(master, start_node):
    node = start_node("--seed", "7", "--map-resolution", "0.1", "--watchdog", "0")
    time.sleep(2.0)  # the subscriber connects well after the node published /map
    got = master.client("map")
    assert node.alive(), node.output
    first = got["first"]
    assert got["latching"] == "1"
    assert first["frame_id"] == "map"
    assert (first["width"], first["height"]) == (42, 42)
    assert first["resolution"] == pytest.approx(0.1)
    assert first["origin"] == pytest.approx([-2.1, -2.1, 1.0])
    expected = _grid(7, 0.1)
    assert np.array_equal(np.array(first["data"], dtype=np.int8).reshape(42, 42), expected)
    assert ["map", "odom"] in got["tf_static"]
    assert ["base_link", "laser_link"] in got["tf_static"]


def test_the_map_is_published_again_at_every_reset(master, start_node):
    # Episodes of 10 steps at 4x real time: a new arena every 0.14 s.
    node = start_node("--seed", "0", "--rate-factor", "4", "--max-steps", "10", "--namespace", "r2")
    got = master.client("--ns", "/r2", "map", "--seconds", "2.0")
    assert node.alive(), node.output
    assert got["first"]["frame_id"] == "r2/map"
    assert ["r2/map", "r2/odom"] in got["tf_static"]
    stamps = got["stamps"]
    assert len(stamps) >= 4, got["stamps"]
    assert stamps == sorted(stamps) and len(set(stamps)) == len(stamps)
    assert got["distinct"] >= 3  # new seeds, new arenas
