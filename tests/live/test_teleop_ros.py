"""``bubblerob teleop --ros 1`` in a real terminal (tmux) drives a real ``bubblerob node --ros 1``.

The oracle is the node's own ``/odom``, read by a separate rospy client (``ros_client.py odom``);
see ``tests/teleop_terminal.py`` for the key sequence and what it must do.
"""

from __future__ import annotations

import shlex
import shutil
import subprocess
import sys
from typing import Any

import pytest
from live_helpers import requires_ros
from teleop_terminal import check_drive, drive_in_tmux

pytestmark = [
    requires_ros,
    pytest.mark.skipif(shutil.which("tmux") is None, reason="needs tmux"),
]


def test_teleop_drives_a_ros1_node(master, start_node):
    node = start_node(
        "--seed", "0", "--env-kwargs", '{"num_obstacles": [0, 0], "start_pose": [0, 0, 1.5708]}',
        "--namespace", "tele",
    )  # fmt: skip
    ros = {k: v for k, v in master.venv_env.items() if k.startswith("ROS_")}
    env = " ".join(f"{k}={shlex.quote(v)}" for k, v in ros.items())
    command = (
        f"env -u ROS_NAMESPACE {env} {shlex.quote(sys.executable)} -m bubblerob_cli "
        "teleop --ros 1 --namespace tele --max-seconds 90"
    )
    result = drive_in_tmux(command, f"bubblerob-teleop-ros1-{id(node)}", lambda: odom(master))
    assert node.alive(), node.output
    check_drive(result)
    still = result["still"]
    print(
        f"keys w w w, until odom y >= 0.4, Space, q -> odom x={still['x']:.4f} "
        f"y={still['y']:.4f} yaw={still['yaw']:.4f}; {result['text'].strip().splitlines()[-1]}"
    )


def odom(master: Any) -> dict[str, Any]:
    return dict(master.client("--ns", "/tele", "odom"))


def test_teleop_without_a_master_is_one_line(master):
    from live_helpers import free_port

    env = {**master.venv_env, "ROS_MASTER_URI": f"http://127.0.0.1:{free_port()}/"}
    result = subprocess.run(
        [sys.executable, "-m", "bubblerob_cli", "teleop", "--ros", "1"],
        env=env, capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert result.returncode == 2, result.stderr
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    assert lines[0].startswith("bubblerob teleop: no ROS master reachable"), lines[0]


def test_teleop_ros_refuses_local_options_in_one_line():
    result = subprocess.run(
        [sys.executable, "-m", "bubblerob_cli", "teleop", "--ros", "1", "--record", "x"],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert result.returncode == 2 and len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert "--record" in result.stderr and "bubblerob node" in result.stderr
