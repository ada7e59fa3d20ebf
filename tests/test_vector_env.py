"""The native batch (``gym.make_vec(..., vectorization_mode="vector_entry_point")``) against plain
``gym.make`` envs: sub-env ``i`` seeded ``s + i`` gives bit for bit what a plain env seeded
``s + i`` gives, across resets, for any number of robots and threads, in both autoreset modes."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode, VectorEnv

from bubblerob_env.batch.common import collate_infos
from bubblerob_env.batch.cpu import ARENA_MEMORY, BubbleRobVectorEnv

SEED = 40


def _make_vec(num_envs: int, **kwargs: Any) -> BubbleRobVectorEnv:
    envs = gym.make_vec(
        "BubbleRob-v0", num_envs=num_envs, vectorization_mode="vector_entry_point", **kwargs
    )
    assert isinstance(envs, BubbleRobVectorEnv)
    return envs


def _actions(steps: int, num_envs: int, seed: int = 0) -> np.ndarray:
    # Mostly forward (collisions happen) with some out-of-range values (clipping is counted).
    actions = np.random.default_rng(seed).uniform(-1.3, 1.3, size=(steps, num_envs, 2))
    actions[..., 0] = np.abs(actions[..., 0])
    return actions.astype(np.float32)


def _same(a: Any, b: Any) -> bool:
    """Equal bit for bit: same bytes for numbers and arrays (a -0.0 is not a 0.0)."""
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, (str, type(None))):
        return a == b
    a_arr, b_arr = np.asarray(a), np.asarray(b)
    if a_arr.dtype.kind == "f" or b_arr.dtype.kind == "f":
        a_arr, b_arr = a_arr.astype(np.float64), b_arr.astype(np.float64)
    return a_arr.shape == b_arr.shape and a_arr.tobytes() == b_arr.tobytes()


def _row(batch: dict[str, Any], i: int) -> dict[str, Any]:
    """Robot ``i``'s info out of a batched info: the keys its mask marks present."""
    keys = [k for k in batch if not k.startswith("_") and k not in ("final_obs", "final_info")]
    return {k: batch[k][i] for k in keys if batch[f"_{k}"][i]}


def _plain(seed: int, actions: np.ndarray, mode: AutoresetMode, **kwargs: Any) -> list[tuple]:
    """What a plain env does with Gymnasium's autoreset: one entry per vector reset/step."""
    env = gym.make("BubbleRob-v0", **kwargs)
    obs, info = env.reset(seed=seed)
    trace: list[tuple] = [(obs, info)]
    done = False
    for action in actions:
        if done and mode == AutoresetMode.NEXT_STEP:
            obs, info = env.reset()
            trace.append((obs, 0.0, False, False, info, None))
            done = False
            continue
        obs, reward, terminated, truncated, info = env.step(action)
        done = terminated or truncated
        final = None
        if done and mode == AutoresetMode.SAME_STEP:
            final = (obs, info)
            obs, info = env.reset()
            done = False
        trace.append((obs, reward, terminated, truncated, info, final))
    env.close()
    return trace


def _check(envs: BubbleRobVectorEnv, actions: np.ndarray, **kwargs: Any) -> int:
    """Run the batch and a plain env per robot; assert equality; return episodes ended."""
    mode = envs.autoreset_mode
    n = envs.num_envs
    plains = [_plain(SEED + i, actions[:, i], mode, **kwargs) for i in range(n)]
    obs, info = envs.reset(seed=SEED)
    for i in range(n):
        assert _same({k: v[i] for k, v in obs.items()}, plains[i][0][0])
        assert _same(_row(info, i), plains[i][0][1])
    ended = 0
    for t, action in enumerate(actions, start=1):
        obs, reward, terminated, truncated, info = envs.step(action)
        for i in range(n):
            p_obs, p_reward, p_term, p_trunc, p_info, final = plains[i][t]
            where = f"robot {i} step {t}"
            assert _same({k: v[i] for k, v in obs.items()}, p_obs), where
            assert _same(reward[i], p_reward), where
            assert (terminated[i], truncated[i]) == (p_term, p_trunc), where
            assert _same(_row(info, i), p_info), where
            ended += bool(p_term or p_trunc)
            if final is not None:
                assert info["_final_obs"][i] and info["_final_info"][i], where
                assert _same(info["final_obs"][i], final[0]), where
                assert _same(_row(info["final_info"], i), final[1]), where
            elif "_final_obs" in info:
                assert not info["_final_obs"][i], where
    envs.close()
    return ended


@pytest.mark.parametrize(("num_envs", "num_threads"), [(1, 1), (3, 2), (5, 3), (8, 2)])
@pytest.mark.parametrize("mode", ["NextStep", "SameStep"])
def test_each_robot_is_a_plain_env_bit_for_bit(num_envs, num_threads, mode):
    limit = 40  # short episodes: many resets, by the time limit and by collisions
    envs = _make_vec(
        num_envs, num_threads=num_threads, autoreset_mode=mode, max_episode_steps=limit
    )
    assert envs.metadata["autoreset_mode"] == AutoresetMode(mode)
    ended = _check(envs, _actions(130, num_envs), max_episode_steps=limit)
    assert ended >= 3 * num_envs


@pytest.mark.parametrize(
    "kwargs",
    [
        {"action_type": "twist", "laser_noise_std": 0.05, "odometry_noise": 0.05},
        {"laser_num_rays": 0, "terminate_on_collision": False},
        {"laser_num_rays": 45, "laser_fov": 3.0, "num_obstacles": (12, 16)},
        {"camera_width": 16, "camera_height": 12},
    ],
    ids=["twist-noise", "no-laser", "fov-crowded", "camera"],
)
def test_every_kwarg_bit_for_bit(kwargs):
    envs = _make_vec(3, num_threads=2, max_episode_steps=30, **kwargs)
    _check(envs, _actions(70, 3, seed=1), max_episode_steps=30, **kwargs)


def test_make_vec_gives_a_vector_env_with_batched_spaces():
    envs = _make_vec(4, laser_num_rays=90)
    assert isinstance(envs, VectorEnv)
    assert envs.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    assert envs.max_episode_steps == 1000  # the registered time limit
    assert envs.num_threads >= 1
    obs, _ = envs.reset(seed=0)
    assert obs["laser"].shape == (4, 90) and obs["laser"].dtype == np.float32
    assert obs["velocity"].shape == (4, 2) and obs["proximity"].shape == (4, 1)
    assert envs.observation_space.contains(obs)
    obs, reward, terminated, truncated, info = envs.step(envs.action_space.sample())
    assert reward.shape == terminated.shape == truncated.shape == (4,)
    assert info["position"].shape == (4, 3) and info["_position"].all()
    envs.close()


def test_seeds_as_a_list_and_partial_reset():
    envs = _make_vec(3)
    obs, _ = envs.reset(seed=[7, None, 9])
    plain = gym.make("BubbleRob-v0")
    assert _same(obs["laser"][2], plain.reset(seed=9)[0]["laser"])
    envs.step(np.zeros((3, 2), np.float32))
    obs, info = envs.reset(seed=[None, 5, None], options={"reset_mask": np.array([0, 1, 0], bool)})
    assert _same(obs["laser"][1], plain.reset(seed=5)[0]["laser"])
    assert info["_x"].tolist() == [False, True, False]
    with pytest.raises(ValueError, match="3 seeds"):
        envs.reset(seed=[1, 2])
    envs.close()


def test_is_success_as_the_plain_env():
    # Standing still reaches the time limit without a collision: a success on the last step.
    envs = _make_vec(2, max_episode_steps=5, action_type="twist")
    envs.reset(seed=0)
    for _ in range(5):
        _, _, terminated, truncated, info = envs.step(np.zeros((2, 2), np.float32))
    assert truncated.all() and not terminated.any() and info["is_success"].all()
    envs.close()


def test_bad_arguments_raise_like_the_single_env():
    with pytest.raises(TypeError, match="unexpected keyword argument 'frameskip'"):
        _make_vec(2, frameskip=4)
    with pytest.raises(ValueError, match="laser_num_rays"):
        _make_vec(2, laser_num_rays=-1)
    with pytest.raises(ValueError, match="autoreset_mode"):
        _make_vec(2, autoreset_mode="Sometimes")
    with pytest.raises(ValueError, match="num_envs"):
        BubbleRobVectorEnv(num_envs=0)
    envs = _make_vec(2)
    with pytest.raises(RuntimeError, match="before reset"):
        envs.step(np.zeros((2, 2), np.float32))
    envs.reset(seed=0)
    with pytest.raises(ValueError, match="shape"):
        envs.step(np.zeros(2, np.float32))
    envs.close()


def test_each_robot_has_a_small_arena_and_its_own_model():
    envs = _make_vec(3)
    models = {id(env.model) for env in envs.envs}
    assert len(models) == 3
    assert all(env.model.narena == ARENA_MEMORY for env in envs.envs)
    envs.close()


def test_collate_infos_masks_missing_keys():
    info = collate_infos([{"a": 1.5, "s": "x"}, {"a": 2.0, "v": np.ones(2)}])
    assert info["a"].tolist() == [1.5, 2.0] and info["_a"].all()
    assert info["s"].tolist() == ["x", ""] and info["_s"].tolist() == [True, False]
    assert info["v"].tolist() == [[0.0, 0.0], [1.0, 1.0]] and info["_v"].tolist() == [False, True]


def test_readme_batched_env_example_runs():
    import re
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    section = (root / "README.md").read_text().split("## Batched env", 1)[1].split("\n## ", 1)[0]
    code = re.findall(r"```py\n(.*?)```", section, flags=re.DOTALL)[0]
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, check=False
    )
    assert result.returncode == 0, result.stderr
    assert "laser batch (8, 360)" in result.stdout


def test_call_get_attr_set_attr_reach_every_robot():
    envs = _make_vec(3, laser_num_rays=10)
    assert envs.get_attr("arena_size") == (4.0, 4.0, 4.0)
    assert envs.call("dt") == (0.05, 0.05, 0.05)
    envs.set_attr("collision_penalty", [1.0, 2.0, 3.0])
    assert envs.get_attr("collision_penalty") == (1.0, 2.0, 3.0)
    with pytest.raises(ValueError, match="3 values"):
        envs.set_attr("collision_penalty", [1.0])
    envs.close()


def test_long_random_runs_stay_far_inside_the_small_arena():
    # Robots pushing into walls and large obstacles without termination: the most contacts.
    envs = _make_vec(
        4, terminate_on_collision=False, num_obstacles=(10, 10), obstacle_size=(0.2, 0.4)
    )
    envs.reset(seed=0)
    actions = _actions(1500, 4, seed=5)
    most = 0
    for action in actions:
        envs.step(action)  # raises if MuJoCo reports a full arena
        most = max(most, *(env.data.maxuse_arena for env in envs.envs))
    assert 0 < most < ARENA_MEMORY // 8
    envs.close()


def test_render_gives_each_robots_frame():
    envs = _make_vec(2, render_mode="rgb_array", render_width=32, render_height=24)
    obs, _ = envs.reset(seed=3)
    envs.step(np.zeros((2, 2), np.float32))
    frames = envs.render()
    assert frames is not None and len(frames) == 2
    assert all(frame.shape == (24, 32, 3) for frame in frames)
    plain = gym.make("BubbleRob-v0", render_mode="rgb_array", render_width=32, render_height=24)
    plain.reset(seed=4)
    plain.step(np.zeros(2, np.float32))
    np.testing.assert_array_equal(frames[1], plain.render())
    envs.close()


def test_the_old_module_path_still_names_the_cpu_batch():
    from bubblerob_env import vector

    assert vector.BubbleRobVectorEnv is BubbleRobVectorEnv
    assert vector.ARENA_MEMORY == ARENA_MEMORY
