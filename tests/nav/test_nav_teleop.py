"""``bubblerob teleop --env BubbleRobNav-v0`` shows the goal: distance and bearing (issue #37).

The robot stands still (no key pressed), so the status line must show the goal as the env's
first observation has it, for the same seed.
"""

from __future__ import annotations

import math
import shutil
import subprocess
import sys

import gymnasium as gym
import pytest
from teleop_terminal import screen_until, tmux

pytestmark = pytest.mark.skipif(shutil.which("tmux") is None, reason="needs tmux")


def test_teleop_status_line_has_the_goals_distance_and_bearing(tmp_path):
    obs, _ = gym.make("BubbleRobNav-v0", action_type="twist").reset(seed=4)
    distance, bearing = (float(v) for v in obs["goal"])
    expected = f"goal {distance:.2f} m at {math.degrees(bearing):+.0f} deg"
    session = f"bubblerob-nav-teleop-{id(tmp_path)}"
    command = f"{sys.executable} -m bubblerob_cli teleop --env BubbleRobNav-v0 --seed 4"
    tmux("new-session", "-d", "-s", session, "-x", "200", "-y", "20",
         f"{command} --max-seconds 30; sleep 30")  # fmt: skip
    try:
        screen, match = screen_until(session, r"goal \S+ m at \S+ deg", 30)
    finally:
        subprocess.run(["tmux", "kill-session", "-t", session], check=False, timeout=30)
    assert match, screen
    assert expected in screen, (expected, screen)
