"""Helpers shared by the ROS tests (imported as a plain module: tests/ros is on sys.path)."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from rosbags.highlevel import AnyReader

from bubblerob_env.ros.readback.summary import bag_root

FORMAT_CASES = [
    ("mcap", "zstd"),
    ("mcap", "none"),
    ("sqlite3", "none"),
    ("ros1", "none"),
    ("ros1", "bz2"),
    ("ros1", "lz4"),
]
"""Every format and compression offered."""

FORWARD = np.array([0.6, 0.5], dtype=np.float32)


def drive(env: gym.Env[Any, Any], episodes: int, steps: int, seed: int | None = 0) -> int:
    """Run ``episodes`` episodes of at most ``steps`` steps with a fixed action; steps taken."""
    taken = 0
    for episode in range(episodes):
        env.reset(seed=None if seed is None else seed + episode)
        for _ in range(steps):
            _, _, terminated, truncated, _ = env.step(FORWARD)
            taken += 1
            if terminated or truncated:
                break
    return taken


def read_all(path: Path) -> dict[str, list[tuple[int, Any]]]:
    """Every message of a bag, decoded with rosbags' AnyReader, per topic in time order."""
    messages: dict[str, list[tuple[int, Any]]] = {}
    with AnyReader([bag_root(path)]) as reader:
        for connection, stamp, raw in reader.messages():
            decoded = reader.deserialize(raw, connection.msgtype)
            messages.setdefault(connection.topic, []).append((stamp, decoded))
    return messages


def debian_env() -> dict[str, str]:
    """A clean environment for Debian's ROS tools (no venv, no PYTHONPATH)."""
    return {"PATH": "/usr/bin:/bin", "HOME": os.environ.get("HOME", "/tmp"), "LANG": "C.UTF-8"}


def run_debian(*command: str) -> subprocess.CompletedProcess[str]:
    """Run one of Debian's ROS tools (or /usr/bin/python3) in :func:`debian_env`; not checked."""
    return subprocess.run(
        list(command), env=debian_env(), capture_output=True, text=True, check=False, timeout=120
    )


DEBIAN_MSG_PACKAGES = {
    "std_msgs": "python3-std-msgs",
    "geometry_msgs": "python3-geometry-msgs",
    "sensor_msgs": "python3-sensor-msgs",
    "nav_msgs": "python3-nav-msgs",
    "tf2_msgs": "python3-tf2-msgs",
    "rosgraph_msgs": "python3-rosgraph-msgs",
}


def missing_debian_ros() -> str | None:
    """Why Debian's rosbag tools cannot check our bags here, or ``None`` if they can."""
    if shutil.which("rosbag", path="/usr/bin") is None or not Path("/usr/bin/python3").exists():
        return "Debian's rosbag CLI is not installed (apt install python3-rosbag)"
    modules = ", ".join(f"{name}.msg" for name in DEBIAN_MSG_PACKAGES)
    probe = subprocess.run(
        ["/usr/bin/python3", "-c", f"import rosbag, {modules}"],
        env=debian_env(),
        capture_output=True,
        text=True,
        check=False,
    )
    if probe.returncode != 0:
        packages = " ".join(["python3-rosbag", *DEBIAN_MSG_PACKAGES.values()])
        return f"Debian's rosbag or message packages are missing (apt install {packages})"
    return None
