"""Differential-drive kinematics and the sign conventions of both action modes (REP 103)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bubblerob_env.kinematics import DiffDrive, yaw_from_quat

DRIVE = DiffDrive(wheel_radius=0.04, wheel_separation=0.18, max_wheel_speed=10.0)


def test_inverse_then_forward_kinematics_round_trip():
    left, right = DRIVE.wheel_speeds(0.2, 1.0)
    assert DRIVE.body_twist(left, right) == pytest.approx((0.2, 1.0))


def test_positive_angular_speed_turns_the_right_wheel_faster():
    left, right = DRIVE.wheel_speeds(0.0, 1.0)
    assert right > 0 > left


def test_saturated_command_keeps_the_curvature():
    left, right = DRIVE.wheel_speeds(0.4, 4.0)
    assert max(abs(left), abs(right)) == pytest.approx(10.0)
    linear, angular = DRIVE.body_twist(left, right)
    assert angular / linear == pytest.approx(4.0 / 0.4)


def test_yaw_from_quaternion():
    angle = 2.5
    quat = np.array([math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2)])
    assert yaw_from_quat(quat) == pytest.approx(angle)


def _drive(env, action, steps):
    for _ in range(steps):
        _, _, terminated, _, info = env.step(np.asarray(action, dtype=np.float32))
        assert not terminated
    return info


@pytest.mark.parametrize("yaw", [0.0, 2.0, -2.5])
def test_forward_twist_moves_along_the_robots_heading(wall_env_factory, yaw):
    env = wall_env_factory(action_type="twist", start_pose=(-1.0, -1.0, yaw))
    env.reset(seed=0)
    info = _drive(env, [0.5, 0.0], 20)
    moved = np.array([info["x"] + 1.0, info["y"] + 1.0])
    assert np.linalg.norm(moved) > 0.15
    heading = np.array([math.cos(yaw), math.sin(yaw)])
    assert moved @ heading / np.linalg.norm(moved) > 0.999
    assert info["body_twist"][0] == pytest.approx(0.5 * 0.4, rel=0.05)


def test_positive_angular_twist_turns_counter_clockwise(wall_env_factory):
    env = wall_env_factory(action_type="twist", start_pose=(-1.0, -1.0, 0.0))
    env.reset(seed=0)
    info = _drive(env, [0.0, 0.25], 10)
    assert info["yaw"] > 0.2
    assert info["body_twist"][5] == pytest.approx(0.25 * env.unwrapped.max_angular_speed, rel=0.1)
    assert math.hypot(info["x"] + 1.0, info["y"] + 1.0) < 0.02  # turned in place


def test_wheel_mode_matches_twist_mode(wall_env_factory):
    twist = wall_env_factory(action_type="twist", start_pose=(-1.0, -1.0, 0.3))
    wheels = wall_env_factory(action_type="wheels", start_pose=(-1.0, -1.0, 0.3))
    twist.reset(seed=0)
    wheels.reset(seed=0)
    drive = wheels.unwrapped.drive
    command = drive.wheel_speeds(0.2, 1.0)
    info_twist = _drive(twist, [0.2 / 0.4, 1.0 / twist.unwrapped.max_angular_speed], 30)
    info_wheels = _drive(wheels, command / drive.max_wheel_speed, 30)
    np.testing.assert_allclose(info_twist["wheel_command"], command)
    assert info_wheels["x"] == pytest.approx(info_twist["x"], abs=1e-6)
    assert info_wheels["yaw"] == pytest.approx(info_twist["yaw"], abs=1e-6)


def test_left_wheel_backward_right_forward_turns_counter_clockwise(wall_env_factory):
    env = wall_env_factory(action_type="wheels", start_pose=(-1.0, -1.0, 0.0))
    env.reset(seed=0)
    info = _drive(env, [-0.3, 0.3], 10)
    assert info["yaw"] > 0.2
    assert info["wheel_speeds"][0] < 0 < info["wheel_speeds"][1]
