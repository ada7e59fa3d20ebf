"""``bubblerob teleop --ros 2`` in a real terminal (tmux) drives a real ``bubblerob node --ros 2``.

Both run with ``.venv-ros2``'s python, DDS on the loopback in this session's domain; the oracle is
the node's ``/odom`` read by an rclpy probe (``ros2_client.py odom``). See
``tests/teleop_terminal.py`` for the key sequence and what it must do.
"""

from __future__ import annotations

import shlex
import shutil
from typing import Any

import pytest
from ros2_helpers import ROS2_PYTHON, client, ros2_env
from teleop_terminal import check_drive, drive_in_tmux

pytestmark = pytest.mark.skipif(shutil.which("tmux") is None, reason="needs tmux")


def test_teleop_drives_a_ros2_node(start_node):
    node = start_node(
        "--seed", "0", "--env-kwargs", '{"num_obstacles": [0, 0], "start_pose": [0, 0, 1.5708]}',
        "--namespace", "tele2",
    )  # fmt: skip
    ros = {k: v for k, v in ros2_env().items() if k.startswith(("ROS_", "RCUTILS_"))}
    unset = " ".join(f"-u {k}" for k in ("VIRTUAL_ENV", "PYTHONPATH", "RMW_IMPLEMENTATION"))
    env = " ".join(f"{k}={shlex.quote(v)}" for k, v in ros.items())
    command = (
        f"env {unset} -u ROS_NAMESPACE {env} {shlex.quote(str(ROS2_PYTHON))} -m bubblerob_cli "
        "teleop --ros 2 --namespace tele2 --max-seconds 90"
    )
    result = drive_in_tmux(command, f"bubblerob-teleop-ros2-{id(node)}", odom)
    assert node.alive(), node.output
    check_drive(result)
    still = result["still"]
    print(
        f"keys w w w, until odom y >= 0.4, Space, q -> odom x={still['x']:.4f} "
        f"y={still['y']:.4f} yaw={still['yaw']:.4f}; {result['text'].strip().splitlines()[-1]}"
    )


def odom() -> dict[str, Any]:
    return dict(client("--ns", "/tele2", "odom"))
