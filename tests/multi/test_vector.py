"""The native batch of worlds: one slot per robot; an ended slot restarts alone at a free pose."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("pettingzoo")
import bubblerob_env  # noqa: E402
from bubblerob_env.multi.vector import WorldsVectorEnv  # noqa: E402


def test_world_zero_steps_as_the_parallel_env_until_a_robot_ends() -> None:
    venv = WorldsVectorEnv(num_worlds=2, num_robots=4, laser_noise_std=0.01, num_threads=2)
    env = bubblerob_env.parallel_env(num_robots=4, laser_noise_std=0.01)
    obs: Any
    obs, _ = venv.reset(seed=5)
    single, _ = env.reset(seed=5)
    actions = np.random.default_rng(0).uniform(-1, 1, (60, 8, 2)).astype(np.float32)
    for step in actions:
        for k, agent in enumerate(env.possible_agents):
            assert np.array_equal(obs["laser"][k], single[agent]["laser"])
            assert np.array_equal(obs["velocity"][k], single[agent]["velocity"])
        obs, _, terminated, truncated, _ = venv.step(step)
        single, *ends = env.step({a: step[k] for k, a in enumerate(env.possible_agents)})
        if any(d for flags in ends[1:3] for d in flags.values()):
            break


def test_an_ended_slot_restarts_at_a_free_pose_while_the_others_drive_on() -> None:
    venv = WorldsVectorEnv(num_worlds=2, num_robots=6, max_episode_steps=60, num_threads=1)
    venv.reset(seed=1)
    again = WorldsVectorEnv(num_worlds=2, num_robots=6, max_episode_steps=60, num_threads=2)
    again.reset(seed=1)
    rng = np.random.default_rng(2)
    lengths = np.zeros(12, dtype=int)  # each slot's steps since its episode began
    ends = {"terminated": 0, "truncated": 0}
    obs: Any
    same: Any
    for _ in range(150):
        actions = rng.uniform(0.6, 1, (12, 2)).astype(np.float32)
        obs, rewards, terminated, truncated, info = venv.step(actions)
        same = again.step(actions)  # seeded: the same, whatever the threads
        assert np.array_equal(obs["laser"], same[0]["laser"])
        assert np.array_equal(rewards, same[1])
        lengths += 1
        # A slot's time limit counts its own episode: a neighbour's restart does not reset it.
        # As Gymnasium's TimeLimit, the limit truncates even on a step that also terminates.
        assert np.array_equal(truncated, lengths == 60)
        done = terminated | truncated
        assert np.array_equal(info.get("_final_obs", np.zeros(12, bool)), done)
        for i in np.flatnonzero(terminated).tolist():
            touched = info["final_info"]["collided_with"][i]
            assert touched == "obstacle" or touched in {f"bubblerob_{k}" for k in range(6)}
        # A restarted robot starts clear of every other robot of its world.
        xy = np.stack([info["x"], info["y"]], axis=1).reshape(2, 6, 2)
        for i in np.flatnonzero(done).tolist():
            w, k = divmod(i, 6)
            gaps = np.linalg.norm(xy[w] - xy[w, k], axis=1)
            assert np.delete(gaps, k).min() >= 2 * 0.11
        lengths[done] = 0
        ends["terminated"] += int(terminated.sum())
        ends["truncated"] += int(truncated.sum())
    assert ends["terminated"] > 0 and ends["truncated"] > 0


def test_the_benchmark_prints_its_table() -> None:
    script = Path(__file__).resolve().parents[2] / "bench" / "multi_speed.py"
    result = subprocess.run(
        [sys.executable, str(script), "--quick"], capture_output=True, text=True, timeout=300
    )
    assert result.returncode == 0, result.stderr
    for row in ("single batch", "target at 8 robots a world"):
        assert row in result.stdout
