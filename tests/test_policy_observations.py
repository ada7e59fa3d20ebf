"""load_policy checks an env's observations when it loads a policy (issue #22, item 4).

On an ``obs_mode="flat"`` env every policy drives exactly as on the ``Dict`` env (the same
actions, step for step); on observations it cannot read it fails at load time, in one line.
"""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.wrappers import FlattenObservation

import bubblerob_env  # noqa: F401 - registers BubbleRob-v0
from bubblerob_env.wrappers import LaserPooling
from policies.loading import PolicyEnvMismatchError, load_policy

TRAINED_ZIP = Path(__file__).resolve().parents[1] / "policies" / "trained" / "ppo_bubblerob_v0.zip"
KINDS = ("reactive", "laser", "random", "ppo")


def _actions(env: gym.Env, name: str, steps: int, batched: bool = False) -> np.ndarray:
    policy = load_policy(name, env, seed=3)
    obs, _ = env.reset(seed=7)
    actions = []
    for _ in range(steps):
        if batched:  # a batch of one: SB3's vectorised call
            batch = {k: v[None] for k, v in obs.items()} if isinstance(obs, dict) else obs[None]
            action = policy.predict(batch, deterministic=True)[0][0]
        else:
            action = policy.predict(obs, deterministic=True)[0]
        actions.append(action)
        obs, *_ = env.step(action)
    return np.array(actions)


@pytest.mark.parametrize("name", KINDS)
def test_every_policy_drives_a_flat_env_as_the_dict_env(name) -> None:
    steps = 60
    on_dict = _actions(gym.make("BubbleRob-v0"), name, steps)
    flat_env = gym.make("BubbleRob-v0", obs_mode="flat")
    assert isinstance(flat_env.observation_space, gym.spaces.Box)
    assert np.array_equal(_actions(flat_env, name, steps), on_dict)
    assert np.array_equal(_actions(flat_env, name, steps, batched=True), on_dict)
    assert np.abs(on_dict).max() > 0.1  # it drove


@pytest.mark.parametrize("name", KINDS)
def test_an_unknown_flattening_is_refused_at_load_in_one_line(name) -> None:
    env = FlattenObservation(gym.make("BubbleRob-v0"))
    with pytest.raises(PolicyEnvMismatchError) as error:
        load_policy(name, env)
    message = str(error.value)
    assert "\n" not in message and f"policy {name!r} takes BubbleRob's Dict" in message
    assert "obs_mode='flat'" in message


@pytest.mark.parametrize(
    ("name", "wrap", "expected"),
    [
        ("laser", lambda env: LaserPooling(env, pool=10), "takes laser of shape (360,), but"),
        ("ppo", lambda env: LaserPooling(env, pool=10), "takes laser of shape (360,), but"),
        ("reactive", lambda env: gym.wrappers.FilterObservation(env, ["laser"]), "missing"),
    ],
)
def test_missing_keys_and_other_shapes_are_refused_at_load(name, wrap, expected) -> None:
    with pytest.raises(
        PolicyEnvMismatchError, match=expected.replace("(", r"\(").replace(")", r"\)")
    ):
        load_policy(name, wrap(gym.make("BubbleRob-v0")))


def test_an_sb3_model_on_flat_and_flattened_envs() -> None:
    pytest.importorskip("stable_baselines3")
    with pytest.raises(PolicyEnvMismatchError, match="takes BubbleRob's Dict"):
        load_policy(str(TRAINED_ZIP), FlattenObservation(gym.make("BubbleRob-v0")))
    on_dict = _actions(gym.make("BubbleRob-v0"), str(TRAINED_ZIP), 30)
    on_flat = _actions(gym.make("BubbleRob-v0", obs_mode="flat"), str(TRAINED_ZIP), 30)
    assert np.allclose(on_flat, on_dict)
