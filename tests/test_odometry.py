"""Wheel odometry (issue #27): drift from the truth, the noise's draws, dead reckoning's math."""

from __future__ import annotations

import math
import pickle

import gymnasium as gym
import numpy as np
import pytest

import bubblerob_env  # noqa: F401  (registers BubbleRob-v0)
from bubblerob_env.odometry import TRUTH_COLUMNS, Odometry

SEPARATION = 0.18


def _drive(env: gym.Env, steps: int, seed: int) -> list[dict]:
    actions = np.random.default_rng(seed).uniform(0.2, 1.0, size=(steps, 2)).astype(np.float32)
    _, info = env.reset(seed=seed)
    infos = [info]
    for action in actions:
        *_, terminated, truncated, info = env.step(action)
        infos.append(info)
        if terminated or truncated:
            break
    return infos


def _results(poses: np.ndarray) -> np.ndarray:
    """Kernel result rows holding ``poses`` (x, y, yaw) where the odometry reads the truth."""
    results = np.zeros((len(poses), 28))
    results[:, TRUTH_COLUMNS] = poses
    return results


def test_without_slip_dead_reckoning_follows_an_arc_exactly():
    # A circle of radius 0.5 m about (1, 2), driven forwards counter-clockwise, and a line driven
    # backwards: the chord of each step leaves at the midpoint heading, so no error builds up.
    angles = np.linspace(0.0, 5.0, 101)
    circle = np.column_stack(
        [1 + 0.5 * np.sin(angles), 2 - 0.5 * np.cos(angles), np.remainder(angles, 2 * np.pi)]
    )
    line = np.column_stack([np.linspace(0, -1, 101), np.zeros(101), np.full(101, 0.3)])
    line[:, 1] = line[:, 0] * np.tan(0.3)
    for path in (circle, line):
        odometry = Odometry(1, SEPARATION, 0.1)
        odometry.reset(0, _results(path[:1])[0])
        for pose in path[1:]:
            odometry.advance(np.array([0]), _results(pose[None]), np.zeros((1, 2)))
        np.testing.assert_allclose(odometry.poses[0, :2], path[-1, :2], atol=1e-9)
        assert math.remainder(odometry.poses[0, 2] - path[-1, 2], 2 * math.pi) == pytest.approx(
            0.0, abs=1e-9
        )


def test_slip_scales_each_wheels_travel():
    # 2 cm straight ahead; the left wheel reports 10% more, the right 10% less.
    odometry = Odometry(1, SEPARATION, 0.1)
    odometry.reset(0, _results(np.zeros((1, 3)))[0])
    odometry.advance(np.array([0]), _results(np.array([[0.02, 0.0, 0.0]])), np.array([[0.1, -0.1]]))
    turn = (0.018 - 0.022) / SEPARATION
    expected = [0.02 * math.cos(turn / 2), 0.02 * math.sin(turn / 2), turn]
    np.testing.assert_allclose(odometry.poses[0], expected, atol=1e-15)


def test_no_noise_is_the_truth_and_draws_nothing():
    plain = gym.make("BubbleRob-v0")
    explicit = gym.make("BubbleRob-v0", odometry_noise=0.0)
    for a, b in zip(_drive(plain, 60, 3), _drive(explicit, 60, 3), strict=True):
        assert a["x"] == b["x"] and a["odom_x"] == b["odom_x"]
        assert (a["odom_x"], a["odom_y"], a["odom_yaw"]) == (a["x"], a["y"], a["yaw"])
    # The generator is where a plain env leaves it: nothing was drawn from it.
    fresh = gym.make("BubbleRob-v0")
    fresh.reset(seed=3)
    state = plain.unwrapped.np_random.bit_generator.state
    assert state == fresh.unwrapped.np_random.bit_generator.state


def test_odometry_starts_at_the_truth_and_drifts_with_noise():
    quiet = _drive(gym.make("BubbleRob-v0"), 400, 5)
    noisy = _drive(gym.make("BubbleRob-v0", odometry_noise=0.1), 400, 5)
    for infos in (quiet, noisy):
        first = infos[0]
        assert (first["odom_x"], first["odom_y"]) == (first["x"], first["y"])
    # Odometry noise changes only the odometry: the robot drives the same path.
    assert [i["x"] for i in quiet] == [i["x"] for i in noisy]

    def error(info: dict) -> float:
        return math.hypot(info["odom_x"] - info["x"], info["odom_y"] - info["y"])

    assert max(map(error, quiet)) == 0.0
    assert len(noisy) > 50 and max(map(error, noisy)) > 0.01


def test_an_unpickled_env_keeps_its_odometry():
    env = gym.make("BubbleRob-v0", odometry_noise=0.05)
    _drive(env, 30, 2)
    copy = pickle.loads(pickle.dumps(env))
    action = np.array([0.5, 0.8], dtype=np.float32)
    for _ in range(5):
        *_, info = env.step(action)
        *_, copied = copy.step(action)
        assert (info["odom_x"], info["odom_yaw"]) == (copied["odom_x"], copied["odom_yaw"])


@pytest.mark.parametrize("bad", [-0.1, math.nan, math.inf, "0.1", 2.0])
def test_bad_odometry_noise_is_one_clear_error(bad):
    with pytest.raises(ValueError, match="odometry_noise must be a finite number from 0 to 1"):
        gym.make("BubbleRob-v0", odometry_noise=bad)
