"""The fast encoder produces exactly the bytes rosbags would, for every topic and distro."""

from __future__ import annotations

import struct

import gymnasium as gym
import numpy as np
import pytest

from bubblerob_env.ros.convert import EnvSpecs, RosConverter
from bubblerob_env.ros.encode import Slot, compile_message
from bubblerob_env.ros.topics import MSGTYPES


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
def test_compiled_messages_equal_rosbags_serialisation(distro, action_type):
    specs, obs, info, action, reward, terminated, truncated = _frame(action_type)
    converter = RosConverter(specs, distro)
    values = converter.frame_values(
        obs, info, 1_234_567_890_123, 7, action, reward, terminated, truncated
    )
    slots = converter.slots()
    encoding = converter.distro.encoding
    keys = converter.frame_keys(stepped=True)
    assert {"image", "camera_info", "scan", "action"} <= set(keys)
    for key in keys:
        message = converter.message(key, values)
        if encoding == "ros1":
            expected = bytes(converter.store.serialize_ros1(message, MSGTYPES[key]))
        else:
            expected = bytes(
                converter.store.serialize_cdr(message, MSGTYPES[key], little_endian=True)
            )
        template = converter.message(key, slots)
        compiled = compile_message(converter.store, MSGTYPES[key], template, encoding)
        assert compiled.encode(values) == expected, key


def test_array_slot_without_count_is_rejected():
    specs, *_ = _frame("wheels")
    converter = RosConverter(specs, "jazzy")
    slots = converter.slots()
    slots["ranges"] = Slot("ranges")
    template = converter.message("scan", slots)
    with pytest.raises(ValueError, match="give its count"):
        compile_message(converter.store, MSGTYPES["scan"], template, "cdr")


def test_unknown_encoding_is_rejected():
    specs, *_ = _frame("wheels")
    converter = RosConverter(specs, "jazzy")
    template = converter.message("reward", converter.slots())
    with pytest.raises(ValueError, match="encoding"):
        compile_message(converter.store, MSGTYPES["reward"], template, "json")


@pytest.mark.parametrize("distro", ["noetic", "jazzy"])
def test_tuple_encoder_packs_frame_args_as_encode_packs_frame_values(distro):
    specs, obs, info, action, reward, terminated, truncated = _frame("twist")
    converter = RosConverter(specs, distro)
    frame = (obs, info, 5_000_000_001, 9, action, reward, terminated, truncated)
    args, values = converter.frame_args(*frame), converter.frame_values(*frame)
    names = converter.value_names(True)
    encoding = converter.distro.encoding
    for key in converter.frame_keys(stepped=True):
        template = converter.message(key, converter.slots())
        compiled = compile_message(converter.store, MSGTYPES[key], template, encoding)
        assert compiled.tuple_encoder(names)(args) == compiled.encode(values), key


def test_tuple_encoder_splits_stamps_and_rejects_unknown_slots():
    from bubblerob_env.ros.encode import compile_items

    compiled = compile_items([("I", Slot("log_sec")), ("I", Slot("log_nsec")), ("d", Slot("x"))])
    encode = compiled.tuple_encoder(["x"], ("log_ns",))
    assert encode((0.5,), 3_000_000_007) == struct.pack("<IId", 3, 7, 0.5)
    with pytest.raises(ValueError, match="neither among"):
        compiled.tuple_encoder(["y"], ("log_ns",))
