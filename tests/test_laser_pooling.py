"""Laser pooling: the wrapper, rl-zoo's ``env_wrapper`` in training, and trained policies using it.

A model trained behind ``LaserPooling`` sees 36 sectors; ``load_policy`` (SB3 zip) and its ONNX
export take the env's full 360-ray scan and pool it themselves, as the wrapper did in training.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import yaml

import bubblerob_env  # noqa: F401  (registers BubbleRob-v0)
from bubblerob_env.wrappers import LaserPooling, min_pool
from policies import load_policy
from policies.observations import PolicyEnvMismatchError
from policies.runs import laser_pooling, parse_env_wrapper
from policies.sb3_policy import NormalizedPolicy, PooledPolicy

POOLING = {"bubblerob_env.wrappers.LaserPooling": {"pool": 10}}
TOLERANCE = 1e-5


def _loop_pool(scan, size):
    """Independent of ``min_pool``: the Python ``min`` of each run of ``size`` rays."""
    values = [float(value) for value in scan]
    return np.array([min(values[start : start + size]) for start in range(0, len(values), size)])


def _pool_batch(batch, size=10):
    pooled = dict(batch)
    pooled["laser"] = np.stack([_loop_pool(scan, size) for scan in batch["laser"]]).astype(
        np.float32
    )
    return pooled


def _observations(env, seeds=range(3), steps=150):
    observations = []
    for seed in seeds:
        obs, _ = env.reset(seed=seed)
        for _ in range(steps):
            observations.append(obs)
            obs, _, terminated, truncated, _ = env.step(env.action_space.sample())
            if terminated or truncated:
                break
    return observations


def _stack(observations):
    return {key: np.stack([obs[key] for obs in observations]) for key in observations[0]}


def test_pooled_observations_are_the_minimum_of_each_ten_rays():
    base = gym.make("BubbleRob-v0")
    pooled = LaserPooling(gym.make("BubbleRob-v0"))
    base.action_space.seed(0)
    pooled.action_space.seed(0)
    compared = 0
    for seed in range(3):
        full, _ = base.reset(seed=seed)
        obs, _ = pooled.reset(seed=seed)
        for _ in range(100):
            assert obs["laser"].shape == (36,) and obs["laser"].dtype == np.float32
            np.testing.assert_array_equal(obs["laser"], _loop_pool(full["laser"], 10))
            for key in ("proximity", "velocity"):
                np.testing.assert_array_equal(obs[key], full[key])
            assert pooled.observation_space.contains(obs)
            action = base.action_space.sample()
            full, reward, terminated, truncated, _ = base.step(action)
            obs, pooled_reward, *_ = pooled.step(action)
            assert pooled_reward == reward  # the reward is the env's, from the full scan
            compared += 1
            if terminated or truncated:
                break
    assert compared > 100


def test_pooled_observation_space():
    env = gym.make("BubbleRob-v0")
    space = LaserPooling(env, pool=12).observation_space
    assert isinstance(space, gym.spaces.Dict)
    laser = space["laser"]
    assert laser.shape == (30,) and laser.dtype == np.float32
    assert np.all(laser.low == 0.0) and np.all(laser.high == env.observation_space["laser"].high[0])
    assert space["proximity"] == env.observation_space["proximity"]
    assert space["velocity"] == env.observation_space["velocity"]


def test_min_pool_on_batches_and_bad_pool_sizes():
    rng = np.random.default_rng(0)
    batch = rng.uniform(0, 5, (7, 360)).astype(np.float32)
    pooled = min_pool(batch, 10)
    assert pooled.shape == (7, 36) and pooled.dtype == np.float32
    for row, scan in zip(pooled, batch, strict=True):
        np.testing.assert_array_equal(row, _loop_pool(scan, 10))
    for size in (0, 7, 361):
        with pytest.raises(ValueError, match="divisor"):
            min_pool(batch, size)
        with pytest.raises(ValueError, match="divisor"):
            LaserPooling(gym.make("BubbleRob-v0"), pool=size)
    with pytest.raises(ValueError, match="'laser'"):
        LaserPooling(gym.make("BubbleRob-v0", laser_num_rays=0))


@pytest.mark.parametrize(
    ("spec", "expected"),
    [
        (None, []),
        ("bubblerob_env.wrappers.LaserPooling", [("bubblerob_env.wrappers.LaserPooling", {})]),
        (POOLING, [("bubblerob_env.wrappers.LaserPooling", {"pool": 10})]),
        (
            ["a.B", {"c.D": None}, POOLING],
            [("a.B", {}), ("c.D", {}), ("bubblerob_env.wrappers.LaserPooling", {"pool": 10})],
        ),
    ],
)
def test_env_wrapper_in_rl_zoos_formats(spec, expected):
    assert parse_env_wrapper(spec) == expected


@pytest.mark.parametrize("spec", [["NoModule"], [{"a.B": {}, "c.D": {}}], [3]])
def test_malformed_env_wrapper_is_refused(spec):
    with pytest.raises(ValueError, match="module.Class"):
        parse_env_wrapper(spec)


def test_policies_replay_only_laser_pooling():
    assert laser_pooling(None) == []
    assert laser_pooling("bubblerob_env.wrappers.LaserPooling") == [("laser", 10)]
    assert laser_pooling([POOLING, POOLING]) == [("laser", 10), ("laser", 10)]
    with pytest.raises(ValueError, match="can apply only"):
        laser_pooling(["gymnasium.wrappers.FrameStackObservation"])
    with pytest.raises(ValueError, match="unknown arguments"):
        laser_pooling([{"bubblerob_env.wrappers.LaserPooling": {"pol": 10}}])


def test_wrapper_class_applies_the_list_in_order():
    pytest.importorskip("stable_baselines3")
    from train.zoo import wrapper_class

    assert wrapper_class(None) is None
    wrap = wrapper_class([POOLING, {"bubblerob_env.wrappers.LaserPooling": {"pool": 3}}])
    env = wrap(gym.make("BubbleRob-v0"))
    assert isinstance(env, LaserPooling) and env.pool == 3
    assert isinstance(env.env, LaserPooling) and env.env.pool == 10
    assert env.observation_space["laser"].shape == (12,)


def test_batched_vec_env_refuses_a_wrapper_that_is_not_an_observation_wrapper(tmp_path):
    # LaserPooling is applied to the whole batch (tests/test_sb3_vec_env.py); a wrapper that
    # changes more than observations cannot be, and is named.
    pytest.importorskip("stable_baselines3")
    from train import train

    with pytest.raises(ValueError, match="observation wrappers only, not EpisodeSuccess"):
        train(
            "ppo",
            "BubbleRob-v0",
            tmp_path,
            timesteps=64,
            overrides={"env_wrapper": [POOLING, "bubblerob_env.wrappers.EpisodeSuccess"]},
            vec_env="batched",
        )


@pytest.fixture(scope="module")
def pooled_run(tmp_path_factory):
    """A few hundred PPO steps trained behind LaserPooling through ``train``."""
    pytest.importorskip("stable_baselines3")
    from train import train

    out = tmp_path_factory.mktemp("pooled")
    train(
        "ppo",
        "BubbleRob-v0",
        out,
        timesteps=256,
        n_envs=2,
        seed=1,
        eval_freq=128,
        eval_episodes=1,
        progress_bar=False,
        overrides={
            "n_steps": 64,
            "batch_size": 32,
            "env_kwargs": {"max_episode_steps": 50},
            "env_wrapper": [POOLING],
        },
    )
    return out


def test_training_applies_and_records_the_env_wrapper(pooled_run):
    import pickle

    from stable_baselines3 import PPO

    config = yaml.safe_load((pooled_run / "config.yml").read_text())["BubbleRob-v0"]
    assert config["env_wrapper"] == [POOLING]
    for name in ("model", "best_model"):
        model = PPO.load(pooled_run / f"{name}.zip", device="cpu")
        assert model.observation_space["laser"].shape == (36,)
        with (pooled_run / f"{name}_vecnormalize.pkl").open("rb") as handle:
            stats = pickle.load(handle)  # noqa: S301 - written by the run above
        assert stats.obs_rms["laser"].mean.shape == (36,)
    evaluations = np.load(pooled_run / "evaluations.npz")
    assert len(evaluations["timesteps"]) >= 1  # the evaluation env was pooled too, or it failed


def test_load_policy_pools_the_envs_full_scan(pooled_run):
    env = gym.make("BubbleRob-v0", max_episode_steps=50)
    policy = load_policy(pooled_run / "best_model.zip", env)
    assert isinstance(policy, PooledPolicy)
    assert isinstance(policy.policy, NormalizedPolicy)
    assert policy.pooling == [("laser", 10)]
    batch = _stack(_observations(env))
    assert batch["laser"].shape[1] == 360
    actions, _ = policy.predict(batch)
    expected, _ = policy.policy.predict(_pool_batch(batch))
    np.testing.assert_array_equal(actions, expected)
    single, _ = policy.predict({key: value[0] for key, value in batch.items()})
    assert single.shape == (2,)
    with pytest.raises(PolicyEnvMismatchError, match="laser_num_rays=360"):
        load_policy(pooled_run / "best_model.zip", gym.make("BubbleRob-v0", laser_num_rays=180))


def test_onnx_export_bakes_the_pooling_in(pooled_run, tmp_path):
    pytest.importorskip("onnxruntime")
    from policies.export_onnx import export_onnx
    from policies.onnx_policy import OnnxPolicy

    out = export_onnx(pooled_run / "best_model.zip", tmp_path / "pooled.onnx")
    env = gym.make("BubbleRob-v0", max_episode_steps=50)
    exported = load_policy(out, env)
    assert isinstance(exported, OnnxPolicy)
    assert exported.observation_shapes["laser"] == (360,)  # the env's scan goes in
    assert exported.metadata["observation_pooling"] == [["laser", 10]]
    inputs = {node.name: node.shape for node in exported.session.get_inputs()}
    assert inputs["laser"][1:] == [360]
    # The SB3 model itself (no pooling of its own) fed the independently pooled observations.
    sb3 = load_policy(pooled_run / "best_model.zip", env)
    assert isinstance(sb3, PooledPolicy)
    space = env.observation_space
    space.seed(0)
    observations = _observations(env) + [space.sample() for _ in range(500)]
    batch = _stack(observations)
    expected, _ = sb3.policy.predict(_pool_batch(batch), deterministic=True)
    actions, _ = exported.predict(batch)
    assert float(np.abs(actions - expected).max()) <= TOLERANCE
    with pytest.raises(PolicyEnvMismatchError):
        load_policy(out, gym.make("BubbleRob-v0", laser_num_rays=36))
