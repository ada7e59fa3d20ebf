"""Helpers for the live-node tests (imported as a plain module: tests/live is on sys.path).

Everything runs as subprocesses with ``ROS_MASTER_URI``/``ROS_HOSTNAME`` set to that master; each
fixture stops what it started, also when a test fails. Tests are skipped (naming the Debian
packages) only where Debian's ROS 1 tools are missing.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from live_support import ClientServer, NodeProcess, stop, wait_for

from bubblerob_env.ros.live.backend import LiveBackend, Publish, RawCallback

__all__ = [
    "InProcessBackend",
    "Master",
    "Node",
    "SKIP_REASON",
    "free_port",
    "requires_ros",
    "stop",
    "wait_for",
]

HERE = Path(__file__).resolve().parent


class InProcessBackend(LiveBackend):
    """A ROS 1 backend in the test's own process: what the node publishes is kept per topic
    (``sent``), its subscriptions are handed to the test (``callbacks``), its log is ``lines``."""

    ros_version = 1
    distro = "noetic"

    def __init__(self) -> None:
        self.sent: dict[str, list[bytes]] = {}
        self.callbacks: dict[str, RawCallback] = {}
        self.lines: list[str] = []

    def advertise(self, topic: str, msgtype: str, latched: bool = False) -> Publish:
        return lambda data: self.sent.setdefault(topic, []).append(bytes(data))

    def subscribe(self, topic: str, msgtype: str, callback: RawCallback) -> None:
        self.callbacks[topic] = callback

    def ok(self) -> bool:
        return True

    def shutdown(self, reason: str = "done") -> None:
        pass

    def log(self, level: str, text: str) -> None:
        self.lines.append(text)


CLIENT = HERE / "ros_client.py"
DEBIAN_PACKAGES = (
    "python3-rospy python3-rosmaster python3-rostopic python3-rosbag python3-roslaunch "
    "python3-std-msgs python3-geometry-msgs python3-sensor-msgs python3-nav-msgs "
    "python3-tf2-msgs python3-rosgraph-msgs"
)


def missing_ros_tools() -> str | None:
    """Why the live tests cannot run here, or ``None``."""
    for tool in ("rosmaster", "rostopic", "rosbag", "roslaunch"):
        if not Path("/usr/bin", tool).exists():
            return f"/usr/bin/{tool} is missing: apt-get install {DEBIAN_PACKAGES}"
    probe = subprocess.run(
        ["/usr/bin/python3", "-c", "import rospy, std_msgs.msg, geometry_msgs.msg, nav_msgs.msg"],
        env={"PATH": "/usr/bin:/bin", "HOME": "/tmp"},
        capture_output=True,
        text=True,
        check=False,
    )
    if probe.returncode != 0:
        return f"Debian's rospy is not importable: apt-get install {DEBIAN_PACKAGES}"
    return None


SKIP_REASON = missing_ros_tools()
requires_ros = pytest.mark.skipif(SKIP_REASON is not None, reason=SKIP_REASON or "")
"""Module mark: skip where Debian's ROS 1 tools are missing."""


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


class Master:
    """A running ``rosmaster`` and the environments that reach it."""

    def __init__(self, port: int, home: Path) -> None:
        self.uri = f"http://127.0.0.1:{port}/"
        ros = {"ROS_MASTER_URI": self.uri, "ROS_HOSTNAME": "127.0.0.1", "ROS_HOME": str(home)}
        self.debian_env = {"PATH": "/usr/bin:/bin", "HOME": str(home), "LANG": "C.UTF-8", **ros}
        self.venv_env = {**os.environ, **ros, "PYTHONUNBUFFERED": "1"}
        self.venv_env.pop("ROS_NAMESPACE", None)
        self.clients = ClientServer(["/usr/bin/python3", str(CLIENT)], self.debian_env)

    def run(self, args: list[str], timeout: float = 30.0) -> subprocess.CompletedProcess[str]:
        """Run a Debian ROS tool (``rostopic ...``) to completion."""
        return subprocess.run(
            args, env=self.debian_env, capture_output=True, text=True, timeout=timeout, check=False
        )

    def client(self, *args: str, timeout: float = 30.0) -> Any:
        """Run a ``ros_client.py`` subcommand (in the master's one client process); its result."""
        return self.clients.call(args, timeout)

    def popen(self, args: list[str], **kwargs: Any) -> subprocess.Popen[str]:
        """Start a Debian ROS tool in the background."""
        return subprocess.Popen(args, env=self.debian_env, text=True, **kwargs)


class Node(NodeProcess):
    """A ``bubblerob node`` subprocess on ``master``; stdout/stderr collected by threads."""

    def __init__(self, master: Master, args: list[str], ready_timeout: float = 60.0) -> None:
        command = [sys.executable, "-m", "bubblerob_cli", "node"]
        super().__init__(command, master.venv_env, args, ready_timeout)
