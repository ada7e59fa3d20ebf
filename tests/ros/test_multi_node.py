"""``MultiSimNode`` in process (a fake backend): names, one /clock, inputs, determinism."""

from __future__ import annotations

import struct
from typing import Any

import numpy as np
import pytest

import bubblerob_env
from bubblerob_env.ros.live.backend import LiveBackend, Publish, RawCallback
from bubblerob_env.ros.live.multi_node import MultiSimNode
from bubblerob_env.ros.live.node import NodeConfig
from bubblerob_env.ros.messages.distros import deserialize
from bubblerob_env.ros.messages.robots import robot_topics
from bubblerob_env.ros.messages.topics import Topics

START = "1700000000"


class FakeBackend(LiveBackend):
    ros_version = 1
    distro = "noetic"

    def __init__(self) -> None:
        self.sent: dict[str, list[bytes]] = {}
        self.advertised: list[str] = []
        self.handlers: dict[str, RawCallback] = {}

    def advertise(self, topic: str, msgtype: str, latched: bool = False) -> Publish:
        self.advertised.append(topic)
        return lambda data: self.sent.setdefault(topic, []).append(bytes(data))

    def subscribe(self, topic: str, msgtype: str, callback: RawCallback) -> None:
        self.handlers[topic] = callback

    def send(self, topic: str, raw: bytes) -> None:
        self.handlers[topic](raw, None, "test")

    def ok(self) -> bool:
        return True

    def shutdown(self, reason: str = "done") -> None:
        pass

    def log(self, level: str, text: str) -> None:
        pass


def make_node(naming: str = "namespace", **config: Any) -> tuple[MultiSimNode, FakeBackend]:
    backend = FakeBackend()
    env = bubblerob_env.parallel_env(num_robots=2, max_episode_steps=200)
    settings = NodeConfig(start_time=START, **{"sync": True, "watchdog": 0.5, **config})
    return MultiSimNode(env, backend, naming=naming, config=settings), backend


def travelled(backend: FakeBackend, topic: str) -> float:
    """Metres between the first and latest pose on an odometry topic."""
    first, last = (
        deserialize("noetic", backend.sent[topic][i], "nav_msgs/msg/Odometry").pose.pose.position
        for i in (0, -1)
    )
    return float(np.hypot(last.x - first.x, last.y - first.y))


def twist(v: float, w: float) -> bytes:
    return struct.pack("<6d", v, 0, 0, 0, 0, w)


def test_names_frames_and_exactly_one_clock():
    node, backend = make_node()
    node._new_episode()
    node.step_once()
    assert backend.advertised.count("/clock") == 1
    assert backend.advertised.count("/tf_static") == 1  # shared: one latched message for all
    for k in (0, 1):
        assert f"/robot_{k}/scan" in backend.advertised
        assert f"/robot_{k}/cmd_vel" in backend.handlers
        assert f"/robot_{k}/leftMotorSpeed" in backend.handlers
        assert f"/robot_{k}/laser_switch" in backend.handlers
        assert f"/robot_{k}/cmd_vel" not in backend.advertised  # an input: never echoed
    assert (
        "/triggerNextStep" in backend.handlers
        and "/robot_0/triggerNextStep" not in backend.handlers
    )
    odom = deserialize("noetic", backend.sent["/robot_1/odom"][0], "nav_msgs/msg/Odometry")
    assert (odom.header.frame_id, odom.child_frame_id) == ("robot_1/odom", "robot_1/base_link")
    static = deserialize("noetic", backend.sent["/tf_static"][-1], "tf2_msgs/msg/TFMessage")
    pairs = {(t.header.frame_id, t.child_frame_id) for t in static.transforms}
    assert {("map", "robot_0/odom"), ("map", "robot_1/odom")} <= pairs
    assert len(backend.sent["/clock"]) == 2  # the reset's and the step's
    grid = deserialize("noetic", backend.sent["/robot_0/map"][0], "nav_msgs/msg/OccupancyGrid")
    assert grid.header.frame_id == "map"
    node.close()


def test_tutorial_names_carry_the_robot_index():
    topics = robot_topics(Topics(), 1, "tutorial").resolved()
    assert topics["left_motor_speed"] == "/leftMotorSpeed1"
    assert topics["sensor_trigger"] == "/sensorTrigger1"
    assert topics["simulation_time"] == "/simTime1"
    assert topics["tf"] == "/tf" and "clock" not in topics
    with pytest.raises(ValueError, match="naming"):
        robot_topics(Topics(), 0, "suffix")


def test_each_robot_has_its_own_command_and_watchdog():
    node, backend = make_node()
    node._new_episode()
    backend.send("/robot_1/cmd_vel", twist(0.3, 0.0))
    for _ in range(5):  # 0.25 s: within the watchdog
        node.step_once()
    # robot 0 had no command: it only settles on its wheels (under a millimetre)
    assert travelled(backend, "/robot_0/odom") < 0.002
    assert travelled(backend, "/robot_1/odom") > 0.03
    backend.send("/robot_0/cmd_vel", twist(0.3, 0.0))  # robot 0 now; robot 1's goes stale
    for _ in range(30):
        node.step_once()
    assert node.channels[1].state.watchdog_trips == 1 and node.channels[0].state.watchdog_trips == 1
    velocities = node.env.batch.core.velocity
    assert np.allclose(velocities, 0.0, atol=1e-3)  # both watchdogs stopped their own robot
    node.close()


def test_sync_mode_is_deterministic():
    def scans() -> list[bytes]:
        node, backend = make_node(seed=7)
        node._new_episode()
        backend.send("/robot_0/leftMotorSpeed", struct.pack("<f", 4.0))
        for _ in range(12):
            node.step_once()
        node.close()
        return backend.sent["/robot_0/scan"] + backend.sent["/robot_1/scan"]

    first, second = scans(), scans()
    assert first == second and len(first) > 4
