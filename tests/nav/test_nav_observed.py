"""``navigator_observed``: the navigator whose side memory is read from its observation."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np

import bubblerob_env  # noqa: F401  (registers the envs)
from policies import load_policy
from policies.navigator import NavigatorPolicy


def _episode(env: gym.Env, policy: NavigatorPolicy, seed: int) -> tuple[list[float], bool]:
    """Drive one episode; per step after the first, carried memory minus the observed one."""
    obs, _ = env.reset(seed=seed)
    policy.reset()
    gaps: list[float] = []
    while True:
        action, state = policy.predict(obs)
        carried = float(np.asarray(state)[0]) if state is not None else math.nan
        obs, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            return gaps, bool(info.get("is_success"))
        if math.isfinite(carried) and carried != policy.FRESH_STATE:
            wrapped = (carried - policy.memory_in(obs) + math.pi) % math.tau - math.pi
            gaps.append(abs(wrapped))


def test_the_observation_shows_the_carried_memory() -> None:
    """The oracle is the carried navigator's own memory, on validation seeds."""
    env = gym.make("BubbleRobNav-v0")
    navigator = load_policy("navigator", env)
    assert isinstance(navigator, NavigatorPolicy) and not navigator.observed_memory
    gaps: list[float] = []
    for seed in range(1000, 1004):
        gaps += _episode(env, navigator, seed)[0]
    assert len(gaps) > 100
    # Within 0.01 rad at the median; the tail is the steps where the turn rate lags the command.
    assert float(np.median(gaps)) < 0.01
    assert float(np.mean(np.asarray(gaps) < 0.1)) > 0.85


def test_navigator_observed_reaches_goals_from_its_observation_alone() -> None:
    env = gym.make("BubbleRobNav-v0")
    policy = load_policy("navigator_observed", env)
    assert isinstance(policy, NavigatorPolicy) and policy.observed_memory
    reached = [_episode(env, policy, seed)[1] for seed in range(1000, 1012)]
    assert sum(reached) >= 11
    # Its state only marks a step taken: the action of a state it did not carry is the same.
    obs, _ = env.reset(seed=1000)
    for _ in range(30):
        obs, *_ = env.step(policy.predict(obs)[0])
    first, _ = policy.predict(obs, state=np.array([1.0]))
    other, _ = policy.predict(obs, state=np.array([7.0]))
    np.testing.assert_array_equal(first, other)
