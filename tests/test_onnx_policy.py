"""The shipped policy as ONNX: same actions as the SB3 model, no torch, and the env it needs."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from policies import load_policy
from policies.base import Policy
from policies.export_onnx import sha256
from policies.loading import SHIPPED_POLICIES, PolicyEnvMismatchError
from policies.onnx_policy import OnnxPolicy
from policies.residual import ResidualPolicy
from policies.runs import recorded_pooling
from policies.sb3_policy import PooledPolicy

ROOT = Path(__file__).resolve().parents[1]
TRAINED = ROOT / "policies" / "trained"
ONNX = TRAINED / "ppo_bubblerob_v0.onnx"
TOLERANCE = 1e-5
EXPORT_COMMAND = "python -m policies.export_onnx --overwrite"


def _env_observations(policy, seeds=range(5), steps=300):
    """Observations from real episodes, driven by ``policy`` (several seeds, collisions too)."""
    env = gym.make("BubbleRob-v0")
    observations = []
    for seed in seeds:
        obs, _ = env.reset(seed=seed)
        for _ in range(steps):
            observations.append(obs)
            obs, _, terminated, truncated, _ = env.step(policy.predict(obs)[0])
            if terminated or truncated:
                break
    env.close()
    return observations


def _stack(observations):
    return {key: np.stack([obs[key] for obs in observations]) for key in observations[0]}


def _pooled(batch, pooling):
    """``batch`` with each ``(key, pool)`` min-pooled by Python's ``min`` (independent of the code
    under test), as ``LaserPooling`` showed the model its observations in training."""
    pooled = dict(batch)
    for key, size in pooling:
        scans = np.asarray(pooled[key])
        rows = scans.reshape(-1, scans.shape[-1]).tolist()
        sectors = [[min(row[i : i + size]) for i in range(0, len(row), size)] for row in rows]
        pooled[key] = np.asarray(sectors, dtype=scans.dtype).reshape(*scans.shape[:-1], -1)
    return pooled


def _random_observations(space, count, seed=0):
    space.seed(seed)
    return [space.sample() for _ in range(count)]


def _learnt(policy):
    """The network of a policy: a residual policy's correction, else the policy itself."""
    return policy.learnt if isinstance(policy, ResidualPolicy) else policy


def test_shipped_ppo_is_the_onnx_export():
    assert SHIPPED_POLICIES["ppo"] == ONNX
    policy = load_policy("ppo", gym.make("BubbleRob-v0"))
    assert isinstance(_learnt(policy), OnnxPolicy)
    assert isinstance(policy, Policy)


def test_shipped_onnx_was_exported_from_the_shipped_model():
    # A retrained ppo_bubblerob_v0.zip needs a new export; the ONNX file names its sources.
    source = OnnxPolicy(ONNX).metadata["source"]
    expected = {
        name: sha256(TRAINED / name)
        for name in ("ppo_bubblerob_v0.zip", "ppo_bubblerob_v0_vecnormalize.pkl")
    }
    assert source == expected, f"stale {ONNX.name}: run {EXPORT_COMMAND}"


def test_onnx_actions_equal_the_sb3_models():
    pytest.importorskip("stable_baselines3")
    env = gym.make("BubbleRob-v0")
    sb3 = load_policy(TRAINED / "ppo_bubblerob_v0.zip", env)
    shipped = load_policy("ppo", env)
    # A residual policy: the networks are compared here, the sum in test_residual.py.
    assert isinstance(sb3, ResidualPolicy) == isinstance(shipped, ResidualPolicy)
    learnt_sb3, onnx = _learnt(sb3), _learnt(shipped)
    # A model trained behind LaserPooling: the ONNX graph takes the env's full scan and pools it
    # itself; the SB3 model is fed the pooled observations, computed here.
    pooling = recorded_pooling(TRAINED / "ppo_bubblerob_v0.zip")
    model = learnt_sb3.policy if isinstance(learnt_sb3, PooledPolicy) else learnt_sb3
    assert isinstance(learnt_sb3, PooledPolicy) == bool(pooling)
    # Real observations from several seeds, driven by both policies and the gap follower (close
    # calls and collisions), and samples of the whole observation space (clipping).
    observations = (
        _env_observations(sb3)
        + _env_observations(shipped, seeds=range(5, 8))
        + _env_observations(load_policy("laser", env), seeds=range(8, 10))
        + _random_observations(env.observation_space, 2000)
    )
    assert len(observations) > 3000
    batch = _stack(observations)
    expected, _ = model.predict(_pooled(batch, pooling), deterministic=True)
    actions, state = onnx.predict(batch)
    assert state is None
    assert actions.dtype == np.float32 and actions.shape == expected.shape == (len(observations), 2)
    difference = float(np.abs(actions - expected).max())
    assert difference <= TOLERANCE, difference
    for obs in observations[::250]:  # single observations, as run_episode passes them
        single, _ = onnx.predict(obs)
        assert single.shape == (2,)
        reference, _ = model.predict(_pooled(obs, pooling), deterministic=True)
        assert np.abs(single - reference).max() <= TOLERANCE


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_export_of_a_fresh_model_matches_it(tmp_path, algo):
    # The export handles both algorithms, with and without VecNormalize statistics.
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import PPO, SAC
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import VecNormalize

    from policies.export_onnx import export_onnx

    envs = make_vec_env("BubbleRob-v0", n_envs=1, seed=0, env_kwargs={"laser_num_rays": 36})
    if algo == "ppo":
        envs = VecNormalize(envs)
        envs.reset()
        for _ in range(20):
            envs.step([envs.action_space.sample()])
        envs.save(str(tmp_path / "model_vecnormalize.pkl"))
        model = PPO("MultiInputPolicy", envs, seed=0, device="cpu")
    else:
        model = SAC("MultiInputPolicy", envs, seed=0, device="cpu", buffer_size=100)
    model.save(tmp_path / "model.zip")
    (tmp_path / "config.yml").write_text("BubbleRob-v0:\n  env_kwargs: {laser_num_rays: 36}\n")
    out = export_onnx(tmp_path / "model.zip")
    assert out == tmp_path / "model.onnx"
    env = gym.make("BubbleRob-v0", laser_num_rays=36)
    reference = load_policy(tmp_path / "model.zip", env)
    exported = load_policy(out, env)
    assert exported.metadata["env"]["laser_num_rays"] == 36
    batch = _stack(_random_observations(env.observation_space, 500))
    difference = np.abs(exported.predict(batch)[0] - reference.predict(batch)[0]).max()
    assert difference <= TOLERANCE
    with pytest.raises(PolicyEnvMismatchError):
        load_policy(out, gym.make("BubbleRob-v0"))


_TORCH_FREE = """
import sys
sys.modules.update(torch=None, stable_baselines3=None)  # any import of them fails
import gymnasium as gym
import bubblerob_env
from policies import load_policy
env = gym.make("BubbleRob-v0")
policy = load_policy("ppo", env)
obs, _ = env.reset(seed=0)
for _ in range(50):
    obs, *_ = env.step(policy.predict(obs)[0])
loaded = [m for m, module in sys.modules.items() if module is not None]
print(type(policy).__name__, type(policy.learnt).__name__,
      sorted(m for m in loaded if m.split(".")[0] == "torch"))
"""


def test_shipped_policy_runs_without_torch():
    result = subprocess.run(
        [sys.executable, "-c", _TORCH_FREE],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
        cwd=ROOT,
    )
    assert result.returncode == 0, result.stderr
    # The shipped policy: the ONNX network's correction on the gap follower, and no torch.
    assert result.stdout.split() == ["ResidualPolicy", "OnnxPolicy", "[]"]


@pytest.mark.parametrize(
    ("kwargs", "named"),
    [
        ({"action_type": "twist"}, "action_type='twist'"),
        ({"laser_num_rays": 180}, "laser_num_rays=180"),
        ({"camera": True}, "camera=64x64"),
    ],
)
def test_shipped_policy_refuses_an_env_it_was_not_trained_for(kwargs, named):
    with pytest.raises(PolicyEnvMismatchError) as error:
        load_policy("ppo", gym.make("BubbleRob-v0", **kwargs))
    message = str(error.value)
    assert "\n" not in message
    assert "policy 'ppo' was trained for an env with action_type='wheels'" in message
    assert named in message


def test_sb3_model_refuses_an_env_unlike_its_runs_config(tmp_path):
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import PPO

    env = gym.make("BubbleRob-v0", action_type="twist")
    PPO("MultiInputPolicy", env, n_steps=32, batch_size=16, device="cpu").save(tmp_path / "m.zip")
    (tmp_path / "config.yml").write_text(
        json.dumps({"BubbleRob-v0": {"env_kwargs": {"action_type": "twist"}}})
    )
    assert load_policy(tmp_path / "m.zip", env) is not None
    with pytest.raises(PolicyEnvMismatchError, match=r"action_type='twist'.*action_type='wheels'"):
        load_policy(tmp_path / "m.zip", gym.make("BubbleRob-v0"))


@pytest.mark.parametrize("name", ["reactive", "laser", "random", "ppo"])
def test_every_policy_follows_the_protocol(name):
    assert isinstance(load_policy(name, gym.make("BubbleRob-v0")), Policy)
