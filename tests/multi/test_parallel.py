"""The PettingZoo env of several robots: PettingZoo's own tests, one robot = BubbleRob-v0, input."""

from __future__ import annotations

import math
import pickle
import re
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("pettingzoo")
from pettingzoo.test import parallel_api_test, parallel_seed_test  # noqa: E402

import bubblerob_env  # noqa: E402


def test_pettingzoo_api_and_seed_tests_pass() -> None:
    parallel_api_test(
        bubblerob_env.parallel_env(num_robots=3, max_episode_steps=60, laser_num_rays=36),
        num_cycles=80,
    )
    parallel_seed_test(
        lambda: bubblerob_env.parallel_env(
            num_robots=3, max_episode_steps=60, laser_num_rays=36, laser_noise_std=0.01
        ),
        num_cycles=60,
    )


def _same(a: object, b: object) -> bool:
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    return np.asarray(a).tobytes() == np.asarray(b).tobytes()


@pytest.mark.parametrize(
    "kwargs",
    [{}, {"laser_noise_std": 0.01, "odometry_noise": 0.05, "laser_backend": "mujoco"}],
)
def test_one_robot_is_bubblerob_v0_bit_for_bit(kwargs: dict[str, Any]) -> None:
    """Observations, rewards, flags and every info value, across episode boundaries."""
    single = gym.make("BubbleRob-v0", max_episode_steps=120, **kwargs)
    multi = bubblerob_env.parallel_env(num_robots=1, max_episode_steps=120, **kwargs)
    (agent,) = multi.possible_agents
    actions = np.random.default_rng(0).uniform(-0.3, 1, (300, 2)).astype(np.float32)
    obs, info = single.reset(seed=7)
    multi_obs, multi_info = multi.reset(seed=7)
    episodes, ends = 1, set()
    for action in actions:
        assert _same(obs, multi_obs[agent]) and _same(info, multi_info[agent])
        obs, reward, terminated, truncated, info = single.step(action)
        step = multi.step({agent: action})
        multi_obs, multi_info = step[0], step[4]
        assert (reward, terminated, truncated) == tuple(step[i][agent] for i in (1, 2, 3))
        if terminated or truncated:
            ends.add("terminated" if terminated else "truncated")
            obs, info = single.reset()
            multi_obs, multi_info = multi.reset()
            episodes += 1
    assert ends == {"terminated", "truncated"}  # both kinds of episode end were crossed


def test_circle_scenario_faces_the_centre() -> None:
    env = bubblerob_env.parallel_env(num_robots=6, scenario="circle", num_obstacles=(0, 0))
    _, infos = env.reset(seed=1)
    radii = [math.hypot(info["x"], info["y"]) for info in infos.values()]
    assert max(radii) - min(radii) < 1e-9
    for info in infos.values():
        towards = math.atan2(-info["y"], -info["x"])
        assert abs(math.remainder(info["yaw"] - towards, 2 * math.pi)) < 1e-6


def test_random_starts_are_free_and_seeded() -> None:
    env = bubblerob_env.parallel_env(num_robots=8)
    for seed in range(5):
        _, infos = env.reset(seed=seed)
        # mj_forward ran at reset: every contact is with the floor.
        model, data = env.world.scene.model, env.world.scene.data
        floor = model.geom("floor").id
        assert all(floor in pair for pair in data.contact.geom[: data.ncon].tolist())
        xy = np.array([[info["x"], info["y"]] for info in infos.values()])
        gaps = np.linalg.norm(xy[:, None] - xy[None], axis=-1) + np.eye(8) * 10
        assert gaps.min() >= 2 * 0.11
        again = bubblerob_env.parallel_env(num_robots=8)
        assert all(map(_same, again.reset(seed=seed), env.reset(seed=seed)))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"num_robots": 0}, "num_robots must be an integer >= 1, got 0"),
        ({"num_robots": 200}, "num_robots=200 do not fit in a 4.0 m arena"),
        ({"num_robots": 40, "scenario": "circle"}, "num_robots=40 do not fit on the circle"),
        ({"robot": "roomba"}, "robot must be one of ['bubblerob', 'pioneer_p3dx'], got 'roomba'"),
        ({"scenario": "square"}, "scenario must be one of ['random', 'circle'], got 'square'"),
    ],
)
def test_bad_input_is_one_clear_line(kwargs: dict[str, object], message: str) -> None:
    with pytest.raises(ValueError) as raised:
        bubblerob_env.parallel_env(**kwargs)  # type: ignore[arg-type]
    text = str(raised.value)
    assert message in text and "\n" not in text


def test_readme_example_runs_and_the_robots_meet() -> None:
    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    section = readme.split("## Several robots in one world\n", 1)[1].split("\n## ", 1)[0]
    (block,) = re.findall(r"```python\n(.*?)```", section, flags=re.DOTALL)
    namespace: dict[str, Any] = {}
    exec(block, namespace)
    infos = namespace["infos"]
    assert {info.get("collided_with", "") for info in infos.values()} & set(
        namespace["env"].possible_agents
    )


def test_a_copy_mid_episode_steps_as_the_original() -> None:
    """The kernel reads MuJoCo through addresses: a copy must bind its own data."""
    env = bubblerob_env.parallel_env(num_robots=3, laser_noise_std=0.01, max_episode_steps=50)
    env.reset(seed=4)
    rng = np.random.default_rng(0)
    for _ in range(5):
        env.step({agent: rng.uniform(-1, 1, 2).astype(np.float32) for agent in env.agents})
    twin = pickle.loads(pickle.dumps(env))
    while env.agents:
        actions = {agent: rng.uniform(-1, 1, 2).astype(np.float32) for agent in env.agents}
        assert all(map(_same, env.step(actions), twin.step(actions)))
    assert not twin.agents
