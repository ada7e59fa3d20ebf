"""Helpers for the live ROS 2 tests (imported as a plain module: tests/live2 is on sys.path).

The node and the probe are subprocesses of ``.venv-ros2``'s python: ROS 1 and ROS 2 message
packages share module names, so rclpy lives in a virtualenv of its own (README's set-up makes it).
Every process gets ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` and this test session's own
``ROS_DOMAIN_ID``: no discovery traffic leaves the loopback, and other sessions stay apart.
"""

from __future__ import annotations

import os
import subprocess
from pathlib import Path
from typing import Any

import pytest
from live_support import ClientServer, NodeProcess, wait_for

__all__ = [
    "DOMAIN_ID",
    "ROOT",
    "ROS2_PYTHON",
    "Node",
    "client",
    "require_ros2",
    "ros2_env",
    "wait_for",
]

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
CLIENT = HERE / "ros2_client.py"
ROS2_PYTHON = Path(os.environ.get("BUBBLEROB_ROS2_PYTHON", ROOT / ".venv-ros2" / "bin" / "python"))
SETUP = (
    "python3 -m venv .venv-ros2 && .venv-ros2/bin/pip install -e '.[ros2]' && "
    ".venv-ros2/bin/python -m bubblerob_env.ros.live.ros2_msgs"
)
DOMAIN_ID = str(1 + os.getpid() % 100)
"""This session's DDS domain (1..100): concurrent test sessions on one machine stay apart."""


def missing_ros2() -> str | None:
    """Why the ROS 2 tests cannot run here, or ``None``."""
    if not ROS2_PYTHON.exists():
        return f"no {ROS2_PYTHON} (README's set-up makes it: {SETUP})"
    probe = subprocess.run(
        [str(ROS2_PYTHON), "-c", "import rclpy, tf2_msgs.msg, nav_msgs.msg, bubblerob_env"],
        env=ros2_env(),
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    if probe.returncode != 0:
        return f"{ROS2_PYTHON} lacks rclpy, tf2_msgs or bubblerob ({probe.stderr[-300:]}): {SETUP}"
    return None


def ros2_env(**extra: str) -> dict[str, str]:
    """The environment of every ROS 2 process of these tests."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("ROS_", "_ROS_", "RMW_"))}
    for key in ("PYTHONPATH", "VIRTUAL_ENV", "AMENT_PREFIX_PATH", "LD_LIBRARY_PATH"):
        env.pop(key, None)
    env.update(
        ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
        ROS_DOMAIN_ID=DOMAIN_ID,
        PYTHONUNBUFFERED="1",
        RCUTILS_LOGGING_BUFFERED_STREAM="0",
    )
    env.update(extra)
    return env


_SKIP: list[str | None] = []


def skip_reason() -> str | None:
    if not _SKIP:
        _SKIP.append(missing_ros2())
    return _SKIP[0]


def require_ros2() -> None:
    reason = skip_reason()
    if reason is not None:
        pytest.skip(reason)


CLIENTS = ClientServer([str(ROS2_PYTHON), str(CLIENT)], ros2_env())
"""The session's one ``ros2_client.py`` process; it ends with its input, at the session's end."""


def client(*args: str, timeout: float = 60.0) -> Any:
    """Run a ``ros2_client.py`` subcommand (in the session's client process); its result."""
    return CLIENTS.call(args, timeout)


class Node(NodeProcess):
    """A ``bubblerob node --ros 2`` subprocess; stdout/stderr collected by threads."""

    def __init__(self, args: list[str], ready_timeout: float = 90.0) -> None:
        command = [str(ROS2_PYTHON), "-m", "bubblerob_cli", "node", "--ros", "2"]
        super().__init__(command, ros2_env(), args, ready_timeout, cwd=ROOT)
