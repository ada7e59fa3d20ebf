"""Drifting ``/odom`` and ``/base_pose_ground_truth`` in bags (issue #27), field by field."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from ros_helpers import FORWARD, read_all

from bubblerob_env.ros import RosBagRecorder
from bubblerob_env.ros.readback.replay import replay_bag


def _record(tmp_path, fmt, **env_kwargs):
    env = gym.make("BubbleRob-v0", max_episode_steps=15, **env_kwargs)
    frames = []
    with RosBagRecorder(env, tmp_path / "bag", format=fmt) as recorder:
        _, info = recorder.reset(seed=3)
        frames.append(info)
        for _ in range(14):
            *_, info = recorder.step(FORWARD)
            frames.append(info)
    return recorder.bag_paths[0], frames


def _yaw(q) -> float:
    return math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))


@pytest.mark.parametrize("fmt", ["mcap", "ros1", "sqlite3"])
def test_noisy_odometry_on_odom_and_tf_and_the_truth_beside_it(tmp_path, fmt):
    path, frames = _record(tmp_path, fmt, odometry_noise=0.2)
    messages = read_all(path)
    truth, odom, tf = (messages[t] for t in ("/base_pose_ground_truth", "/odom", "/tf"))
    assert len(truth) == len(odom) == len(frames)
    for info, (_, true), (_, odometry), (_, transforms) in zip(
        frames, truth, odom, tf, strict=True
    ):
        assert true.header.frame_id == "map" and true.child_frame_id == "base_link"
        position = true.pose.pose.position
        assert (position.x, position.y, position.z) == tuple(info["position"])
        assert odometry.header.frame_id == "odom"
        position = odometry.pose.pose.position
        assert (position.x, position.y) == (info["odom_x"], info["odom_y"])
        assert _yaw(odometry.pose.pose.orientation) == pytest.approx(info["odom_yaw"], abs=1e-12)
        (transform,) = transforms.transforms
        assert transform.header.frame_id == "odom" and transform.child_frame_id == "base_link"
        assert transform.transform.translation.x == info["odom_x"]
        assert odometry.twist.twist.linear.x == true.twist.twist.linear.x
    drift = [math.hypot(i["odom_x"] - i["x"], i["odom_y"] - i["y"]) for i in frames]
    assert drift[0] == 0.0 and max(drift) > 1e-3


def test_without_noise_odom_is_the_truth_and_no_ground_truth_topic(tmp_path):
    path, frames = _record(tmp_path, "mcap")
    messages = read_all(path)
    assert "/base_pose_ground_truth" not in messages
    for info, (_, odom) in zip(frames, messages["/odom"], strict=True):
        orientation = odom.pose.pose.orientation
        w, x, y, z = info["quaternion_wxyz"]
        assert (orientation.x, orientation.y, orientation.z, orientation.w) == (x, y, z, w)
        assert odom.pose.pose.position.x == info["x"]


def test_a_noisy_recording_replays(tmp_path):
    path, _ = _record(tmp_path, "mcap", odometry_noise=0.2, laser_noise_std=0.01)
    report = replay_bag(path)
    assert report.ok, str(report)
    assert np.isfinite(report.messages)
