"""The third tutorial's Pioneer as a live ROS 2 node (issue #26): ``--env PioneerP3DX-v0 --topics
vrep`` against a real rclpy probe (``.venv-ros2``, DDS on the loopback in this session's domain).

``/vrep/scan`` every 4th simulation step (measured against ``/clock``), ``/simTime`` every step,
``/vrep/image``, the static ``base_link -> laser_link`` and ``base_link -> camera_link``;
``/vrep/laser_switch`` and ``/vrep/camera_switch`` turn the sensors off and on, and
``/vrep/cmd_vel`` drives the robot (measured on ``/odom``).
"""

from __future__ import annotations

import json
import math
import subprocess
import textwrap
from itertools import pairwise

import pytest
from ros2_helpers import ROS2_PYTHON, ros2_env

DT_NS = 50_000_000
SCAN_EVERY = 4
PROBE = textwrap.dedent(
    """
    import json, math, time
    import rclpy
    from geometry_msgs.msg import Twist
    from nav_msgs.msg import Odometry
    from rclpy.qos import DurabilityPolicy, QoSProfile, qos_profile_sensor_data
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import Image, LaserScan
    from std_msgs.msg import Bool, Float32
    from tf2_msgs.msg import TFMessage

    rclpy.init()
    node = rclpy.create_node("pioneer_probe")
    ns = lambda t: t.sec * 10**9 + t.nanosec
    got = {"scan": [], "image": [], "sim_time": [], "clock": [], "static": []}
    odom = []
    sensor, latched = qos_profile_sensor_data, QoSProfile(
        depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    node.create_subscription(LaserScan, "/vrep/scan",
        lambda m: got["scan"].append((ns(m.header.stamp), len(m.ranges))), sensor)
    node.create_subscription(Image, "/vrep/image",
        lambda m: got["image"].append(ns(m.header.stamp)), sensor)
    node.create_subscription(Float32, "/simTime", lambda m: got["sim_time"].append(m.data), 100)
    node.create_subscription(Clock, "/clock", lambda m: got["clock"].append(ns(m.clock)), 100)
    node.create_subscription(TFMessage, "/tf_static", lambda m: got["static"].extend(
        [t.header.frame_id, t.child_frame_id] for t in m.transforms), latched)
    def on_odom(m):
        p, q = m.pose.pose.position, m.pose.pose.orientation
        odom[:] = [p.x, p.y, math.atan2(2 * q.w * q.z, 1 - 2 * q.z * q.z)]
    node.create_subscription(Odometry, "/odom", on_odom, 100)
    drive = node.create_publisher(Twist, "/vrep/cmd_vel", 10)
    switches = [node.create_publisher(Bool, f"/vrep/{s}_switch", 10) for s in ("laser", "camera")]

    def spin(seconds, twist=None):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            if twist is not None:
                drive.publish(twist)
            rclpy.spin_once(node, timeout_sec=0.05)

    def counts():
        return [len(got[k]) for k in ("scan", "image", "sim_time")]

    deadline = time.monotonic() + 30
    while (not odom or not got["scan"] or drive.get_subscription_count() == 0
           or min(p.get_subscription_count() for p in switches) == 0):
        if time.monotonic() > deadline:
            raise SystemExit("the node's topics did not match within 30 s")
        rclpy.spin_once(node, timeout_sec=0.05)
    before = list(odom)
    twist = Twist()
    twist.linear.x, twist.angular.z = 0.6, 0.4
    marks = {"start": counts()}
    spin(0.8, twist)
    marks["driven"], after = counts(), list(odom)
    for phase, on in (("off", False), ("on", True)):
        for switch in switches:
            switch.publish(Bool(data=on))
        spin(0.3)  # the switches take effect at the node's next step
        marks[phase] = counts()
        spin(0.8)
        marks[phase + "_end"] = counts()
    # The last scan's /clock tick may still be queued (spin_once takes one message a call).
    scans = list(got["scan"])
    deadline = time.monotonic() + 10
    while not got["clock"] or got["clock"][-1] < scans[-1][0]:
        if time.monotonic() > deadline:
            raise SystemExit("the last scan's /clock tick did not come within 10 s")
        rclpy.spin_once(node, timeout_sec=0.05)
    got["scan"] = scans
    print(json.dumps({**got, "marks": marks, "before": before, "after": after}))
    """
)
NODE_ARGS = (
    "--env", "PioneerP3DX-v0", "--topics", "vrep", "--camera", "--seed", "0",
    "--env-kwargs", '{"num_obstacles": [0, 0], "start_pose": [0, 0, 0]}',
)  # fmt: skip


@pytest.fixture(scope="module")
def vrep(start_node):
    node = start_node(*NODE_ARGS)
    probe = subprocess.run(
        [str(ROS2_PYTHON), "-c", PROBE], env=ros2_env(), capture_output=True, text=True,
        timeout=90, check=False,
    )  # fmt: skip
    assert probe.returncode == 0, probe.stderr
    assert node.alive(), node.output
    return json.loads(probe.stdout.strip().splitlines()[-1])


def test_vrep_scan_every_4th_step_of_the_clock(vrep):
    scans = [stamp for stamp, _ in vrep["scan"]]
    assert {rays for _, rays in vrep["scan"]} == {901}
    assert len(scans) >= 5, vrep["marks"]
    # Best effort may drop a scan; what arrives is on a grid of 4 steps, mostly 4 steps apart.
    gaps = [b - a for a, b in pairwise(scans)]
    assert all(gap > 0 and gap % (SCAN_EVERY * DT_NS) == 0 for gap in gaps), gaps
    assert gaps.count(SCAN_EVERY * DT_NS) >= 0.8 * len(gaps), gaps
    ticks = [c for c in vrep["clock"] if scans[0] <= c <= scans[-1]]  # /clock: every step
    assert len(ticks) == (scans[-1] - scans[0]) // DT_NS + 1
    assert len(ticks) >= SCAN_EVERY * (len(scans) - 1)
    assert abs(len(vrep["sim_time"]) - len(vrep["clock"])) <= 3  # /simTime every step too


def test_vrep_switches_and_static_frames(vrep):
    marks = vrep["marks"]
    scan_off, image_off, time_off = marks["off"]
    scan_off_end, image_off_end, time_off_end = marks["off_end"]
    assert (scan_off_end - scan_off, image_off_end - image_off) == (0, 0), marks
    assert time_off_end - time_off >= 8, marks
    (scan_on, image_on, _), (scan_end, image_end, _) = marks["on"], marks["on_end"]
    assert scan_end - scan_on >= 2 and image_end - image_on >= 6, marks
    assert ["base_link", "laser_link"] in vrep["static"]
    assert ["base_link", "camera_link"] in vrep["static"]


def test_vrep_cmd_vel_drives_forward_and_counter_clockwise(vrep):
    (x0, y0, yaw0), (x1, y1, yaw1) = vrep["before"], vrep["after"]
    assert (x0, y0, yaw0) == pytest.approx((0, 0, 0), abs=1e-3)
    assert (x1 - x0) * math.cos(yaw0) + (y1 - y0) * math.sin(yaw0) > 0.3, vrep["after"]
    assert math.remainder(yaw1 - yaw0, 2 * math.pi) > 0.15, vrep["after"]
