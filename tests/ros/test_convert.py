"""Field semantics of the conversion: REP 117 ranges, quaternion order, action units, camera."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

from bubblerob_env.ros.messages.convert import RosConverter
from bubblerob_env.specs import EnvSpecs


@pytest.fixture
def frame():
    env = gym.make("BubbleRob-v0", camera=True, camera_width=16, camera_height=12)
    obs, info = env.reset(seed=5)
    specs = EnvSpecs.from_env(env)
    yield specs, obs, info
    env.close()


def test_laser_no_return_is_plus_inf_and_too_close_is_minus_inf(frame):
    specs, obs, info = frame
    laser = specs.laser
    obs = dict(obs)
    obs["laser"] = np.full(laser.num_rays, 1.0, dtype=np.float32)
    obs["laser"][0] = laser.range_max
    obs["laser"][1] = laser.range_min / 2
    obs["laser"][2] = laser.range_min
    scan = RosConverter(specs, "jazzy").message(
        "scan", RosConverter(specs, "jazzy").frame_values(obs, info, 0)
    )
    assert scan.ranges[0] == math.inf
    assert scan.ranges[1] == -math.inf
    assert scan.ranges[2] == pytest.approx(laser.range_min)
    assert scan.ranges[3] == pytest.approx(1.0)
    assert scan.header.frame_id == "laser_link"
    assert scan.angle_min == pytest.approx(laser.angle_min)
    assert scan.angle_increment == pytest.approx(laser.angle_increment)
    assert scan.range_max == pytest.approx(laser.range_max)
    assert scan.scan_time == pytest.approx(laser.scan_time)


def test_pose_quaternion_is_reordered_to_xyzw(frame):
    specs, obs, info = frame
    info = dict(info, quaternion_wxyz=np.array([0.9, 0.1, 0.2, 0.3]))
    converter = RosConverter(specs, "humble")
    values = converter.frame_values(obs, info, 0)
    odom = converter.message("odom", values)
    q = odom.pose.pose.orientation
    assert (q.x, q.y, q.z, q.w) == (0.1, 0.2, 0.3, 0.9)
    tf = converter.message("tf", values).transforms[0]
    assert (tf.header.frame_id, tf.child_frame_id) == ("odom", "base_link")
    assert tf.transform.rotation.w == 0.9


def test_wheels_action_gives_motor_speeds_and_forward_kinematics_twist(frame):
    specs, obs, info = frame
    info = dict(info, wheel_command=np.array([2.0, 6.0]))
    converter = RosConverter(specs, "jazzy")
    values = converter.frame_values(obs, info, 0, action=np.array([0.2, 0.6]))
    linear, angular = specs.drive.body_twist(2.0, 6.0)
    twist = converter.message("cmd_vel", values)
    assert twist.linear.x == pytest.approx(linear)
    assert twist.angular.z == pytest.approx(angular)
    assert converter.message("left_motor_speed", values).data == pytest.approx(2.0)
    assert converter.message("right_motor_speed", values).data == pytest.approx(6.0)
    assert list(converter.message("action", values).data) == pytest.approx([0.2, 0.6])


def test_twist_action_is_scaled_to_physical_units():
    env = gym.make("BubbleRob-v0", action_type="twist")
    obs, info = env.reset(seed=0)
    specs = EnvSpecs.from_env(env)
    converter = RosConverter(specs, "jazzy")
    values = converter.frame_values(obs, info, 0, action=np.array([0.5, -2.0]))
    twist = converter.message("cmd_vel", values)
    assert twist.linear.x == pytest.approx(0.5 * specs.max_linear_speed)
    assert twist.angular.z == pytest.approx(-1.0 * specs.max_angular_speed)  # clipped like env
    env.close()


def test_camera_info_matches_camera_spec(frame):
    specs, obs, info = frame
    converter = RosConverter(specs, "jazzy")
    values = converter.frame_values(obs, info, 0)
    camera_info = converter.message("camera_info", values)
    assert (camera_info.width, camera_info.height) == (16, 12)
    assert camera_info.k.reshape(3, 3) == pytest.approx(specs.camera.intrinsics())
    assert camera_info.p.reshape(3, 4)[:, :3] == pytest.approx(specs.camera.intrinsics())
    assert camera_info.header.frame_id == "camera_optical_frame"
    image = converter.message("image", values)
    assert (image.encoding, image.step) == ("rgb8", 3 * 16)
    assert np.array_equal(image.data.reshape(12, 16, 3), obs["camera"])


def test_range_has_variance_in_jazzy_only(frame):
    specs, obs, info = frame
    jazzy = RosConverter(specs, "jazzy")
    humble = RosConverter(specs, "humble")
    assert hasattr(jazzy.message("proximity", jazzy.frame_values(obs, info, 0)), "variance")
    assert not hasattr(humble.message("proximity", humble.frame_values(obs, info, 0)), "variance")


@pytest.mark.parametrize(("radiation", "expected"), [(None, 0), ("INFRARED", 1)])
def test_range_reports_the_proximity_sensors_radiation_type(radiation, expected):
    kwargs = {} if radiation is None else {"proximity_radiation_type": radiation}
    env = gym.make("BubbleRob-v0", **kwargs)
    obs, info = env.reset(seed=0)
    converter = RosConverter(EnvSpecs.from_env(env), "jazzy")
    message = converter.message("proximity", converter.frame_values(obs, info, 0))
    types = converter.store.types["sensor_msgs/msg/Range"]
    assert message.radiation_type == expected  # default: ULTRASOUND, the tutorial's FrontUS
    assert expected == (types.INFRARED if radiation else types.ULTRASOUND)


def test_noetic_headers_carry_seq_and_camera_info_uses_capital_matrices(frame):
    specs, obs, info = frame
    noetic = RosConverter(specs, "noetic")
    values = noetic.frame_values(obs, info, 3_500_000_000, seq=42)
    scan = noetic.message("scan", values)
    assert (scan.header.seq, scan.header.stamp.sec, scan.header.stamp.nanosec) == (42, 3, 5e8)
    assert noetic.message("camera_info", values).K.shape == (9,)
