"""A real-time node (rate factor 1, camera on) against Debian's rostopic and a rospy client."""

from __future__ import annotations

import math
import re
import signal
import subprocess

import pytest
from live_helpers import requires_ros, stop, wait_for

pytestmark = requires_ros

NODE_ARGS = ["--camera", "--env-kwargs", '{"num_obstacles": [0, 0], "start_pose": [0, 0, 0]}']


@pytest.fixture(scope="module")
def node(start_node):
    return start_node(*NODE_ARGS)


def echo(master, topic: str) -> str:
    result = master.run(["/usr/bin/rostopic", "echo", "-n", "1", topic], timeout=30)
    assert result.returncode == 0, result.stderr
    return result.stdout


def test_rostopic_echo_scan_odom_image(master, node):
    scan = echo(master, "/scan")
    assert 'frame_id: "laser_link"' in scan
    ranges = re.search(r"^ranges: \[(.*)\]$", scan, re.M)
    assert ranges is not None and len(ranges.group(1).split(",")) == 360
    assert "range_max: 5.0" in scan and "angle_increment: 0.0174" in scan
    odom = echo(master, "/odom")
    assert 'frame_id: "odom"' in odom and 'child_frame_id: "base_link"' in odom
    w = float(re.search(r"orientation:\s+x: \S+\s+y: \S+\s+z: \S+\s+w: (\S+)", odom).group(1))
    assert w == pytest.approx(1.0, abs=1e-3)  # start_pose yaw 0
    image = echo(master, "/camera/image_raw")
    assert 'encoding: "rgb8"' in image and "step: 192" in image


def test_rostopic_hz_scan_is_near_20_hz(master, node):
    proc = master.popen(
        ["/usr/bin/rostopic", "hz", "/scan", "-w", "40"],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
    )
    try:
        wait_for(lambda: proc.poll() is not None, 6.0)
    finally:
        stop(proc, signal.SIGINT)
    rates = [float(r) for r in re.findall(r"average rate: ([\d.]+)", proc.stdout.read())]
    assert rates, "rostopic hz saw no /scan"
    assert 14.0 < rates[-1] < 26.0  # 20 Hz expected; loose on a loaded machine


def test_cmd_vel_forward_then_counter_clockwise(master, node):
    before = master.client("odom")
    master.client("drive", "--linear", "0.2", "--seconds", "1.5")
    after = master.client("odom")
    dx, dy = after["x"] - before["x"], after["y"] - before["y"]
    forward = dx * math.cos(before["yaw"]) + dy * math.sin(before["yaw"])
    assert forward > 0.15, (before, after)
    assert abs(after["yaw"] - before["yaw"]) < 0.1
    master.client("drive", "--angular", "1.5", "--seconds", "1.0")
    turned = master.client("odom")
    dyaw = math.remainder(turned["yaw"] - after["yaw"], 2 * math.pi)
    assert dyaw > 0.5, (after, turned)  # positive angular z turns counter-clockwise


def test_watchdog_stops_the_wheels(master, node):
    result = master.client("drive", "--linear", "0.2", "--seconds", "1.0", "--idle", "1.0")
    moving, stopped = result["moving"], result["idle"]
    assert moving["vx"] > 0.1  # the watchdog does not stop a robot that is commanded
    assert abs(stopped["vx"]) < 0.01 and abs(stopped["wz"]) < 0.05, stopped


def test_sensor_switches(master, node):
    topics = ["/scan", "/camera/image_raw", "/camera/camera_info", "/odom"]
    master.client("pub", "/laser_switch", "bool", "false")
    master.client("pub", "/camera_switch", "bool", "false")
    counts = master.client("count", *topics, "--seconds", "1.0")
    assert counts["/scan"] == 0 and counts["/camera/image_raw"] == 0, counts
    assert counts["/camera/camera_info"] == 0 and counts["/odom"] >= 10, counts
    master.client("pub", "/laser_switch", "bool", "true")
    master.client("pub", "/camera_switch", "bool", "true")
    counts = master.client("count", *topics, "--seconds", "1.0")
    assert min(counts.values()) >= 10, counts


def test_command_topics_have_their_types_on_the_master(master, node):
    expected = {
        "/cmd_vel": "geometry_msgs/Twist",
        "/leftMotorSpeed": "std_msgs/Float32",
        "/triggerNextStep": "std_msgs/Bool",
        "/laser_switch": "std_msgs/Bool",
    }
    for topic, msgtype in expected.items():
        result = master.run(["/usr/bin/rostopic", "type", topic])
        assert result.stdout.strip() == msgtype, (topic, result.stdout, result.stderr)


def test_malformed_and_wrongly_typed_commands_are_rejected(master, node):
    master.client("pub", "/cmd_vel", "string", "forward please")
    master.client("pub", "/cmd_vel", "badtwist")
    master.client("pub", "/leftMotorSpeed", "float32", "nan")
    assert wait_for(lambda: "malformed message on /leftMotorSpeed" in node.output, 5.0)
    assert "wrong type message on /cmd_vel: std_msgs/String" in node.output
    assert "malformed message on /cmd_vel: 8 bytes" in node.output
    assert node.alive()
    odom = master.client("odom")
    assert abs(odom["vx"]) < 0.01  # nothing was applied
    assert master.client("count", "/odom", "--seconds", "0.5")["/odom"] >= 5


def test_pause_start_stop_change_the_state(master, node):
    result = master.client("states", "--pause-seconds", "0.6")
    assert result["states"] == [1, 2, 1, 0, 1]
    assert result["paused_clocks"] == 0  # no steps while paused
    assert result["clocks"] > 0
    assert node.alive()
