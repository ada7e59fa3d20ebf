"""``navigator_observed``: the navigator whose side memory is read from its observation."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
from nav_support import assert_action_ignores_the_state

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
    assert_action_ignores_the_state(env, policy)


def _boxed_in(turn_rate: float) -> dict[str, np.ndarray]:
    """A robot boxed in (every ray 0.15 m), more room on its left (0.3 m), turning at a rate."""
    laser = np.full(360, 0.15, dtype=np.float32)
    laser[200:300] = 0.3  # rays 20 to 120 degrees to the left (ray 180 is straight ahead)
    velocity = np.array([0.0, turn_rate], dtype=np.float32)
    goal = np.array([2.0, 0.0], dtype=np.float32)
    proximity = np.zeros(1, dtype=np.float32)
    return {"laser": laser, "proximity": proximity, "velocity": velocity, "goal": goal}


def test_boxed_in_navigator_observed_keeps_turning_the_way_it_turns() -> None:
    """Boxed in, the navigator turns to the side with more room; ``navigator_observed`` keeps
    to the side it already turns to (the measured rate), as long as it turns: the side with
    more room flips as the robot turns, and a student averaging both labels stands still."""
    env = gym.make("BubbleRobNav-v0")
    navigator, observed = load_policy("navigator", env), load_policy("navigator_observed", env)

    def turn(policy: NavigatorPolicy, rate: float) -> float:
        action, _ = policy.predict(_boxed_in(rate), state=np.array([1.0]))
        assert action[0] == -action[1] != 0  # in place
        return float(np.sign(action[1] - action[0]))  # right wheel faster: a left turn

    for rate in (-2.0, 0.0, 2.0):
        assert turn(navigator, rate) == 1.0  # more room on the left
    assert [turn(observed, rate) for rate in (-2.0, 0.0, 0.5, 2.0)] == [-1.0, 1.0, 1.0, 1.0]
