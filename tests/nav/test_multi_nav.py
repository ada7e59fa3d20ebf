"""Several robots with goals: ``parallel_env(task="nav")`` (issue #37, item 1)."""

from __future__ import annotations

import math
from collections import deque
from typing import Any

import numpy as np
import pytest

pytest.importorskip("pettingzoo")
from pettingzoo.test import parallel_api_test, parallel_seed_test  # noqa: E402

import bubblerob_env  # noqa: E402
from bubblerob_env.arena import ArenaLayout  # noqa: E402

RADIUS, CLEARANCE = 0.11, 0.25  # BubbleRob's radius, the default start_clearance
FAST: dict[str, Any] = {"laser_num_rays": 36}


def test_pettingzoo_api_and_seed_tests_pass_with_goals_dict_and_flat() -> None:
    for obs_mode in ("dict", "flat"):
        env = bubblerob_env.parallel_env(
            num_robots=3, task="nav", max_episode_steps=60, obs_mode=obs_mode, **FAST
        )
        parallel_api_test(env, num_cycles=80)
    parallel_seed_test(
        lambda: bubblerob_env.parallel_env(
            num_robots=3, task="nav", max_episode_steps=40, laser_noise_std=0.01, **FAST
        ),
        num_cycles=40,
    )


def test_circle_goals_are_the_antipodes_and_twenty_robots_get_room_to_pass() -> None:
    env = bubblerob_env.parallel_env(num_robots=5, scenario="circle", task="nav", **FAST)
    observations, infos = env.reset(seed=4)
    for agent, info in infos.items():
        start = np.array([info["x"], info["y"]])
        np.testing.assert_allclose(info["goal"], -start, atol=1e-12)
        assert info["shortest_path_length"] >= 2 * np.hypot(*start) - 1e-9
        assert math.isclose(observations[agent]["goal"][0], 2 * np.hypot(*start), rel_tol=1e-6)
        assert abs(observations[agent]["goal"][1]) < 1e-5  # every robot faces its goal
    # 20 robots: the arena grows so that each robot has 4r + c of the circle (the default
    # 4 m arena holds them, but with neighbours closer than a robot's width apart).
    env = bubblerob_env.parallel_env(num_robots=20, scenario="circle", task="nav", **FAST)
    _, infos = env.reset(seed=0)
    circle = 20 * (4 * RADIUS + CLEARANCE) / (2 * math.pi)
    assert env.config.arena_size == math.ceil(10 * 2 * (circle + RADIUS + CLEARANCE)) / 10
    starts = np.array([[info["x"], info["y"]] for info in infos.values()])
    neighbours = np.hypot(*(starts - np.roll(starts, 1, axis=0)).T)
    assert neighbours.min() - 2 * RADIUS >= 2 * RADIUS + CLEARANCE  # a robot fits between
    wander = bubblerob_env.parallel_env(num_robots=20, scenario="circle", **FAST)
    assert wander.config.arena_size == 4.0  # task="wander" is as it was


def _free_cells(layout: ArenaLayout, arena: float, cell: float) -> Any:
    """Cells whose centre keeps the robot's radius from walls and obstacles (this test's own)."""
    n = round(arena / cell)
    centres = -arena / 2 + (np.arange(n) + 0.5) * cell
    x, y = np.meshgrid(centres, centres)  # rows: y, columns: x
    free = (np.abs(x) <= arena / 2 - RADIUS) & (np.abs(y) <= arena / 2 - RADIUS)
    for o in layout.obstacles:
        dx, dy = x - o.x, y - o.y
        if o.kind == "cylinder":
            gap = np.hypot(dx, dy) - o.size[0]
        else:
            along = np.abs(dx * math.cos(o.yaw) + dy * math.sin(o.yaw)) - o.size[0]
            across = np.abs(-dx * math.sin(o.yaw) + dy * math.cos(o.yaw)) - o.size[1]
            gap = np.hypot(np.maximum(along, 0), np.maximum(across, 0))
        free &= gap >= RADIUS
    return free


def _reachable(free: np.ndarray, start: tuple[int, int]) -> np.ndarray:
    """Breadth-first search, 4-connected (what 8-connected without corner cuts reaches)."""
    seen = np.zeros_like(free)
    seen[start] = free[start]
    queue = deque([start] if free[start] else [])
    while queue:
        r, c = queue.popleft()
        for nr, nc in ((r + 1, c), (r - 1, c), (r, c + 1), (r, c - 1)):
            inside = 0 <= nr < free.shape[0] and 0 <= nc < free.shape[1]
            if inside and free[nr, nc] and not seen[nr, nc]:
                seen[nr, nc] = True
                queue.append((nr, nc))
    return seen


def test_random_goals_are_reachable_far_from_their_start_and_apart() -> None:
    env = bubblerob_env.parallel_env(num_robots=6, task="nav", num_obstacles=(8, 12), **FAST)
    cell, arena = 0.05, env.config.arena_size
    for seed in range(3):
        _, infos = env.reset(seed=seed)
        free = _free_cells(env.layout, arena, cell)
        goals = np.array([info["goal"] for info in infos.values()])
        for info, goal in zip(infos.values(), goals, strict=True):
            start = (info["x"], info["y"])
            assert math.dist(start, goal) >= 1.0
            to_cell = [int((v + arena / 2) // cell) for v in (start[1], start[0])]
            here = _reachable(free, (to_cell[0], to_cell[1]))
            assert here[int((goal[1] + arena / 2) // cell), int((goal[0] + arena / 2) // cell)]
            assert info["shortest_path_length"] >= math.dist(start, goal) - 1e-9
        gaps = np.hypot(*(goals[:, None] - goals[None]).transpose(2, 0, 1))
        assert gaps[~np.eye(len(goals), dtype=bool)].min() >= 2 * RADIUS + CLEARANCE


def test_arrival_ends_that_robot_which_stays_stopped_while_the_other_drives_on() -> None:
    env = bubblerob_env.parallel_env(num_robots=2, task="nav", num_obstacles=(0, 0), **FAST)
    first, second = env.possible_agents
    options = {
        "start_poses": [(-1.5, -1.0, 0.0), (-1.5, 1.0, 0.0)],
        "goals": [(-0.9, -1.0), (1.5, 1.0)],
    }
    env.reset(seed=0, options=options)
    ahead = np.ones(2, dtype=np.float32)
    for _ in range(100):
        actions = {agent: ahead for agent in env.agents}
        _, rewards, terminations, _, infos = env.step(actions)
        if first not in env.agents:
            break
    assert terminations[first] and infos[first]["is_success"]
    assert infos[first]["goal_distance"] <= 0.2 and infos[first]["reward_arrival"] == 100.0
    assert rewards[first] == pytest.approx(
        sum(infos[first][f"reward_{p}"] for p in ("progress", "arrival", "collision", "time"))
    )
    assert "reward_forward" not in infos[first]
    assert not terminations[second] and not infos[second]["is_success"]
    assert env.agents == [second]
    qpos, root = env.world.scene.data.qpos, env.world.robots[0].root_qpos
    x_before = infos[second]["x"]
    for _ in range(10):  # the arrived robot's wheels are stopped: it coasts to rest
        _, _, _, _, infos = env.step({second: ahead})
    parked = qpos[root : root + 2].copy()
    for _ in range(10):
        _, _, _, _, infos = env.step({second: ahead})
    assert infos[second]["x"] > x_before + 0.2  # the other drives on
    np.testing.assert_allclose(qpos[root : root + 2], parked, atol=1e-4)  # at rest
    assert math.dist(parked, (-0.9, -1.0)) <= 0.2  # at its goal


def test_a_head_on_touch_ends_both_robots_as_failures_naming_the_other() -> None:
    env = bubblerob_env.parallel_env(num_robots=2, task="nav", num_obstacles=(0, 0), **FAST)
    first, second = env.possible_agents
    options = {
        "start_poses": [(-0.4, 0.0, 0.0), (0.4, 0.0, math.pi)],
        "goals": [(1.5, 0.0), (-1.5, 0.0)],
    }
    env.reset(seed=0, options=options)
    while env.agents:
        _, _, terminations, _, infos = env.step({a: np.ones(2, np.float32) for a in env.agents})
    assert terminations == {first: True, second: True}
    assert (infos[first]["collided_with"], infos[second]["collided_with"]) == (second, first)
    assert not infos[first]["is_success"] and infos[first]["reward_collision"] < 0


@pytest.mark.parametrize(
    ("kwargs", "options", "line"),
    [
        ({"task": "fly"}, None, "task must be one of ['wander', 'nav'], got 'fly'"),
        ({"task": "nav", "goal_radius": 0}, None, "goal_radius must be a finite number of metres"),
        ({"goal_radius": 0.3}, None, "['goal_radius'] are arguments of task='nav', not 'wander'"),
        ({"task": "nav"}, {"goals": [(0.0, 0.0)]}, "options['goals'] must be 2 (x, y) goals"),
        ({"task": "nav"}, {"goals": [(0.0, 0.0), (5.0, 0.0)]}, "is outside the arena"),
        ({}, {"goals": [(0.0, 0.0), (1.0, 0.0)]}, "options['goals'] needs task='nav'"),
    ],
)  # fmt: skip
def test_bad_input_is_one_line(kwargs: dict[str, Any], options: Any, line: str) -> None:
    with pytest.raises(ValueError) as error:
        env = bubblerob_env.parallel_env(num_robots=2, **kwargs, **FAST)
        env.reset(seed=0, options=options)
    assert line in str(error.value) and "\n" not in str(error.value)
