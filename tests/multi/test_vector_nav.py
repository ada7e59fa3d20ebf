"""``WorldsVectorEnv(task="nav")``: each slot drives to its own goal; a restart brings a new one."""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("pettingzoo")
import bubblerob_env  # noqa: E402
from bubblerob_env.multi.vector import WorldsVectorEnv  # noqa: E402

RADIUS, CLEARANCE, GOAL_RADIUS = 0.11, 0.25, 0.2  # BubbleRob's, the defaults
FAST: dict[str, Any] = {"laser_num_rays": 36}
_FINALS = ("final_obs", "final_info")


def _row(batch: dict[str, Any], i: int) -> dict[str, Any]:
    """Slot ``i``'s entries of a dict of arrays with ``_key`` masks."""
    return {
        key: value[i]
        for key, value in batch.items()
        if not key.startswith("_") and key not in _FINALS and batch[f"_{key}"][i]
    }


@pytest.mark.parametrize("obs_mode", ["dict", "flat"])
def test_one_robot_a_world_has_the_single_nav_envs_observation_space(obs_mode: str) -> None:
    venv = WorldsVectorEnv(num_worlds=2, num_robots=1, task="nav", obs_mode=obs_mode, **FAST)
    single = gym.make("BubbleRobNav-v0", obs_mode=obs_mode, **FAST)
    assert venv.single_observation_space == single.observation_space
    obs, _ = venv.reset(seed=0)
    assert venv.observation_space.contains(obs)


def test_world_zero_is_the_parallel_nav_env_until_its_first_robot_ends() -> None:
    kwargs: dict[str, Any] = {"task": "nav", "laser_noise_std": 0.01, "max_episode_steps": 80}
    venv = WorldsVectorEnv(num_worlds=2, num_robots=4, num_threads=2, **kwargs, **FAST)
    env = bubblerob_env.parallel_env(num_robots=4, **kwargs, **FAST)
    obs: Any
    obs, infos = venv.reset(seed=5)
    single, single_infos = env.reset(seed=5)
    agents = env.possible_agents
    for k, agent in enumerate(agents):
        np.testing.assert_array_equal(obs["goal"][k], single[agent]["goal"])
        np.testing.assert_array_equal(infos["goal"][k], single_infos[agent]["goal"])
    # Towards the goal, the wheels a little random: some robots end before the time limit.
    rng = np.random.default_rng(0)
    for _ in range(80):
        turn = np.clip(2.0 * obs["goal"][:, 1], -1, 1)
        noisy = np.stack([0.7 - turn, 0.7 + turn], axis=1) + rng.normal(0, 0.2, (8, 2))
        actions = np.clip(noisy, -1, 1).astype(np.float32)
        obs, rewards, terminated, truncated, info = venv.step(actions)
        single, single_rewards, ends, cuts, single_infos = env.step(
            {agent: actions[k] for k, agent in enumerate(agents)}
        )
        for k, agent in enumerate(agents):
            done = terminated[k] or truncated[k]
            mine = info["final_obs"][k] if done else {key: v[k] for key, v in obs.items()}
            mine_info = _row(info["final_info"] if done else info, k)
            for key, value in single[agent].items():
                np.testing.assert_array_equal(mine[key], value)
            assert rewards[k] == single_rewards[agent]
            assert (terminated[k], truncated[k]) == (ends[agent], cuts[agent])
            assert mine_info.keys() == single_infos[agent].keys()
            for key, value in single_infos[agent].items():
                np.testing.assert_array_equal(mine_info[key], value)
        if len(env.agents) < 4:
            return
    raise AssertionError("no robot ended")


def _drive(venv: WorldsVectorEnv, seed: int, steps: int) -> list[Any]:
    """Steer every slot at its goal; every step's results."""
    obs: Any
    obs, _ = venv.reset(seed=seed)
    history = []
    for _ in range(steps):
        turn = np.clip(2.5 * obs["goal"][:, 1], -1, 1)
        actions = np.stack([0.8 - turn, 0.8 + turn], axis=1).clip(-1, 1).astype(np.float32)
        result = venv.step(actions)
        history.append(result)
        obs = result[0]
    return history


def test_success_is_exactly_arriving_untouched_and_a_restart_gets_a_fresh_goal() -> None:
    kwargs: dict[str, Any] = {"task": "nav", "max_episode_steps": 150, **FAST}
    venv = WorldsVectorEnv(num_worlds=2, num_robots=3, num_threads=1, **kwargs)
    again = WorldsVectorEnv(num_worlds=2, num_robots=3, num_threads=2, **kwargs)
    history = _drive(venv, 3, 200)
    outcomes = {"success": 0, "collision": 0, "truncated": 0}
    for step, same in zip(history, _drive(again, 3, 200), strict=True):
        obs, rewards, terminated, truncated, info = step
        np.testing.assert_array_equal(obs["laser"], same[0]["laser"])  # seeded: bit for bit
        np.testing.assert_array_equal(rewards, same[1])
        np.testing.assert_array_equal(info["goal"], same[4]["goal"])
        done = terminated | truncated
        for i in range(6):
            last = _row(info["final_info"], i) if done[i] else _row(info, i)
            # The oracle: the distance from the pose the kernel reports to the goal.
            distance = math.dist((last["x"], last["y"]), last["goal"])
            assert last["goal_distance"] == pytest.approx(distance, abs=1e-12)
            reached = distance <= GOAL_RADIUS
            assert last["is_success"] == (reached and not last["collision"] and not truncated[i])
            assert bool(terminated[i]) == (last["is_success"] or last["collision"])
            assert (last["reward_arrival"] == 100.0) == last["is_success"]
            assert "reward_forward" not in last
            if done[i]:
                key = "success" if last["is_success"] else "collision"
                outcomes["truncated" if truncated[i] else key] += 1
                new = _row(info, i)  # the new episode's first info
                assert not np.array_equal(new["goal"], last["goal"])
                assert math.dist((new["x"], new["y"]), new["goal"]) >= 1.0 - 0.02
                assert new["distance_driven"] == 0.0 and "is_success" not in new
                w = i // 3
                others = [j for j in range(3 * w, 3 * w + 3) if j != i]
                gaps = np.linalg.norm(info["goal"][others] - new["goal"], axis=1)
                assert gaps.min() >= 2 * RADIUS + CLEARANCE - 1e-9
            else:
                reading = obs["goal"][i]
                assert reading[0] == pytest.approx(distance, abs=1e-6)
                bearing = math.atan2(last["goal"][1] - last["y"], last["goal"][0] - last["x"])
                assert math.cos(reading[1] - (bearing - last["yaw"])) == pytest.approx(1, abs=1e-6)
    assert outcomes["success"] > 0 and outcomes["collision"] + outcomes["truncated"] > 0


def test_python_m_train_on_nav_worlds_gives_a_policy_for_the_single_nav_env(tmp_path: Any) -> None:
    from stable_baselines3 import PPO

    from bubblerob_cli.train import main

    out = tmp_path / "run"
    argv = [
        "--env", "BubbleRobNav-v0", "--vec-env", "worlds", "--robots", "1", "--n-envs", "4",
        "--timesteps", "256", "--set", "n_steps=64", "--set", "batch_size=128",
        "--set", "n_epochs=1", "--set", "callback=null",
        "--set", "env_kwargs={max_episode_steps: 60, laser_num_rays: 36}",
        "--eval-freq", "256", "--eval-episodes", "2", "--no-progress", "--out", str(out),
    ]  # fmt: skip
    assert main(argv) == 0
    env = gym.make("BubbleRobNav-v0", **FAST)
    model = PPO.load(out / "model.zip", device="cpu")
    assert model.observation_space == env.observation_space
    obs, _ = env.reset(seed=0)
    action, _ = model.predict(obs, deterministic=True)
    assert env.action_space.contains(action)


def test_one_robot_worlds_first_episodes_are_the_single_nav_envs_step_for_step() -> None:
    venv = WorldsVectorEnv(num_worlds=2, num_robots=1, task="nav", max_episode_steps=100, **FAST)
    singles = [gym.make("BubbleRobNav-v0", max_episode_steps=100, **FAST) for _ in range(2)]
    obs: Any
    obs, _ = venv.reset(seed=7)
    firsts = [env.reset(seed=7 + w)[0] for w, env in enumerate(singles)]
    live = [True, True]
    rng = np.random.default_rng(1)
    for _ in range(100):
        for w in np.flatnonzero(live).tolist():
            for key, value in firsts[w].items():
                np.testing.assert_array_equal(obs[key][w], value)
        turn = np.clip(2.0 * obs["goal"][:, 1], -1, 1) + rng.normal(0, 0.3, 2)
        actions = np.stack([0.8 - turn, 0.8 + turn], axis=1).clip(-1, 1).astype(np.float32)
        obs, rewards, terminated, truncated, info = venv.step(actions)
        for w in np.flatnonzero(live).tolist():
            firsts[w], reward, ended, cut, single_info = singles[w].step(actions[w])
            assert (rewards[w], terminated[w], truncated[w]) == (reward, ended, cut)
            if ended or cut:
                mine = _row(info["final_info"], w)
                assert mine["is_success"] == single_info["is_success"]
                assert mine["goal_distance"] == single_info["goal_distance"]
                live[w] = False
        if not any(live):
            return
    raise AssertionError("an episode outlived its time limit")


def test_world_steps_starts_the_crossing_again_and_crowd_groups_keep_their_slots() -> None:
    from train.worlds_vec import WorldsSB3VecEnv

    circle: dict[str, Any] = {"scenario": "circle", "circle_jitter": 0.1, "world_steps": 30}
    kwargs: dict[str, Any] = {"task": "nav", **FAST}
    mixed = WorldsSB3VecEnv.mixed([(1, 4, circle), (2, 2, {})], **kwargs)
    alone = [WorldsVectorEnv(1, 4, **circle, **kwargs), WorldsVectorEnv(2, 2, **kwargs)]
    mixed.seed(3)
    obs: Any = mixed.reset()
    firsts: list[Any] = [alone[0].reset(seed=3)[0], alone[1].reset(seed=4)[0]]  # seed + w
    np.testing.assert_array_equal(obs["laser"], np.concatenate([f["laser"] for f in firsts]))
    circle_radius = alone[0].config.arena_size / 2 - RADIUS - CLEARANCE
    rng = np.random.default_rng(0)
    for step in range(1, 31):
        actions = rng.uniform(-0.3, 0.3, (8, 2)).astype(np.float32)
        obs, rewards, dones, infos = mixed.step(actions)
        own: list[Any] = [alone[0].step(actions[:4]), alone[1].step(actions[4:])]
        expected = np.concatenate([o[1] for o in own]).astype(rewards.dtype)  # SB3's dtype
        np.testing.assert_array_equal(rewards, expected)
        np.testing.assert_array_equal(obs["goal"], np.concatenate([o[0]["goal"] for o in own]))
        if step < 30:
            assert not dones[:4].any()
    # Step 30: the circle world is drawn anew, every robot truncated, back on a new circle.
    assert dones[:4].all() and all(infos[i]["TimeLimit.truncated"] for i in range(4))
    # The new episodes' first readings: the antipode, straight ahead, across the circle.
    np.testing.assert_allclose(obs["goal"][:4, 0], 2 * circle_radius, atol=4e-3)
    np.testing.assert_allclose(obs["goal"][:4, 1], 0.0, atol=1e-3)
    mixed.close()
