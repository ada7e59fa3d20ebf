"""``crowd_navigator``: a laser window read as a whole robot; other robots passed on the right."""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("pettingzoo")
from nav_support import assert_action_ignores_the_state  # noqa: E402

import bubblerob_env  # noqa: E402, F401
from policies import load_policy  # noqa: E402
from policies.multi_evaluation import run_world_episode, world_env  # noqa: E402

FAST: dict[str, Any] = {"num_obstacles": (0, 0)}


def test_a_narrow_return_becomes_a_robots_disc_and_walls_stay_as_they_are() -> None:
    policy: Any = load_policy("crowd_navigator", gym.make("BubbleRobNav-v0"))
    angles = -math.pi + 2 * math.pi / 360 * np.arange(360)
    scan = np.full(360, 3.0, dtype=np.float32)  # a wall all round, 3 m away
    scan[179:182] = 1.0  # a window 1 m straight ahead (rays -1, 0, +1 degree)
    narrow = policy.seen_robots(scan)
    assert np.flatnonzero(narrow).tolist() == [179, 180, 181]
    cut = policy.with_bodies(scan, narrow)
    # The oracle: the ray straight ahead meets the disc of radius 0.11 + 0.09 m whose centre is
    # the window's, 1 + 0.025 m ahead; a ray 30 degrees off misses it and keeps the wall.
    assert cut[180] == pytest.approx(1.025 - 0.2, abs=1e-5)
    half = math.asin(0.2 / 1.025)  # the disc's half-angle seen from the robot
    missed = np.abs(angles) > half + 0.02
    np.testing.assert_array_equal(cut[missed], scan[missed])
    assert (cut[np.abs(angles) < half - 0.02] < 1.0).all()
    wide = np.full(360, 3.0, dtype=np.float32)
    wide[150:211] = 1.0  # an obstacle 60 degrees wide is no robot
    assert not policy.seen_robots(wide).any()


def test_four_robots_cross_the_circle_where_the_navigator_meets_in_the_middle() -> None:
    outcomes = {}
    for name in ("navigator", "crowd_navigator"):
        world = world_env(4, "circle", "BubbleRobNav-v0", FAST, circle_jitter=0.1)
        policy = load_policy(name, gym.make("BubbleRobNav-v0", **FAST))
        try:
            records = run_world_episode(world, policy, seed=1000, max_speed=0.4)  # validation
        finally:
            world.close()
        outcomes[name] = [(r["succeeded"], r["collided_with"]) for r in records]
    assert all(success for success, _ in outcomes["crowd_navigator"])
    assert any(touched.startswith("bubblerob_") for _, touched in outcomes["navigator"])


def test_crowd_navigator_observed_reads_its_memory_from_the_observation() -> None:
    """The crowd recipe's teacher: ``crowd_navigator`` whose side memory is the observation's."""
    policy: Any = load_policy("crowd_navigator_observed", gym.make("BubbleRobNav-v0", **FAST))
    assert policy.observed_memory and policy.name == "crowd_navigator_observed"
    carried: Any = load_policy("crowd_navigator", gym.make("BubbleRobNav-v0", **FAST))
    margin, carried_margin = (p.gap.half_width - 0.11 for p in (policy, carried))  # radius 0.11
    assert margin == pytest.approx(1.5 * carried_margin)  # room for a student's errors
    world = world_env(4, "circle", "BubbleRobNav-v0", FAST, circle_jitter=0.1)
    try:
        records = run_world_episode(world, policy, seed=1001, max_speed=0.4)  # validation
    finally:
        world.close()
    assert all(r["succeeded"] for r in records), records
    assert_action_ignores_the_state(gym.make("BubbleRobNav-v0", **FAST), policy)
