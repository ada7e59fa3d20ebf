"""The ROS 2 backend without a ROS 2 graph: QoS choice, errors that say what to install."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from ros2_helpers import ROS2_PYTHON, require_ros2, ros2_env

from bubblerob_env.ros.live import RosUnavailableError, load_backend
from bubblerob_env.ros.live.ros2 import SENSOR_TYPES, qos_kind
from bubblerob_env.ros.live.ros2_msgs import MSG_DIR, PACKAGES
from bubblerob_env.ros.messages.topics import LATCHED_TOPICS, MSGTYPES


def test_qos_kinds_follow_ros2_conventions():
    assert qos_kind(MSGTYPES["scan"]) == "sensor"
    assert qos_kind(MSGTYPES["image"]) == qos_kind(MSGTYPES["camera_info"]) == "sensor"
    assert qos_kind(MSGTYPES["proximity"]) == "sensor"
    for key in ("odom", "tf", "clock", "sensor_trigger", "action"):
        assert qos_kind(MSGTYPES[key]) == "reliable", key
    for key in LATCHED_TOPICS:  # tf_static, episode
        assert qos_kind(MSGTYPES[key], latched=True) == "latched", key
    assert set(SENSOR_TYPES) <= set(MSGTYPES.values())


def test_missing_rclpy_says_how_to_install_it(monkeypatch):
    monkeypatch.setitem(sys.modules, "rclpy", None)  # makes `import rclpy` fail
    with pytest.raises(RosUnavailableError, match=r"\.venv-ros2.*\[ros2\]"):
        load_backend(2)


def test_tf2_msgs_is_built_from_the_genuine_definition():
    text = (MSG_DIR / "tf2_msgs" / "TFMessage.msg").read_text()
    assert text.strip() == "geometry_msgs/TransformStamped[] transforms"
    assert PACKAGES["tf2_msgs"]["messages"] == ["TFMessage"]


def test_a_bad_domain_id_is_a_clear_error_not_a_dds_exit():
    require_ros2()
    result = subprocess.run(
        [str(ROS2_PYTHON), "-m", "bubblerob_cli", "node", "--ros", "2", "--steps", "1"],
        env=ros2_env(ROS_DOMAIN_ID="500"),
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert result.returncode == 2, result.stdout + result.stderr
    assert "ROS_DOMAIN_ID='500': it must be 0-232" in result.stderr


WRAPPER = """
import json, time
import gymnasium as gym
import numpy as np
import rclpy
from rclpy.executors import SingleThreadedExecutor
from nav_msgs.msg import Odometry
import bubblerob_env
from bubblerob_env.ros import RosLivePublisher

env = RosLivePublisher(gym.make("BubbleRob-v0"), ros=2)  # starts rclpy
probe = rclpy.create_node("probe")
got = []
probe.create_subscription(Odometry, "/odom", got.append, 100)
executor = SingleThreadedExecutor()
executor.add_node(probe)
end = time.monotonic() + 20
while probe.count_publishers("/odom") < 1 and time.monotonic() < end:
    executor.spin_once(timeout_sec=0.05)
time.sleep(0.5)
env.reset(seed=0)
for _ in range(20):
    env.step(np.array([0.5, 0.5], dtype=np.float32))
while len(got) < 21 and time.monotonic() < end:
    executor.spin_once(timeout_sec=0.05)
stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in got]
executor.shutdown()
probe.destroy_node()
env.close()
print(json.dumps({"odom": len(got), "steps": [b - a for a, b in zip(stamps, stamps[1:])]}))
"""


def test_ros_live_publisher_wrapper_on_rclpy():
    require_ros2()
    result = subprocess.run(
        [str(ROS2_PYTHON), "-c", WRAPPER],
        env=ros2_env(),
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    out = json.loads(result.stdout.strip().splitlines()[-1])
    assert out["odom"] == 21  # the reset and 20 steps
    assert out["steps"] == [50_000_000] * 20  # simulated time, one control step apart
