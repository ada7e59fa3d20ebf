"""Bags of a Nav env (issue #37 item 4): its goal and planned path, recorded and replayed exactly.

``BubbleRobNav-v0`` bags carry each episode's goal (``/move_base/current_goal``,
``geometry_msgs/PoseStamped``) and shortest path (``/plan``, ``nav_msgs/Path``), latched, at the
episode's start; replay plans them again and compares them byte for byte. Other envs' bags do not
change: their metadata names neither topic.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from ros_helpers import read_all

import bubblerob_env.tasks.nav as nav_module
from bubblerob_env.ros import RosBagRecorder
from bubblerob_env.ros.messages.topics import NAV_TOPICS, Topics
from bubblerob_env.ros.readback.replay import replay_bag
from bubblerob_env.tasks.goals import NavProblem

START = 1_700_000_000
SEEDS = (1, 2)


def _record(path: Path, fmt: str) -> list[NavProblem]:
    """Two seeded episodes of 12 steps of seeded random wheel commands; each one's problem."""
    problems = []
    with RosBagRecorder(gym.make("BubbleRobNav-v0"), path, format=fmt, start_time=START) as rec:
        rec.action_space.seed(0)
        for seed in SEEDS:
            rec.reset(seed=seed)
            problems.append(rec.unwrapped.problem)
            for _ in range(12):
                rec.step(rec.action_space.sample())
    return problems


@pytest.fixture(scope="module", params=["ros1", "mcap"])
def recorded(request: Any, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[Any]]:
    folder = tmp_path_factory.mktemp(request.param)
    path = folder / ("nav.bag" if request.param == "ros1" else "nav")
    return path, _record(path, request.param)


def test_each_episode_has_its_goal_and_path_latched_at_its_start(recorded):
    path, problems = recorded
    messages = read_all(path)
    episodes = [stamp for stamp, _ in messages["/bubblerob/episode"]]
    goals, plans = messages["/move_base/current_goal"], messages["/plan"]
    assert [s for s, _ in goals] == [s for s, _ in plans] == episodes
    for problem, (_, goal), (_, plan) in zip(problems, goals, plans, strict=True):
        assert goal.header.frame_id == plan.header.frame_id == "map"
        assert (goal.pose.position.x, goal.pose.position.y) == problem.goal
        points = np.array([[p.pose.position.x, p.pose.position.y] for p in plan.poses])
        np.testing.assert_array_equal(points, problem.path)
        assert tuple(points[0]) == problem.start and tuple(points[-1]) == problem.goal
        length = sum(math.dist(a, b) for a, b in zip(points[:-1], points[1:], strict=True))
        assert length == pytest.approx(problem.length, abs=1e-9)
        # Each pose faces along its segment (a global planner's /plan).
        q = plan.poses[0].pose.orientation
        heading = math.atan2(points[1, 1] - points[0, 1], points[1, 0] - points[0, 0])
        assert 2 * math.atan2(q.z, q.w) == pytest.approx(heading, abs=1e-9)


def test_replay_re_plans_the_goal_and_path_byte_for_byte(recorded):
    path, _ = recorded
    report = replay_bag(path)
    assert report.ok, str(report)
    others = dict(report.not_resimulated)
    assert not set(NAV_TOPICS.values()) & set(others), others
    assert report.episodes == len(SEEDS) and report.steps == 12 * len(SEEDS)


def test_replay_reports_a_goal_that_differs(recorded, monkeypatch):
    path, _ = recorded
    draw = nav_module.draw_problem

    def shifted(*args: Any, **kwargs: Any) -> NavProblem | None:
        problem = draw(*args, **kwargs)
        assert problem is not None
        goal = (problem.goal[0] + 1e-6, problem.goal[1])
        return NavProblem(problem.start, goal, problem.path, problem.length, problem.grid)

    monkeypatch.setattr(nav_module, "draw_problem", shifted)
    report = replay_bag(path, max_episodes=1)
    assert report.divergence is not None
    assert report.divergence.topic == "/move_base/current_goal" and report.divergence.step == 0


def test_a_goal_set_between_steps_is_recorded_and_replayed(tmp_path):
    path = tmp_path / "set.bag"
    with RosBagRecorder(gym.make("BubbleRobNav-v0"), path, format="ros1", start_time=START) as rec:
        rec.reset(seed=SEEDS[0])
        drawn = rec.unwrapped.problem
        for _ in range(5):
            rec.step(np.array([0.5, 0.4], dtype=np.float32))
        here = rec.unwrapped.robot_pose[:2]
        goal = tuple((drawn.path[0] + drawn.path[1]) / 2)  # in line of sight: free
        rec.unwrapped.set_goal(goal)
        for _ in range(5):
            rec.step(np.array([0.5, 0.4], dtype=np.float32))
    goals, plans = (read_all(path)[t] for t in ("/move_base/current_goal", "/plan"))
    frames = [stamp for stamp, _ in read_all(path)["/odom"]]
    assert [s for s, _ in goals] == [s for s, _ in plans] == [frames[0], frames[5]]
    second = plans[1][1].poses
    assert (goals[1][1].pose.position.x, goals[1][1].pose.position.y) == goal
    assert (second[0].pose.position.x, second[0].pose.position.y) == here
    assert (second[-1].pose.position.x, second[-1].pose.position.y) == goal
    report = replay_bag(path)
    assert report.ok and report.steps == 10, str(report)


def test_other_envs_bags_name_no_goal_topics(tmp_path):
    assert not set(NAV_TOPICS) & set(Topics().to_dict())
    assert Topics().for_nav().to_dict()["plan"] == "/plan"
    with RosBagRecorder(gym.make("BubbleRob-v0"), tmp_path / "bag", format="mcap") as recorder:
        assert recorder.topics == Topics()
