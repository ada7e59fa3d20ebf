"""The ROS 2 backend without a ROS 2 graph: QoS choice, errors that say what to install."""

from __future__ import annotations

import sys

import pytest

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
