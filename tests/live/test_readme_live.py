"""README's "Live on a ROS 1 graph" commands as written: roscore, roslaunch, rostopic, rosbag."""

from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from live_helpers import requires_ros
from rosbags.highlevel import AnyReader

ROOT = Path(__file__).resolve().parents[2]
HEADING = "## Live on a ROS 1 graph\n"

pytestmark = requires_ros


def _section_block() -> str:
    section = (ROOT / "README.md").read_text().split(HEADING, 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```bash\n(.*?)```", section, flags=re.DOTALL)[0]


def _default_master_port_is_free() -> bool:
    with socket.socket() as sock:
        return sock.connect_ex(("127.0.0.1", 11311)) != 0


def _wait_until_stopped(group: int, timeout: float) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            os.killpg(group, 0)
        except ProcessLookupError:
            return
        time.sleep(0.2)


def test_readme_live_section_runs(tmp_path):
    # roscore takes the default port 11311 whatever ROS_MASTER_URI says, as for a user.
    if not _default_master_port_is_free():
        pytest.skip("a ROS master already listens on 11311")
    env = {
        **os.environ,
        "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
        "ROS_MASTER_URI": "http://127.0.0.1:11311/",
        "ROS_HOSTNAME": "127.0.0.1",
        "ROS_HOME": str(tmp_path / "ros_home"),
    }
    env.pop("ROS_NAMESPACE", None)
    script = "set -euo pipefail\n" + _section_block()
    log = tmp_path / "section.log"
    # Its own process group, so that the background roscore and roslaunch are stopped with it;
    # output to a file, because they keep a pipe open after bash exits.
    with log.open("w") as out:
        proc = subprocess.Popen(
            ["bash", "-c", script],
            cwd=tmp_path,
            env=env,
            stdout=out,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
    try:
        proc.wait(timeout=240)
    finally:
        for sig in (signal.SIGINT, signal.SIGKILL):
            try:
                os.killpg(proc.pid, sig)
            except ProcessLookupError:
                break
            if sig == signal.SIGINT:
                _wait_until_stopped(proc.pid, 15)
    output = log.read_text()
    assert proc.returncode == 0, output
    # rostopic echo printed the scan's angle_increment: 360 rays over 360 degrees.
    assert re.search(r"^0\.01745\d*\s*$", output, flags=re.MULTILINE), output
    # and the latched /map's width: the 4.2 m of the arena and its walls in 0.05 m cells.
    assert re.search(r"^84\s*$", output, flags=re.MULTILINE), output
    bag = tmp_path / "live.bag"
    with AnyReader([bag]) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        scans = [
            reader.deserialize(raw, c.msgtype)
            for c, _, raw in reader.messages([c for c in reader.connections if c.topic == "/scan"])
        ]
    assert set(counts) == {"/scan", "/odom", "/tf", "/clock"}, counts
    assert counts["/scan"] >= 40, counts  # 5 s at 20 Hz, real time
    assert {(s.header.frame_id, len(s.ranges)) for s in scans} == {("laser_link", 360)}
    assert re.search(r"/scan\s+\d+\s+sensor_msgs/msg/LaserScan", output), output  # bubblerob info
