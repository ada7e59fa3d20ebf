"""``bubblerob node --ros 2 --robots 2``: one /clock publisher, each robot its own cmd_vel and
watchdog (rclpy clients; the same checks as tests/live/test_multi_live.py on ROS 1)."""

from __future__ import annotations

import json
import math
import subprocess
import time

from ros2_helpers import ROOT, ROS2_PYTHON, client, ros2_env

SPIN = 1.5  # rad/s: turning in place touches nothing, so no episode ends mid-test

PROBE = """
import json, sys, time, rclpy
from geometry_msgs.msg import Twist
rclpy.init()
node = rclpy.create_node("multi_probe")
deadline = time.monotonic() + 20
while node.count_publishers("/clock") < 1 and time.monotonic() < deadline:
    time.sleep(0.1)
if sys.argv[1:]:  # turn robot_1 until killed
    pub = node.create_publisher(Twist, "/robot_1/cmd_vel", 10)
    msg = Twist()
    msg.angular.z = float(sys.argv[1])
    while True:
        pub.publish(msg)
        time.sleep(0.05)
time.sleep(1.0)  # discovery settles: a second clock would be seen by now
print(json.dumps(node.count_publishers("/clock")), flush=True)
"""


def turned(a: dict, b: dict) -> float:
    return abs(math.remainder(b["yaw"] - a["yaw"], math.tau))


def turning(odom) -> None:
    """Until the robot that ``odom()`` reads turns (a new publisher's first commands are here)."""
    deadline = time.monotonic() + 20
    while odom()["wz"] < 1.0:
        assert time.monotonic() < deadline, "robot_1 never turned"
        time.sleep(0.2)


def test_one_clock_and_each_robot_its_own_cmd_vel_and_watchdog(start_node):
    node = start_node("--robots", "2", "--seed", "3", "--watchdog", "0.5")
    probe = subprocess.run(
        [str(ROS2_PYTHON), "-c", PROBE], env=ros2_env(), cwd=ROOT, capture_output=True,
        text=True, timeout=60, check=True,
    )  # fmt: skip
    assert json.loads(probe.stdout) == 1
    before0, before1 = client("--ns", "/robot_0", "odom"), client("--ns", "/robot_1", "odom")
    assert (
        before1["frame_id"] == "robot_1/odom" and before1["child_frame_id"] == "robot_1/base_link"
    )
    spun = client(
        "--ns", "/robot_1", "drive", "--angular", str(SPIN), "--seconds", "1.0", "--idle", "1.0"
    )
    after0 = client("--ns", "/robot_0", "odom")
    assert turned(before1, spun["moving"]) > 0.5 and spun["moving"]["wz"] > 1.0
    assert abs(spun["idle"]["wz"]) < 0.05  # robot_1's watchdog stopped it
    assert turned(before0, after0) < 0.01 and abs(after0["wz"]) < 0.01  # robot_0 never moved
    keep = subprocess.Popen(
        [str(ROS2_PYTHON), "-c", PROBE, str(SPIN)], env=ros2_env(), cwd=ROOT,
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    try:
        turning(lambda: client("--ns", "/robot_1", "odom"))
        driven = client(
            "--ns", "/robot_0", "drive", "--angular", str(SPIN), "--seconds", "1.0",
            "--idle", "1.5",
        )  # fmt: skip
        still1 = client("--ns", "/robot_1", "odom")
    finally:
        keep.kill()
        keep.wait(10)
    assert driven["moving"]["wz"] > 1.0 and abs(driven["idle"]["wz"]) < 0.05
    assert still1["wz"] > 1.0  # robot_1 still turning: its own watchdog did not trip
    assert node.alive()
    node.stop()  # the sync test's nodes are the graph's only ones


SCANS = """
import json, time, rclpy
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Bool, Float32
rclpy.init()
node = rclpy.create_node("multi_scans")
scans = []
node.create_subscription(
    LaserScan, "/robot_1/scan", lambda m: scans.append(list(m.ranges)), qos_profile_sensor_data
)
wheel = node.create_publisher(Float32, "/robot_0/leftMotorSpeed", 10)
trigger = node.create_publisher(Bool, "/triggerNextStep", 10)
deadline = time.monotonic() + 30
while (node.count_publishers("/robot_1/scan") < 1 or wheel.get_subscription_count() < 1
       or trigger.get_subscription_count() < 1) and time.monotonic() < deadline:
    rclpy.spin_once(node, timeout_sec=0.05)
time.sleep(0.5)
rclpy.spin_once(node, timeout_sec=0.1)
scans.clear()  # the reset's scan, if it came: no step's
for _ in range(12):
    wheel.publish(Float32(data=4.0))
    rclpy.spin_once(node, timeout_sec=0.05)
    count = len(scans)
    trigger.publish(Bool(data=True))
    end = time.monotonic() + 5
    while len(scans) == count and time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
print(json.dumps(scans))
"""


def _sync_scans(start_node) -> list[list[float]]:
    node = start_node("--robots", "2", "--seed", "5", "--sync")
    try:
        result = subprocess.run(
            [str(ROS2_PYTHON), "-c", SCANS], env=ros2_env(), cwd=ROOT, capture_output=True,
            text=True, timeout=90, check=True,
        )  # fmt: skip
        return json.loads(result.stdout.splitlines()[-1])
    finally:
        node.stop()


def test_sync_mode_gives_the_same_scans_from_the_same_seed(start_node):
    first, second = _sync_scans(start_node), _sync_scans(start_node)
    assert len(first) == 12 and first == second
