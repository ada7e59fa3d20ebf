"""Residual policies on the gap follower: training's wrapper, the SB3 model and its ONNX export.

The oracle for "the executed action" is written here from the definition: the ``laser`` policy's
action plus ``scale`` times the network's, clipped to [-1, 1].
"""

from __future__ import annotations

import re
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from bubblerob_env.wrappers import LaserPooling
from policies import load_policy
from policies.residual import ResidualOnLaser, ResidualPolicy
from policies.runs import residual_scale

RESIDUAL = "policies.residual.ResidualOnLaser"
CONFIG = f"""BubbleRob-v0:
  env_kwargs: {{laser_num_rays: 36}}
  env_wrapper:
  - {RESIDUAL}: {{scale: 0.5}}
  - bubblerob_env.wrappers.LaserPooling: {{pool: 4}}
"""


def test_a_zero_correction_drives_the_gap_followers_episode() -> None:
    plain = gym.make("BubbleRob-v0", max_episode_steps=200)
    wrapped = ResidualOnLaser(gym.make("BubbleRob-v0", max_episode_steps=200), scale=0.5)
    laser = load_policy("laser", plain)
    obs, _ = plain.reset(seed=1234)
    wrapped_obs, _ = wrapped.reset(seed=1234)
    done = False
    while not done:
        obs, reward, terminated, truncated, _ = plain.step(laser.predict(obs)[0])
        wrapped_obs, wrapped_reward, *_ = wrapped.step(np.zeros(2, dtype=np.float32))
        assert np.array_equal(obs["laser"], wrapped_obs["laser"]) and reward == wrapped_reward
        done = terminated or truncated


def test_the_executed_action_is_base_plus_scaled_correction_clipped() -> None:
    env = ResidualOnLaser(gym.make("BubbleRob-v0"), scale=0.4)
    obs, _ = env.reset(seed=5)
    base = load_policy("laser", env.unwrapped).predict(obs)[0]
    for correction in ([1.0, -1.0], [0.3, 0.2], [5.0, -5.0]):
        expected = [
            min(1.0, max(-1.0, b + 0.4 * min(1.0, max(-1.0, c))))
            for b, c in zip(base, correction, strict=True)
        ]
        assert np.allclose(env.action(np.array(correction, dtype=np.float32)), expected, atol=1e-6)


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ([{RESIDUAL: {"scale": 0}}], "residual scale must be in (0, 2], got 0"),
        ([{RESIDUAL: {"scale": 3}}], "residual scale must be in (0, 2], got 3"),
        ([{RESIDUAL: {"gain": 1}}], "unknown arguments ['gain']"),
    ],
)
def test_bad_residual_settings_are_one_line(spec: list[dict[str, object]], message: str) -> None:
    with pytest.raises(ValueError, match=re.escape(message)):
        residual_scale(spec)


def test_trained_residual_loads_as_zip_and_onnx_alike(tmp_path: Path) -> None:
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import PPO

    from policies.export_onnx import export_onnx

    def make() -> gym.Env[object, object]:
        env = gym.make("BubbleRob-v0", laser_num_rays=36, max_episode_steps=50)
        return LaserPooling(ResidualOnLaser(env, scale=0.5), pool=4)

    model = PPO("MultiInputPolicy", make(), n_steps=64, batch_size=64, seed=0, device="cpu")
    model.learn(128)
    model.save(tmp_path / "model.zip")
    (tmp_path / "config.yml").write_text(CONFIG)
    onnx_path = export_onnx(tmp_path / "model.zip")
    env = gym.make("BubbleRob-v0", laser_num_rays=36)
    zipped, exported = load_policy(tmp_path / "model.zip", env), load_policy(onnx_path, env)
    assert isinstance(zipped, ResidualPolicy) and isinstance(exported, ResidualPolicy)
    assert exported.learnt.metadata["residual"] == {"base": "laser", "scale": 0.5}
    laser = load_policy("laser", env)
    obs, _ = env.reset(seed=3)
    for _ in range(40):
        action = zipped.predict(obs)[0]
        assert np.abs(exported.predict(obs)[0] - action).max() <= 1e-5
        # The oracle: the gap follower plus half the network's own output (pooled scan), clipped.
        pooled = {**obs, "laser": obs["laser"].reshape(9, 4).min(axis=1)}
        network = model.predict(pooled, deterministic=True)[0]
        expected = np.clip(laser.predict(obs)[0] + 0.5 * np.clip(network, -1, 1), -1, 1)
        assert np.abs(action - expected).max() <= 1e-6
        obs, *_ = env.step(action)


def test_the_native_batch_applies_the_residual_as_each_env_does() -> None:
    pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.env_util import make_vec_env

    from train.envs import batched_envs
    from train.zoo import wrapper_class

    spec = [{RESIDUAL: {"scale": 0.5}}, {"bubblerob_env.wrappers.LaserPooling": {"pool": 10}}]
    batched = batched_envs("BubbleRob-v0", 3, 0, {}, spec)
    dummy = make_vec_env("BubbleRob-v0", n_envs=3, seed=0, wrapper_class=wrapper_class(spec))
    first_b, first_d = batched.reset(), dummy.reset()
    assert all(np.array_equal(first_b[k], first_d[k]) for k in first_d)
    rng = np.random.default_rng(0)
    for _ in range(150):
        actions = rng.uniform(-1, 1, (3, 2)).astype(np.float32)
        obs_b, rewards_b, dones_b, _ = batched.step(actions)
        obs_d, rewards_d, dones_d, _ = dummy.step(actions)
        assert all(np.array_equal(obs_b[k], obs_d[k]) for k in obs_d)
        assert np.array_equal(rewards_b, rewards_d) and np.array_equal(dones_b, dones_d)
