"""``RosLivePublisher`` and ``LiveSink`` with an in-process backend: the recorder's exact bytes."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
from rosbags.rosbag1 import Reader

from bubblerob_env.ros import RosBagRecorder
from bubblerob_env.ros.live import LiveBackend, RosLivePublisher
from bubblerob_env.ros.live.backend import Publish, RawCallback


class FakeBackend(LiveBackend):
    ros_version = 1
    distro = "noetic"

    def __init__(self) -> None:
        self.sent: dict[str, list[bytes]] = {}
        self.types: dict[str, str] = {}

    def advertise(self, topic: str, msgtype: str, latched: bool = False) -> Publish:
        self.types[topic] = msgtype
        return lambda data: self.sent.setdefault(topic, []).append(bytes(data))

    def subscribe(self, topic: str, msgtype: str, callback: RawCallback) -> None:
        raise AssertionError("the wrapper subscribes to nothing")

    def ok(self) -> bool:
        return True

    def shutdown(self, reason: str = "done") -> None:
        pass

    def log(self, level: str, text: str) -> None:
        pass


def drive(env: gym.Env) -> None:
    rng = np.random.default_rng(3)
    for episode in range(2):
        env.reset(seed=10 + episode)
        for _ in range(30):
            env.step(rng.uniform(-1, 1, 2).astype(np.float32))


def test_live_publisher_sends_the_recorders_bytes(tmp_path):
    backend = FakeBackend()
    live = RosLivePublisher(gym.make("BubbleRob-v0", camera=True), backend)
    drive(live)
    live.close()
    start = f"{live.start_time_ns // 10**9}.{live.start_time_ns % 10**9:09d}"  # the wall clock
    env = gym.make("BubbleRob-v0", camera=True)
    with RosBagRecorder(env, tmp_path / "b", format="ros1", start_time=start) as r:
        drive(r)
    assert r.start_time_ns == live.start_time_ns
    recorded: dict[str, list[bytes]] = {}
    with Reader(tmp_path / "b.bag") as reader:
        for connection, _, raw in reader.messages():
            recorded.setdefault(connection.topic, []).append(bytes(raw))
    assert set(backend.sent) == set(recorded)
    for topic, messages in recorded.items():
        assert len(backend.sent[topic]) == len(messages), topic
        if topic != "/bubblerob/episode":
            assert backend.sent[topic] == messages, topic
    assert backend.types["/scan"] == "sensor_msgs/msg/LaserScan"


def test_muted_topics_are_not_sent():
    backend = FakeBackend()
    live = RosLivePublisher(gym.make("BubbleRob-v0"), backend)
    live.reset(seed=0)
    live.sink.mute(["/scan"])
    live.step(np.zeros(2, dtype=np.float32))
    live.sink.mute(["/scan"], muted=False)
    live.step(np.zeros(2, dtype=np.float32))
    assert len(backend.sent["/scan"]) == 2 and len(backend.sent["/odom"]) == 3
    live.close()


def test_live_episode_metadata_is_the_recorders_with_rng_state(tmp_path):
    from bubblerob_env.ros.messages.distros import deserialize

    def unseeded(env: gym.Env) -> None:
        env.reset(seed=4)
        env.step(np.zeros(2, dtype=np.float32))
        env.reset()  # unseeded: replay needs the generator's state
        env.step(np.zeros(2, dtype=np.float32))

    backend = FakeBackend()
    live = RosLivePublisher(gym.make("BubbleRob-v0"), backend, start_time="2024-05-01")
    unseeded(live)
    live.close()
    env = gym.make("BubbleRob-v0")
    with RosBagRecorder(env, tmp_path / "b", format="ros1", start_time=1714521600) as recorder:
        unseeded(recorder)

    def decode(raw: bytes) -> dict:
        return json.loads(deserialize("noetic", raw, "std_msgs/msg/String").data)

    published = [decode(raw) for raw in backend.sent["/bubblerob/episode"]]
    with Reader(tmp_path / "b.bag") as reader:
        recorded = [
            decode(bytes(raw))
            for connection, _, raw in reader.messages()
            if connection.topic == "/bubblerob/episode"
        ]
    assert len(published) == len(recorded) == 2
    for live_meta, bag_meta in zip(published, recorded, strict=True):
        assert live_meta.pop("format") == "live" and bag_meta.pop("format") == "ros1"
        assert live_meta == bag_meta
    assert published[0]["rng_state"] is None and published[1]["rng_state"]["bit_generator"]
    assert published[0]["start_time_ns"] == 1714521600 * 10**9
