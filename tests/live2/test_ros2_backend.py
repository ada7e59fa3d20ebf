"""The ROS 2 backend without a ROS 2 graph: QoS choice, errors that say what to install."""

from __future__ import annotations

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
        [str(ROS2_PYTHON), "-m", "bubblerob_env.cli", "node", "--ros", "2", "--steps", "1"],
        env=ros2_env(ROS_DOMAIN_ID="500"),
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert result.returncode == 2, result.stdout + result.stderr
    assert "ROS_DOMAIN_ID='500': it must be 0-232" in result.stderr
