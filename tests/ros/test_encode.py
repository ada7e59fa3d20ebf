"""The one packer produces exactly the bytes rosbags would, for every topic and distro."""

from __future__ import annotations

import struct

import gymnasium as gym
import numpy as np
import pytest

from bubblerob_env.ros.fastpath.batch import FrameBatch
from bubblerob_env.ros.fastpath.encode import Slot, message_items
from bubblerob_env.ros.fastpath.framing import Framing
from bubblerob_env.ros.fastpath.packer import Packer
from bubblerob_env.ros.fastpath.serializer import FrameSerializer
from bubblerob_env.ros.messages.convert import RosConverter
from bubblerob_env.ros.messages.distros import serialize
from bubblerob_env.ros.messages.topics import MSGTYPES, Topics
from bubblerob_env.specs import EnvSpecs


def _frame(action_type: str):
    env = gym.make(
        "BubbleRob-v0", camera=True, camera_width=8, camera_height=6, action_type=action_type
    )
    env.reset(seed=3)
    action = np.array([0.4, -0.9], dtype=np.float32)
    obs, reward, terminated, truncated, info = env.step(action)
    specs = EnvSpecs.from_env(env)
    env.close()
    return specs, obs, info, action, reward, terminated, truncated


@pytest.mark.parametrize("action_type", ["wheels", "twist"])
@pytest.mark.parametrize("distro", ["noetic", "humble", "jazzy"])
def test_packed_records_equal_rosbags_serialisation(distro, action_type):
    specs, obs, info, action, reward, terminated, truncated = _frame(action_type)
    serializer = FrameSerializer(specs, distro, Topics())
    converter = serializer.converter
    frame = (obs, info, 1_234_567_890_123, 7, action, reward, terminated, truncated)
    values = converter.frame_values(*frame)
    records = serializer.frame(converter.frame_args(*frame), 1_234_567_890_123, 5, stepped=True)
    by_topic = {topic: (stamp, data) for topic, stamp, data in records}
    keys = converter.frame_keys(stepped=True)
    assert {"image", "camera_info", "scan", "action"} <= set(keys)
    assert len(records) == len(keys)
    for key in keys:
        expected = serialize(distro, converter.message(key, values), MSGTYPES[key])
        stamp, data = by_topic[serializer.names[key]]
        assert data == expected, key
        assert stamp == (5 if key in converter.action_keys() else 1_234_567_890_123), key


@pytest.mark.parametrize("distro", ["noetic", "jazzy"])
@pytest.mark.parametrize("kind", ["mcap", "ros1", "raw"])
def test_pack_many_packs_what_pack_one_packs(distro, kind):
    specs, obs, info, action, reward, terminated, truncated = _frame("twist")
    serializer = FrameSerializer(specs, distro, Topics())
    framing = Framing(kind, tuple((name, i) for i, name in enumerate(serializer.names.values())))
    packer = serializer.packer(framing, stepped=True)
    batch = FrameBatch(specs, capacity=3)
    one = b""
    for i in range(3):
        stamp, action_stamp = 5_000_000_001 + i * 50_000_000, 4_000_000_000 + i
        args = (obs, info, stamp, 9 + i, action, reward, terminated, truncated)
        one += packer.pack_one(serializer.converter.frame_args(*args), stamp, action_stamp)
        batch.add(obs, info, stamp, 9 + i, action, action_stamp, reward, terminated, truncated)
    assert packer.pack_many(batch.columns(), 3).tobytes() == one
    assert len(one) == 3 * packer.layout.size


def test_array_slot_without_count_is_rejected():
    specs, *_ = _frame("wheels")
    converter = RosConverter(specs, "jazzy")
    slots = converter.slots()
    slots["ranges"] = Slot("ranges")
    template = converter.message("scan", slots)
    with pytest.raises(ValueError, match="give its count"):
        message_items(converter.store, MSGTYPES["scan"], template, "cdr")


def test_unknown_encoding_is_rejected():
    specs, *_ = _frame("wheels")
    converter = RosConverter(specs, "jazzy")
    template = converter.message("reward", converter.slots())
    with pytest.raises(ValueError, match="encoding"):
        message_items(converter.store, MSGTYPES["reward"], template, "json")


def test_packer_splits_stamps_and_rejects_unknown_slots():
    items = [("I", Slot("log_sec")), ("I", Slot("log_nsec")), ("d", Slot("x"))]
    packer = Packer(items, ["x"])
    assert packer.pack_one((0.5,), 3_000_000_007, 0) == struct.pack("<IId", 3, 7, 0.5)
    columns = {"x": np.array([0.5]), "log_sec": np.array([3]), "log_nsec": np.array([7])}
    assert packer.pack_many(columns, 1).tobytes() == struct.pack("<IId", 3, 7, 0.5)
    with pytest.raises(ValueError, match="neither among"):
        Packer(items, ["y"])
