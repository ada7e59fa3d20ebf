"""``bubblerob node --robots 2`` on a real rosmaster: one /clock, one robot per command, watchdogs,
the tutorial's names, and the same scans from the same seed in sync mode."""

from __future__ import annotations

import json
import math
import subprocess
import time

from live_helpers import requires_ros, stop

pytestmark = requires_ros

SPIN = 1.5  # rad/s: turning in place touches nothing, so no episode ends mid-test

SCANS = """
import json, sys, rospy
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Bool, Float32
rospy.init_node("multi_scans", anonymous=True, disable_signals=True)
scans = []
sub = rospy.Subscriber("/robot_1/scan", LaserScan, lambda m: scans.append(list(m.ranges)))
wheel = rospy.Publisher("/robot_0/leftMotorSpeed", Float32, queue_size=10, latch=True)
trigger = rospy.Publisher("/triggerNextStep", Bool, queue_size=100)
end = rospy.get_time() + 10
while (sub.get_num_connections() < 1 or trigger.get_num_connections() < 1
       or wheel.get_num_connections() < 1) and rospy.get_time() < end:
    rospy.sleep(0.02)
wheel.publish(Float32(4.0))
rospy.sleep(0.3)
for _ in range(12):
    trigger.publish(Bool(True))
    rospy.sleep(0.05)
rospy.sleep(1.0)
print(json.dumps(scans))
"""


def clock_publishers(master) -> list[str]:
    info = master.run(["/usr/bin/rostopic", "info", "/clock"]).stdout
    section = info.split("Publishers:")[1].split("Subscribers:")[0]
    return [line for line in section.splitlines() if line.strip().startswith("*")]


def odom(master, robot: str) -> dict:
    return master.client("--ns", f"/{robot}", "odom")


def turned(a: dict, b: dict) -> float:
    return abs(math.remainder(b["yaw"] - a["yaw"], math.tau))


def turning(read) -> None:
    """Until the robot that ``read()`` reads turns (a new publisher's first commands are here)."""
    deadline = time.monotonic() + 20
    while read()["wz"] < 1.0:
        assert time.monotonic() < deadline, "robot_1 never turned"
        time.sleep(0.2)


def test_one_clock_and_each_robot_its_own_cmd_vel_and_watchdog(master, start_node):
    node = start_node("--robots", "2", "--seed", "3", "--watchdog", "0.5")
    assert len(clock_publishers(master)) == 1
    before0, before1 = odom(master, "robot_0"), odom(master, "robot_1")
    spun = master.client(
        "--ns", "/robot_1", "drive", "--angular", str(SPIN), "--seconds", "1.0", "--idle", "1.0"
    )
    after0 = odom(master, "robot_0")
    assert turned(before1, spun["moving"]) > 0.5 and spun["moving"]["wz"] > 1.0
    assert abs(spun["idle"]["wz"]) < 0.05, spun  # robot_1's watchdog stopped it
    assert turned(before0, after0) < 0.01 and abs(after0["wz"]) < 0.01  # robot_0 never moved
    # robot_1 keeps getting commands while robot_0's stop: only robot_0's watchdog trips.
    keep = master.popen(
        [
            "/usr/bin/rostopic", "pub", "-r", "20", "/robot_1/cmd_vel", "geometry_msgs/Twist",
            f"{{angular: {{z: {SPIN}}}}}",
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )  # fmt: skip
    try:
        turning(lambda: odom(master, "robot_1"))
        driven = master.client(
            "--ns", "/robot_0", "drive", "--angular", str(SPIN), "--seconds", "1.0",
            "--idle", "1.5",
        )  # fmt: skip
        still1 = odom(master, "robot_1")
    finally:
        stop(keep)
    assert driven["moving"]["wz"] > 1.0 and abs(driven["idle"]["wz"]) < 0.05
    assert still1["wz"] > 1.0  # robot_1 still turning: its own watchdog did not trip
    assert node.alive()
    node.stop()


def _sync_scans(master, start_node, *naming: str) -> list[list[float]]:
    node = start_node("--robots", "2", "--seed", "5", "--sync", *naming)
    try:
        result = master.run(["/usr/bin/python3", "-c", SCANS], timeout=60)
        assert result.returncode == 0, result.stderr
        return json.loads(result.stdout.splitlines()[-1])
    finally:
        node.stop()


def test_sync_mode_gives_the_same_scans_from_the_same_seed(master, start_node):
    first = _sync_scans(master, start_node)
    second = _sync_scans(master, start_node)
    assert len(first) >= 12 and first[-12:] == second[-12:]  # (the reset's scan may be missed)


def test_tutorial_names_carry_the_robot_index(master, start_node):
    node = start_node("--robots", "2", "--topics", "tutorial", "--sync")
    topics = set(master.run(["/usr/bin/rostopic", "list"]).stdout.split())
    node.stop()
    for k in (0, 1):
        assert {f"/leftMotorSpeed{k}", f"/rightMotorSpeed{k}", f"/sensorTrigger{k}"} <= topics
        assert {f"/simTime{k}", f"/scan{k}", f"/odom{k}"} <= topics
    assert "/clock" in topics and "/triggerNextStep" in topics
    assert not any(t.startswith("/robot_") for t in topics)


LAUNCH = """
import sys
import roslaunch.config
sys.argv = ["roslaunch", *sys.argv[1:]]
config = roslaunch.config.load_config_default(["bubblerob.launch"], None)
for node in config.nodes:
    print(node.name, node.namespace, node.args)
"""


def test_launch_file_takes_robots(master):
    from bubblerob_env.ros.live.node import LAUNCH_DIR

    env = {"PATH": "/usr/bin:/bin", "HOME": "/tmp", "ROS_PACKAGE_PATH": str(LAUNCH_DIR)}
    result = subprocess.run(
        ["/usr/bin/python3", "-c", LAUNCH, "robots:=3", "rviz:=true"],
        env=env, cwd=LAUNCH_DIR, capture_output=True, text=True, timeout=60, check=True,
    )  # fmt: skip
    node, rviz = result.stdout.splitlines()
    assert node.endswith("--robots 3")
    assert rviz.split()[:2] == ["rviz", "/robot_0/"] and rviz.endswith("-f map")
