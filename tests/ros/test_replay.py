"""Replay re-simulates a bag from its metadata and finds the first divergence."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from ros_helpers import drive
from rosbags import rosbag1, rosbag2
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import StoragePlugin

from bubblerob_env.ros import RosBagRecorder
from bubblerob_env.ros.readback.replay import ReplayError, replay_bag

NOISY = {"laser_noise_std": 0.01, "max_episode_steps": 12}


def _record(tmp_path, fmt, **env_kwargs):
    env = gym.make("BubbleRob-v0", **env_kwargs)
    with RosBagRecorder(env, tmp_path / "bag", format=fmt) as recorder:
        drive(recorder, episodes=1, steps=12, seed=4)
        drive(recorder, episodes=1, steps=12, seed=None)  # unseeded: generator state replayed
    return recorder.bag_paths[0]


def _tamper(path, out, topic, index, change):
    """Copy the bag at ``path`` to ``out`` with message ``index`` of ``topic`` changed."""
    with AnyReader([path]) as reader:
        ros1 = path.suffix == ".bag"
        writer = (
            rosbag1.Writer(out)
            if ros1
            else rosbag2.Writer(out, version=9, storage_plugin=StoragePlugin.MCAP)
        )
        writer.open()
        connections = {}
        for c in reader.connections:
            if ros1:
                connections[c.id] = writer.add_connection(
                    c.topic, c.msgtype, msgdef=c.msgdef.data, md5sum=c.digest
                )
            else:
                connections[c.id] = writer.add_connection(
                    c.topic, c.msgtype, msgdef=c.msgdef.data, rihs01=c.digest
                )
        seen = 0
        for c, stamp, raw in reader.messages():
            if c.topic == topic:
                if seen == index:
                    message = reader.deserialize(raw, c.msgtype)
                    change(message)
                    store = reader.typestore
                    raw = (
                        store.serialize_ros1(message, c.msgtype)
                        if ros1
                        else store.serialize_cdr(message, c.msgtype)
                    )
                seen += 1
            writer.write(connections[c.id], stamp, bytes(raw))
        writer.close()
    return out


@pytest.mark.parametrize("fmt", ["mcap", "ros1", "sqlite3"])
def test_replay_matches_the_recording(tmp_path, fmt):
    path = _record(tmp_path, fmt, **NOISY)
    report = replay_bag(path)
    assert report.ok, str(report)
    assert (report.episodes, report.steps) == (2, 24)
    assert report.messages > 24 * 14


def test_replay_matches_with_the_camera(tmp_path):
    path = _record(tmp_path, "mcap", camera=True, camera_width=16, camera_height=16, **NOISY)
    assert replay_bag(path).ok


@pytest.mark.parametrize("fmt", ["mcap", "ros1"])
def test_tampered_scan_is_reported_at_its_step_and_field(tmp_path, fmt):
    path = _record(tmp_path, fmt, **NOISY)

    def change(scan):
        scan.ranges = scan.ranges.copy()
        scan.ranges[17] += 0.25

    tampered = _tamper(path, tmp_path / ("t.bag" if fmt == "ros1" else "t"), "/scan", 5, change)
    report = replay_bag(tampered)
    assert not report.ok
    divergence = report.divergence
    assert (divergence.episode, divergence.step, divergence.topic) == (0, 5, "/scan")
    assert divergence.field == ".ranges[17]"
    assert divergence.recorded == pytest.approx(divergence.replayed + 0.25, abs=1e-5)
    assert "episode 0, step 5, /scan .ranges[17]" in str(report)


def test_tampered_action_makes_the_next_observation_diverge(tmp_path):
    path = _record(tmp_path, "mcap", **NOISY)

    def change(action):
        action.data = np.array([-1.0, 1.0])

    report = replay_bag(_tamper(path, tmp_path / "t", "/bubblerob/action", 3, change))
    assert not report.ok
    assert (report.divergence.episode, report.divergence.step) == (0, 4)


def test_bag_without_episode_metadata_cannot_be_replayed(tmp_path):
    writer = rosbag1.Writer(tmp_path / "plain.bag")
    writer.open()
    writer.close()
    with pytest.raises(ReplayError, match="no bubblerob episode metadata"):
        replay_bag(tmp_path / "plain.bag")
