"""``ActionNoise``: a training-only wrapper that perturbs actions from the env's own generator."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import bubblerob_env  # noqa: F401
from bubblerob_env.wrappers import ActionNoise
from policies.runs import laser_pooling


def _wheel_speeds(env: gym.Env, seed: int, steps: int = 5) -> np.ndarray:
    env.reset(seed=seed)
    action = np.array([0.5, 0.5], dtype=np.float32)
    return np.array([env.step(action)[4]["wheel_command"] for _ in range(steps)])


def test_noise_is_seeded_gaussian_and_clipped():
    noisy = _wheel_speeds(ActionNoise(gym.make("BubbleRob-v0"), std=0.1), seed=3)
    again = _wheel_speeds(ActionNoise(gym.make("BubbleRob-v0"), std=0.1), seed=3)
    plain = _wheel_speeds(gym.make("BubbleRob-v0"), seed=3)
    np.testing.assert_array_equal(noisy, again)  # the env's generator: reproducible
    assert not np.array_equal(noisy, plain)
    # The oracle: the same draws from a generator seeded as the env's, added and clipped.
    env = gym.make("BubbleRob-v0")
    env.reset(seed=3)
    generator = env.unwrapped.np_random
    draws = generator.normal(0.0, 0.1, size=(5, 2))
    expected = np.clip(0.5 + draws, -1, 1).astype(np.float32) * env.unwrapped.drive.max_wheel_speed
    np.testing.assert_allclose(noisy, expected, rtol=1e-6)
    zero = _wheel_speeds(ActionNoise(gym.make("BubbleRob-v0"), std=0.0), seed=3)
    np.testing.assert_array_equal(zero, plain)


@pytest.mark.parametrize("std", [-0.1, float("nan"), "0.1"])
def test_a_bad_std_is_one_line(std):
    with pytest.raises(ValueError, match="ActionNoise std must be a finite number >= 0"):
        ActionNoise(gym.make("BubbleRob-v0"), std=std)


def test_trained_policies_do_not_replay_it():
    spec = [
        {"bubblerob_env.wrappers.LaserPooling": {"pool": 10}},
        {"bubblerob_env.wrappers.ActionNoise": {"std": 0.1}},
    ]
    assert laser_pooling(spec) == [("laser", 10)]
