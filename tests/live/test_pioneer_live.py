"""The third tutorial's Pioneer as a live ROS 1 node (issue #26): ``--env PioneerP3DX-v0
--topics vrep`` against a real rosmaster and a rospy client (``ros_client.py vrep``).

The tutorial's scene (../shared/SEEDS.md, seed 002) publishes ``/vrep/scan`` every 4th simulation
step, ``/vrep/image``, ``/simTime`` and the static ``base_link -> laser_link`` and ``base_link ->
camera_link``; ``/vrep/laser_switch`` and ``/vrep/camera_switch`` turn the sensors off and on, and
``/vrep/cmd_vel`` drives it.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from itertools import pairwise

import numpy as np
import pytest
from live_helpers import requires_ros

pytestmark = requires_ros

DT_NS = 50_000_000
"""The Pioneer's control step (20 Hz)."""
SCAN_EVERY = 4
NODE_ARGS = (
    "--env", "PioneerP3DX-v0", "--topics", "vrep", "--camera", "--seed", "0",
    "--env-kwargs", '{"num_obstacles": [0, 0], "start_pose": [0, 0, 0]}',
)  # fmt: skip


@pytest.fixture(scope="module")
def vrep(master, start_node):
    node = start_node(*NODE_ARGS)
    got = master.client("vrep", "--linear", "0.6", "--angular", "0.4", "--seconds", "0.8")
    assert node.alive(), node.output
    return got


def between(stamps_or_values: list, marks: dict, first: str, last: str, column: int) -> list:
    return stamps_or_values[marks[first][column] : marks[last][column]]


def test_vrep_scan_goes_out_every_4th_step_of_sim_time(vrep):
    assert (vrep["scan_rays"], vrep["scan_frame"]) == (901, "laser_link")
    marks = vrep["marks"]
    scans = between(vrep["scan_stamps"], marks, "start", "off", 0)
    assert len(scans) >= 4, marks
    # One scan per 4 control steps: consecutive scans are 4 steps of simulated time apart...
    assert {b - a for a, b in pairwise(scans)} == {SCAN_EVERY * DT_NS}
    # ... while /clock ticks every step: 4 ticks per scan between the first and the last.
    clocks = [c for c in vrep["clocks"] if scans[0] <= c <= scans[-1]]
    assert len(clocks) == SCAN_EVERY * (len(scans) - 1) + 1, (len(clocks), len(scans))
    # /simTime (std_msgs/Float32) goes out every step too, as /clock does, and holds the
    # simulated time: one control step more each time (float32 steps of 0.05 s).
    assert abs(len(vrep["sim_times"]) - len(vrep["clocks"])) <= 3
    # (An episode's reset starts it from 0 again.)
    times = np.array(vrep["sim_times"], dtype=np.float64)
    steps, after = np.diff(times), times[1:]
    assert len(steps) >= 4
    assert np.all(np.isclose(steps, DT_NS * 1e-9, atol=1e-5) | (after == 0.0)), steps[:8]
    assert np.count_nonzero(after == 0.0) <= 1
    # Switched off and on again, the scans keep the same 4-step grid.
    first = vrep["scan_stamps"][0]
    assert all((s - first) % (SCAN_EVERY * DT_NS) == 0 for s in vrep["scan_stamps"])


def test_vrep_image_every_step_and_static_frames(vrep):
    marks = vrep["marks"]
    images = between(vrep["image_stamps"], marks, "start", "off", 1)
    assert {b - a for a, b in pairwise(images)} == {DT_NS}
    assert ["base_link", "laser_link"] in vrep["tf_static"]
    assert ["base_link", "camera_link"] in vrep["tf_static"]


def test_vrep_switches_turn_the_laser_and_camera_off_and_on(vrep):
    marks = vrep["marks"]
    (scan_off, image_off, time_off), (scan_off_end, image_off_end, time_off_end) = (
        marks["off"],
        marks["off_end"],
    )
    assert (scan_off_end - scan_off, image_off_end - image_off) == (0, 0), marks
    assert time_off_end - time_off >= 8, marks  # the simulation ran on meanwhile
    (scan_on, image_on, _), (scan_end, image_end, _) = marks["on"], marks["on_end"]
    assert scan_end - scan_on >= 2 and image_end - image_on >= 8, marks


def test_vrep_cmd_vel_drives_forward_and_counter_clockwise(vrep):
    before, after = vrep["before"], vrep["after"]
    assert (before["x"], before["y"], before["yaw"]) == pytest.approx((0, 0, 0), abs=1e-3)
    dx, dy = after["x"] - before["x"], after["y"] - before["y"]
    forward = dx * math.cos(before["yaw"]) + dy * math.sin(before["yaw"])
    # 0.8 s at 0.6 m/s and 0.4 rad/s (the client's wall clock; the node at real time): about
    # 0.48 m along an arc turning 0.32 rad to the left.
    assert forward > 0.3, (before, after)
    assert math.remainder(after["yaw"] - before["yaw"], 2 * math.pi) > 0.15, (before, after)
    assert after["vx"] == pytest.approx(0.6, abs=0.1) and after["wz"] == pytest.approx(0.4, abs=0.1)


TELEOP_LINK = """
import json, sys, time
from bubblerob_cli.main import build_parser
from bubblerob_env.ros.messages.topics import topics_preset
from bubblerob_cli.teleop.cli import ros_limits
from bubblerob_cli.teleop.keys import TeleopState
from bubblerob_cli.teleop.ros import RosLink

args = build_parser().parse_args(sys.argv[1:])
link = RosLink(1, topics_preset(args.topics, args.namespace), *ros_limits(args))
state = TeleopState()
for key in b"www":  # 0.3 of the top speed forward, as the keys set it
    state.press(key)
end = time.monotonic() + 0.6
while time.monotonic() < end:
    link.send(state)
    time.sleep(0.05)
print(json.dumps({"limits": [link.max_linear, link.max_angular], "speed": link.speed,
                  "nearest": link.nearest, "pose": link.pose}))
link.close()
"""


def test_teleop_ros_link_drives_the_pioneer_on_vrep_topics(master, vrep):
    # What `bubblerob teleop --ros 1 --env PioneerP3DX-v0 --topics vrep` sends and reads (the
    # terminal part is tests/live/test_teleop_ros.py's), against the module's node.
    argv = ["teleop", "--ros", "1", "--env", "PioneerP3DX-v0", "--topics", "vrep"]
    result = subprocess.run(
        [sys.executable, "-c", TELEOP_LINK, *argv],
        env=master.venv_env, capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    got = json.loads(result.stdout.strip().splitlines()[-1])
    assert got["limits"] == pytest.approx([1.2, math.radians(300)], rel=1e-3)  # the Pioneer's
    assert got["speed"] == pytest.approx(0.3 * 1.2, abs=0.05)  # /odom, not BubbleRob's 0.12
    assert 0.1 < got["nearest"] < 10.0  # from /vrep/scan: a wall of the 10 m arena
    assert got["pose"] is not None
