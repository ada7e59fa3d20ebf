"""obs_mode="flat", the batch's all-or-nothing action check, and close() on the batch."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from gymnasium.wrappers import NormalizeObservation
from gymnasium.wrappers.vector import NormalizeObservation as VectorNormalizeObservation

import bubblerob_env  # noqa: F401
from bubblerob_env.batch.cpu import BubbleRobVectorEnv


def test_flat_observation_is_the_dict_readings_in_layout_order():
    flat = gym.make("BubbleRob-v0", obs_mode="flat")
    plain = gym.make("BubbleRob-v0")
    layout = flat.unwrapped.observation_layout
    assert list(layout) == ["laser", "proximity", "velocity"]
    assert flat.observation_space.shape == (363,)
    assert flat.observation_space.dtype == np.float32
    obs_f, _ = flat.reset(seed=31)
    obs_d, _ = plain.reset(seed=31)
    rng = np.random.default_rng(0)
    for _ in range(50):
        for key, part in layout.items():
            np.testing.assert_array_equal(obs_f[part], obs_d[key])
        assert flat.observation_space.contains(obs_f)
        action = rng.uniform(-1, 1, 2).astype(np.float32)
        obs_f, reward_f, *_ = flat.step(action)
        obs_d, reward_d, *_ = plain.step(action)
        assert reward_f == reward_d


def test_flat_passes_gymnasiums_checker_and_normalize_observation():
    env = gym.make("BubbleRob-v0", obs_mode="flat")
    check_env(env.unwrapped, skip_render_check=True)
    normalized = NormalizeObservation(gym.make("BubbleRob-v0", obs_mode="flat"))
    normalized.reset(seed=0)
    for _ in range(20):
        obs, *_ = normalized.step(normalized.action_space.sample())
    assert obs.shape == (363,) and np.isfinite(obs).all()
    vector = VectorNormalizeObservation(BubbleRobVectorEnv(3, obs_mode="flat"))
    vector.reset(seed=0)
    obs, *_ = vector.step(np.zeros((3, 2), np.float32))
    assert obs.shape == (3, 363) and np.isfinite(obs).all()


def test_flat_with_the_camera_is_one_clear_error():
    with pytest.raises(ValueError, match="obs_mode='flat' has no place for the camera"):
        gym.make("BubbleRob-v0", obs_mode="flat", camera=True)
    with pytest.raises(ValueError, match="obs_mode must be one of"):
        gym.make("BubbleRob-v0", obs_mode="box")


def test_flat_batch_rows_equal_single_envs():
    envs = BubbleRobVectorEnv(3, num_threads=2, obs_mode="flat", max_episode_steps=25)
    singles = [gym.make("BubbleRob-v0", obs_mode="flat", max_episode_steps=25) for _ in range(3)]
    obs, _ = envs.reset(seed=70)
    single_obs = [env.reset(seed=70 + i)[0] for i, env in enumerate(singles)]
    rng = np.random.default_rng(1)
    for _ in range(60):
        for i in range(3):
            if single_obs[i] is not None:
                np.testing.assert_array_equal(obs[i], single_obs[i])
        actions = rng.uniform(-1, 1, (3, 2)).astype(np.float32)
        obs, rewards, terminated, truncated, _ = envs.step(actions)
        for i, env in enumerate(singles):
            if single_obs[i] is None:  # NextStep: this step resets the robot
                single_obs[i], _ = env.reset()
                assert rewards[i] == 0.0
                continue
            single_obs[i], reward, done, cut, _ = env.step(actions[i])
            assert reward == rewards[i] and (done, cut) == (terminated[i], truncated[i])
            if done or cut:
                np.testing.assert_array_equal(obs[i], single_obs[i])
                single_obs[i] = None
    envs.close()


def test_a_bad_action_row_moves_no_robot():
    envs = BubbleRobVectorEnv(8, num_threads=2)
    envs.reset(seed=0)
    before = [env.data.qpos.copy() for env in envs.envs]
    time = [env.data.time for env in envs.envs]
    actions = np.zeros((8, 2), np.float32)
    actions[5, 0] = np.nan
    with pytest.raises(ValueError, match=r"robot\(s\) \[5\].*no robot was stepped"):
        envs.step(actions)
    for env, qpos, t in zip(envs.envs, before, time, strict=True):
        np.testing.assert_array_equal(env.data.qpos, qpos)
        assert env.data.time == t
    _, rewards, *_ = envs.step(np.zeros((8, 2), np.float32))  # the batch goes on
    assert rewards.shape == (8,)
    with pytest.raises(ValueError, match="actions must be 8 rows of 2 finite numbers"):
        envs.step([[10**400, 0]] * 8)
    envs.close()
    with pytest.raises(RuntimeError, match=r"step\(\) called after close\(\)"):
        envs.step(np.zeros((8, 2), np.float32))


def test_a_huge_action_is_a_value_error_not_an_overflow():
    env = gym.make("BubbleRob-v0")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action must be 2 finite numbers"):
        env.step([10**400, 0])


def test_the_env_class_refuses_step_before_reset_and_render_after_close():
    from bubblerob_env.env import BubbleRobEnv

    env = BubbleRobEnv(render_mode="rgb_array")
    with pytest.raises(RuntimeError, match=r"step\(\) called before reset\(\)"):
        env.step(np.zeros(2, np.float32))
    env.reset(seed=0)
    env.step(np.zeros(2, np.float32))
    env.close()
    with pytest.raises(RuntimeError, match=r"render\(\) called after close\(\)"):
        env.render()
