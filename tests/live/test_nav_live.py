"""``bubblerob node --env BubbleRobNav-v0``: a real rospy client sends goals as rviz's 2D Nav Goal.

The node runs in sync mode with ``--policy navigator`` in the empty arena from (0, -1.4). The
client (``nav_client.py``, Debian's rospy) sends a goal in a frame the node does not know, one
outside the arena and one in the wall (each refused with one warning, the node going on), then
(1.0, -0.5) in ``odom`` (which is ``map`` without ``--localize``), and triggers steps until
``/goal_reached``. The oracles are geometry: the plan in the empty arena is the straight segment
from the start to the goal, and ``/odom`` comes within ``goal_radius`` of the goal.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest
from live_helpers import requires_ros

pytestmark = requires_ros

CLIENT = Path(__file__).resolve().parent / "nav_client.py"
START, GOAL, GOAL_RADIUS = (0.0, -1.4), (1.0, -0.5), 0.2
NODE_ARGS = (
    "--env", "BubbleRobNav-v0", "--sync", "--policy", "navigator", "--watchdog", "0",
    "--env-kwargs", json.dumps({"num_obstacles": [0, 0], "start_pose": [*START, 0.0]}),
)  # fmt: skip


@pytest.fixture(scope="module")
def navigated(master, start_node):
    node = start_node(*NODE_ARGS)
    command = [
        "/usr/bin/python3", str(CLIENT), "--goal", *map(str, GOAL), "--frame", "odom",
        "--bad-goals",
    ]  # fmt: skip
    done = subprocess.run(
        command, env=master.debian_env, capture_output=True, text=True, timeout=90, check=False
    )
    assert done.returncode == 0, done.stderr + node.output
    return node, json.loads(done.stdout.splitlines()[-1])


def test_a_goal_from_rospy_is_planned_published_and_reached(navigated):
    node, got = navigated
    assert node.alive(), node.output
    # The episode's drawn goal first, then the client's (in map), then the next episode's.
    assert got["goals"][1] == ["map", *GOAL]
    frame, plan = got["plans"][1]
    assert frame == "map" and plan == [list(START), list(GOAL)]  # line of sight: one segment
    assert got["reached"][:2] == [False, False] and got["reached"][2] is True
    closest = min(math.dist(p, GOAL) for p in got["odom"])
    assert closest <= GOAL_RADIUS + 1e-9, closest
    fastest = (math.dist(START, GOAL) - GOAL_RADIUS) / 0.4 / 0.05  # 0.4 m/s, 50 ms steps
    assert fastest < got["steps"] < 3 * fastest, got["steps"]
    assert "goal (1.000, -0.500) reached at" in node.output


def test_bad_goals_get_one_line_each_and_the_node_goes_on(navigated):
    node, _ = navigated
    lines = [line for line in node.output.splitlines() if "/move_base_simple/goal" in line]
    assert len(lines) == 3, node.output
    assert "frame_id 'base_link'" in lines[0] and "'map' or 'odom'" in lines[0]
    assert "goal (25.0, 0.0) is outside the arena" in lines[1] and "(-2, 2)" in lines[1]
    assert "goal (1.95, 0.0) is inside an obstacle or a wall" in lines[2]
    assert node.alive()


@pytest.fixture(scope="module")
def localised(master, start_node):
    """``--localize``: an /initialpose 0.3 m off the truth, then a goal in ``odom``, no steps."""
    node = start_node(*NODE_ARGS, "--localize")
    command = [
        "/usr/bin/python3", str(CLIENT), "--goal", *map(str, GOAL), "--frame", "odom",
        "--initial", str(START[0] + 0.3), str(START[1]), "--max-steps", "0",
    ]  # fmt: skip
    done = subprocess.run(
        command, env=master.debian_env, capture_output=True, text=True, timeout=90, check=False
    )
    assert done.returncode == 0, done.stderr + node.output
    return node, json.loads(done.stdout.splitlines()[-1])


def test_with_localize_the_goal_and_plan_follow_the_estimate_not_the_truth(localised):
    node, got = localised
    x, y, qz, qw = got["estimates"]["amcl"]
    assert math.dist((x, y), (START[0] + 0.3, START[1])) < 0.05  # the initial pose, not the truth
    # The goal given in odom is moved into map by the node's own map -> odom (the estimate's).
    tx, ty, tz, tw = got["estimates"]["map_to_odom"]
    yaw = 2 * math.atan2(tz, tw)
    gx = tx + math.cos(yaw) * GOAL[0] - math.sin(yaw) * GOAL[1]
    gy = ty + math.sin(yaw) * GOAL[0] + math.cos(yaw) * GOAL[1]
    frame, goal_x, goal_y = got["goals"][1]
    assert frame == "map" and (goal_x, goal_y) == pytest.approx((gx, gy), abs=1e-9)
    assert math.dist((goal_x, goal_y), GOAL) > 0.2  # not the truth's odom (= map) either
    # The path starts where the robot believes it is.
    _, plan = got["plans"][1]
    assert plan[0] == pytest.approx([x, y], abs=1e-9) and plan[-1] == [goal_x, goal_y]
    assert math.dist(plan[0], START) > 0.25
    assert node.alive()


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (("--policy", "navigator"), "policy 'navigator' drives to a goal: it needs a Nav env"),
        (
            ("--env", "BubbleRobNav-v0", "--policy", "pursuit", "--localize"),
            "--policy pursuit reads the ground truth",
        ),
    ],
)
def test_a_policy_that_cannot_drive_the_node_is_one_line_before_ros_starts(args, says):
    done = subprocess.run(
        [sys.executable, "-m", "bubblerob_cli", "node", *args, "--steps", "1"],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
        env={**os.environ, "ROS_MASTER_URI": "http://127.0.0.1:1/"},
    )
    assert done.returncode == 2, done.stdout + done.stderr
    (line,) = done.stderr.strip().splitlines()
    assert line.startswith("bubblerob node: --policy ") and says in line, line
