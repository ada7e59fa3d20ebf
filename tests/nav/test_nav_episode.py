"""How a Nav episode ends and is scored: arrival, contact, the reward's parts, bad arguments."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import bubblerob_env  # noqa: F401  (registers the ids)

EMPTY = {"num_obstacles": (0, 0), "action_type": "wheels"}


def _drive_straight(env, goal, start_pose):
    """Full speed ahead until the episode ends; every step's (info, terminated, truncated)."""
    env.reset(seed=0, options={"goal": goal})
    steps = []
    for _ in range(1000):
        _, reward, terminated, truncated, info = env.step(np.array([1.0, 1.0], np.float32))
        steps.append((info, reward, terminated, truncated))
        if terminated or truncated:
            return steps
    raise AssertionError("the episode did not end")


def test_arrival_within_goal_radius_terminates_with_success():
    start = (-1.0, 0.0, 0.0)
    env = gym.make("BubbleRobNav-v0", start_pose=start, **EMPTY)
    goal = (0.5, 0.0)
    steps = _drive_straight(env, goal, start)
    info, reward, terminated, truncated = steps[-1]
    distance = lambda i: math.hypot(i["x"] - goal[0], i["y"] - goal[1])  # noqa: E731
    assert terminated and not truncated and info["is_success"]
    assert distance(info) <= 0.2 < distance(steps[-2][0])  # the first step inside the radius
    assert not any(i["is_success"] for i, *_ in steps[:-1])
    assert info["reward_arrival"] == 100.0 and info["reward_collision"] == 0.0
    # Progress is the straight distance's decrease, in reward per metre.
    before = distance(steps[-2][0])
    assert info["reward_progress"] == pytest.approx(10.0 * (before - distance(info)))
    parts = [info[k] for k in ("reward_progress", "reward_arrival", "reward_collision")]
    assert reward == pytest.approx(sum(parts) + info["reward_time"])
    assert "reward_forward" not in info  # the wandering task's parts are not this reward's
    # Driven distance is what the robot moved; the shortest path is the straight line.
    assert info["distance_driven"] == pytest.approx(math.hypot(info["x"] + 1.0, info["y"]), 1e-3)
    assert info["shortest_path_length"] == pytest.approx(1.5)


def test_a_contact_before_the_goal_ends_the_episode_as_a_failure():
    # Facing the east wall, 0.5 m away; the goal is behind the robot.
    env = gym.make("BubbleRobNav-v0", start_pose=(1.5, 0.0, 0.0), **EMPTY)
    info, reward, terminated, truncated = _drive_straight(env, (-1.0, 0.0), None)[-1]
    assert terminated and not truncated
    assert info["collision"] and not info["is_success"]
    assert info["reward_collision"] == -100.0 and info["reward_arrival"] == 0.0
    assert info["x"] > 1.5  # it hit the wall ahead, not the goal


def test_observation_has_the_goal_in_the_robots_frame_in_dict_and_flat_mode():
    dict_env = gym.make("BubbleRobNav-v0")
    flat_env = gym.make("BubbleRobNav-v0", obs_mode="flat")
    check_env(dict_env.unwrapped, skip_render_check=True)
    check_env(flat_env.unwrapped, skip_render_check=True)
    obs, info = dict_env.reset(seed=7)
    flat, _ = flat_env.reset(seed=7)
    x, y, yaw = dict_env.unwrapped.layout.start_pose
    gx, gy = info["goal"]
    bearing = math.atan2(gy - y, gx - x) - yaw
    bearing = math.atan2(math.sin(bearing), math.cos(bearing))
    assert obs["goal"] == pytest.approx([math.hypot(gx - x, gy - y), bearing], abs=1e-5)
    layout = flat_env.unwrapped.observation_layout
    assert flat[layout["goal"]] == pytest.approx(obs["goal"])
    assert flat[layout["laser"]] == pytest.approx(obs["laser"])


@pytest.mark.parametrize("value", [0, -0.1, float("nan"), "0.2"])
def test_goal_radius_must_be_positive(value):
    with pytest.raises(ValueError) as error:
        gym.make("BubbleRobNav-v0", goal_radius=value)
    message = str(error.value)
    assert "\n" not in message
    assert message.startswith("goal_radius must be a finite number of metres > 0, got")


@pytest.mark.parametrize(("goal", "says"), [
    ((2.5, 0.0), "outside the arena"),
    ((1.95, 0.0), "inside an obstacle or a wall"),
    (("a", 1), "two numbers"),
])  # fmt: skip
def test_a_given_goal_outside_the_arena_or_in_a_wall_is_refused(goal, says):
    env = gym.make("BubbleRobNav-v0", **EMPTY)
    with pytest.raises(ValueError, match=says):
        env.reset(seed=0, options={"goal": goal})


def test_an_unknown_kwarg_lists_the_tasks_arguments_too():
    with pytest.raises(TypeError, match="unexpected keyword argument 'goal_radiu'") as error:
        gym.make("BubbleRobNav-v0", goal_radiu=0.2)
    assert "goal_radius, min_goal_distance" in str(error.value)
