"""The shipped ``crowd`` policy: one network on every robot of ``parallel_env(task="nav")``."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("pettingzoo")
import bubblerob_env  # noqa: E402
from policies import load_policy  # noqa: E402
from policies.crowd_policy import CROWD_DIR, CROWD_MODEL  # noqa: E402
from policies.loading import SHIPPED_POLICIES, PolicyEnvMismatchError  # noqa: E402
from policies.multi_evaluation import run_world_episode, world_env  # noqa: E402
from policies.runs import read_config  # noqa: E402


def test_crowd_loads_for_a_world_or_one_robot_and_takes_one_robots_observation() -> None:
    assert SHIPPED_POLICIES["crowd"] == CROWD_MODEL and CROWD_MODEL.is_file()
    world = bubblerob_env.parallel_env(num_robots=4, scenario="circle", task="nav")
    policy = load_policy("crowd", world)
    observations, _ = world.reset(seed=0)
    one = [policy.predict(observations[a], deterministic=True)[0] for a in world.possible_agents]
    assert all(action.shape == (2,) and np.all(np.abs(action) <= 1) for action in one)
    agents = world.possible_agents
    rows = {
        key: np.stack([observations[a][key] for a in agents]) for key in observations[agents[0]]
    }
    batch, _ = policy.predict(rows, deterministic=True)
    np.testing.assert_allclose(batch, np.stack(one), atol=1e-6)  # a row per robot, the same
    load_policy("crowd", gym.make("BubbleRobNav-v0"))  # one robot's Nav env
    with pytest.raises(PolicyEnvMismatchError, match="task='nav'"):
        load_policy("crowd", bubblerob_env.parallel_env(num_robots=2))


def test_the_zip_and_its_onnx_export_drive_the_same_crossings() -> None:
    pytest.importorskip("stable_baselines3")
    zipped = CROWD_DIR / "crowd_bubblerob_nav_v0.zip"
    assert "BubbleRobNav-v0" in read_config(CROWD_DIR)
    outcomes = []
    for name in (str(zipped), "crowd"):
        world = world_env(4, "circle", "BubbleRobNav-v0", {"num_obstacles": (0, 0)}, 0.1)
        policy = load_policy(name, world)
        try:
            records = [
                r
                for seed in (100_000, 100_001)
                for r in run_world_episode(world, policy, seed, 0.4)
            ]
        finally:
            world.close()
        outcomes.append([(r["outcome"], r["length"]) for r in records])
    # One float64 computation in both (policies/sb3_action.py): the same crossings, step for step.
    assert outcomes[0] == outcomes[1]
    world = bubblerob_env.parallel_env(num_robots=4, scenario="circle", task="nav")
    observations, _ = world.reset(seed=100_000)
    rows = {k: np.stack([o[k] for o in observations.values()]) for k in observations["bubblerob_0"]}
    actions = [load_policy(name, world).predict(rows)[0] for name in (str(zipped), "crowd")]
    np.testing.assert_array_equal(actions[0], actions[1])
