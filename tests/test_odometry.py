"""Wheel odometry (issue #27): drift from the truth, the noise's draws, dead reckoning's math."""

from __future__ import annotations

import math
import pickle

import gymnasium as gym
import numpy as np
import pytest

import bubblerob_env  # noqa: F401  (registers BubbleRob-v0)
from bubblerob_env.kinematics import DiffDrive
from bubblerob_env.odometry import Odometry

DRIVE = DiffDrive(wheel_radius=0.04, wheel_separation=0.18, max_wheel_speed=10.0)


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


def test_a_straight_line_and_a_circle_match_closed_forms():
    odometry = Odometry(2, DRIVE, 0.05, 0.0)
    odometry.reset(0, 0.0, 0.0, 0.0)
    odometry.reset(1, 1.0, 0.0, math.pi / 2)
    rows = np.array([0, 1])
    # Row 0: both wheels at 5 rad/s; row 1: a circle (right faster), the same speeds every step.
    speeds = np.array([[5.0, 5.0], [2.0, 6.0]])
    steps = 200
    for _ in range(steps):
        odometry.advance(rows, speeds)
    first = 0.05 * 0.04 * 5.0 * (steps - 0.5)  # the first step averages with rest
    assert odometry.poses[0] == pytest.approx([first, 0.0, 0.0], abs=1e-12)
    # Constant wheel speeds after the first step: an arc of radius v / w about a fixed centre.
    v, w = 0.04 * 4.0, 0.04 * 4.0 / 0.18
    x0, y0, yaw0 = 1.0, 0.0, math.pi / 2
    centre = (x0 - v / w * math.sin(yaw0), y0 + v / w * math.cos(yaw0))
    x, y, yaw = odometry.poses[1]
    assert math.hypot(x - centre[0], y - centre[1]) == pytest.approx(v / w, rel=1e-3)
    turned = w * 0.05 * (steps - 0.5)
    assert math.remainder(yaw - (yaw0 + turned), 2 * math.pi) == pytest.approx(0.0, abs=1e-9)


def test_no_noise_draws_nothing_and_keeps_episodes_bit_for_bit():
    plain = gym.make("BubbleRob-v0")
    explicit = gym.make("BubbleRob-v0", odometry_noise=0.0)
    for a, b in zip(_drive(plain, 60, 3), _drive(explicit, 60, 3), strict=True):
        assert a["x"] == b["x"] and a["odom_x"] == b["odom_x"]
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

    assert max(map(error, noisy)) > max(map(error, quiet))
    assert max(map(error, noisy)) > 0.05


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
