"""``bubblerob node --ros 2 --env BubbleRobNav-v0``: a real rclpy client's goal is reached.

As tests/live/test_nav_live.py over ROS 2 (Jazzy): sync mode, ``--policy navigator``, the empty
arena from (0, -1.4); a goal in ``base_link`` is refused with one warning, (1.0, -0.5) in
``odom`` is planned (a straight segment from the start: the oracle), published on the
transient-local ``/move_base/current_goal`` and ``/plan``, and reached: ``/goal_reached`` True,
``/odom`` within ``goal_radius``.
"""

from __future__ import annotations

import json
import math
import subprocess

import pytest
from ros2_helpers import HERE, ROS2_PYTHON, ros2_env

CLIENT = HERE / "ros2_nav_client.py"
START, GOAL, GOAL_RADIUS = (0.0, -1.4), (1.0, -0.5), 0.2
NODE_ARGS = (
    "--env", "BubbleRobNav-v0", "--sync", "--policy", "navigator", "--watchdog", "0",
    "--env-kwargs", json.dumps({"num_obstacles": [0, 0], "start_pose": [*START, 0.0]}),
)  # fmt: skip


@pytest.fixture(scope="module")
def navigated(start_node):
    node = start_node(*NODE_ARGS)
    command = [str(ROS2_PYTHON), str(CLIENT), "--goal", *map(str, GOAL), "--frame", "odom"]
    done = subprocess.run(
        command, env=ros2_env(), capture_output=True, text=True, timeout=120, check=False
    )
    assert done.returncode == 0, done.stdout + done.stderr + node.output
    return node, json.loads(done.stdout.splitlines()[-1])


def test_rclpy_goal_is_planned_published_and_reached(navigated):
    node, got = navigated
    assert got["goals"][1] == ["map", *GOAL]
    assert got["plans"][1] == ["map", [list(START), list(GOAL)]]
    reached = got["reached"]  # False with each goal (as seen), True on arrival
    assert True in reached and not any(reached[: reached.index(True)]), reached
    closest = min(math.dist(p, GOAL) for p in got["odom"])
    assert closest <= GOAL_RADIUS + 1e-9, closest
    assert "goal (1.000, -0.500) reached at" in node.output


def test_a_goal_in_an_unknown_frame_is_one_line_and_the_node_goes_on(navigated):
    node, _ = navigated
    lines = [line for line in node.output.splitlines() if "/move_base_simple/goal" in line]
    assert len(lines) == 1 and "frame_id 'base_link'" in lines[0], node.output
    assert "'map' or 'odom'" in lines[0]
    assert node.alive()
