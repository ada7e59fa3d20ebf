"""train/worlds_vec.py: SB3 trains one shared policy on worlds of several robots (#36 item 3).

The adapter is checked against the Gymnasium vector env it wraps, stepped beside it with the
same seed and actions (the oracle), for SB3's VecEnv conventions; then PPO learns on it, through
``python -m train --vec-env worlds``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from gymnasium import spaces

pytest.importorskip("pettingzoo", reason="the [multi] extra is not installed")
pytest.importorskip("stable_baselines3", reason="the [train] extra is not installed")

from bubblerob_env.multi.vector import WorldsVectorEnv  # noqa: E402
from train.worlds_vec import WorldsSB3VecEnv  # noqa: E402

WORLDS, ROBOTS, LIMIT = 2, 3, 40


def test_slots_follow_sb3_conventions_step_for_step_with_the_gymnasium_batch() -> None:
    # On a circle facing its centre, driving ahead: robots hit obstacles and each other.
    kwargs: dict[str, Any] = {"max_episode_steps": LIMIT, "num_threads": 1, "scenario": "circle"}
    adapter = WorldsSB3VecEnv(WORLDS, ROBOTS, **kwargs)
    oracle = WorldsVectorEnv(WORLDS, ROBOTS, **kwargs)
    count = WORLDS * ROBOTS
    assert adapter.num_envs == count
    assert adapter.observation_space == oracle.single_observation_space
    adapter.seed(11)
    obs = adapter.reset()
    expected, _ = oracle.reset(seed=11)  # world w seeded 11 + w
    steps = np.zeros(count, dtype=int)
    ended = {"obstacle": 0, "robot": 0, "truncated": 0}
    for _ in range(2 * LIMIT + 5):
        assert isinstance(adapter.observation_space, spaces.Dict)
        assert isinstance(obs, dict) and isinstance(expected, dict)
        for key, space in adapter.observation_space.spaces.items():
            shape = (count, *(space.shape or ()))
            assert obs[key].shape == shape and obs[key].dtype == space.dtype
            np.testing.assert_array_equal(obs[key], expected[key])
        actions = np.ones((count, 2), dtype=np.float32)
        obs, rewards, dones, infos = adapter.step(actions)
        expected, oracle_rewards, terminated, truncated, info = oracle.step(actions)
        steps += 1
        np.testing.assert_array_equal(rewards, oracle_rewards.astype(np.float32))
        np.testing.assert_array_equal(dones, terminated | truncated)
        assert dones.dtype == bool and len(infos) == count
        for i in range(count):
            if not dones[i]:
                assert "terminal_observation" not in infos[i]
                assert infos[i]["TimeLimit.truncated"] is False
                continue
            final = info["final_obs"][i]
            terminal = infos[i]["terminal_observation"]
            assert adapter.observation_space.contains(terminal)
            for key in final:
                np.testing.assert_array_equal(terminal[key], final[key])
            assert infos[i]["TimeLimit.truncated"] == bool(truncated[i] and not terminated[i])
            assert infos[i]["is_success"] == bool(info["final_info"]["is_success"][i])
            assert infos[i]["episode"]["l"] == steps[i] <= LIMIT
            touched = infos[i].get("collided_with", "")
            assert bool(touched) == bool(terminated[i])  # a collision ends it, naming what
            if terminated[i]:
                ended["obstacle" if touched == "obstacle" else "robot"] += 1
            else:
                ended["truncated"] += 1
            steps[i] = 0
    assert min(ended.values()) > 0, ended  # every kind of end was checked
    adapter.close()
    oracle.close()


def test_ppo_learns_a_shared_policy_through_python_m_train_vec_env_worlds(tmp_path: Path) -> None:
    from bubblerob_cli.train import main

    out = tmp_path / "run"
    argv = [
        "--vec-env", "worlds", "--robots", "4", "--n-envs", "2", "--timesteps", "512",
        "--set", "n_steps=64", "--set", "batch_size=128", "--set", "n_epochs=2",
        "--set", "env_kwargs={max_episode_steps: 60}",
        "--eval-freq", "256", "--eval-episodes", "2", "--no-progress", "--out", str(out),
    ]  # fmt: skip
    assert main(argv) == 0
    settings = json.loads((out / "settings.json").read_text())
    assert settings["vec_env"] == "worlds" and settings["robots"] == 4
    evaluations = np.load(out / "evaluations.npz")
    # --eval-freq counts env steps over every slot: 2 worlds x 4 robots; one rollout is 512.
    assert evaluations["timesteps"].tolist() == [256, 512]
    assert (out / "model.zip").is_file() and (out / "best_model.zip").is_file()


def test_robots_needs_the_worlds_vec_env(capsys: pytest.CaptureFixture[str]) -> None:
    from bubblerob_cli.train import main

    assert main(["--robots", "4", "--out", "/nonexistent/never-made"]) == 2
    assert "--robots" in capsys.readouterr().err
