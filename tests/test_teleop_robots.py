"""``teleop --robots N --robot robot_1``: the keys' twist drives robot_1, a policy the others."""

from __future__ import annotations

import math
import shutil
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest

import bubblerob_env
from bubblerob_cli.teleop.robots import OneRobotView
from policies import load_policy


def test_the_keys_drive_one_robot_and_the_policy_the_others():
    world = bubblerob_env.parallel_env(num_robots=3, action_type="twist", scenario="circle")
    single = gym.make("BubbleRob-v0", action_type="twist")
    view = OneRobotView(world, "robot_1", lambda k: load_policy("reactive", env=single, seed=k))
    _, start = view.reset(seed=2)
    info = start
    for _ in range(10):
        _, _, terminated, _, info = view.step(np.array([0.5, 0.0], dtype=np.float32))
        assert not terminated
    heading = start["yaw"]
    moved = (info["x"] - start["x"], info["y"] - start["y"])
    along = moved[0] * math.cos(heading) + moved[1] * math.sin(heading)
    assert along > 0.05 and abs(info["yaw"] - heading) < 0.05  # straight ahead, as the keys say
    others = [a for a in world.possible_agents if a != view.agent]
    assert view.agent == "bubblerob_1" and view.policy_driven == others
    with pytest.raises(ValueError, match="robot_0, robot_1, robot_2"):
        OneRobotView(world, "robot_5", lambda k: None)
    view.close()
    single.close()


def test_teleop_robots_needs_a_terminal_and_a_known_robot():
    command = [sys.executable, "-m", "bubblerob_cli", "teleop", "--robots", "2"]
    wrong = subprocess.run(
        [*command, "--robot", "robot_4"], capture_output=True, text=True, timeout=60
    )
    assert wrong.returncode == 2 and "robot_4" in wrong.stderr and "robot_1" in wrong.stderr
    if shutil.which("tmux") is None:
        return
    piped = subprocess.run(command, capture_output=True, text=True, timeout=60, input="")
    assert piped.returncode == 2 and "terminal" in piped.stderr
