"""``LiveNavigation`` in-process (no ROS): goals in ``odom`` moved by ``map -> odom``, bad ones.

The live tests (``test_nav_live.py``) see the node from real clients with ``map -> odom`` near
the identity; here a fake backend and a fake localiser give it a quarter turn, so that the
rotation is checked against the formula in the test.
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
from live_helpers import InProcessBackend

from bubblerob_env.ros.live import RosLivePublisher
from bubblerob_env.ros.live.navigation import GOAL_INPUT, LiveNavigation
from bubblerob_env.ros.messages.distros import deserialize, serialize, typestore

DISTRO = "noetic"
GOAL_TYPE = "geometry_msgs/msg/PoseStamped"


class Filter:
    def map_to_odom(self) -> np.ndarray:
        return np.array([0.5, -0.2, math.pi / 2])


class Localizer:
    filter = Filter()
    pose = (0.1, -1.3, 0.3)


def goal_bytes(x: float, y: float, frame: str) -> bytes:
    types = typestore(DISTRO).types
    header = types["std_msgs/msg/Header"](
        seq=0, stamp=types["builtin_interfaces/msg/Time"](sec=0, nanosec=0), frame_id=frame
    )
    pose = types["geometry_msgs/msg/Pose"](
        position=types["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
        orientation=types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
    )
    return serialize(DISTRO, types[GOAL_TYPE](header=header, pose=pose), GOAL_TYPE)


def started() -> tuple[InProcessBackend, LiveNavigation, list[tuple[str, str, str]]]:
    backend = InProcessBackend()
    env = gym.make("BubbleRobNav-v0", num_obstacles=[0, 0], start_pose=[0.0, -1.4, 0.0])
    publisher = RosLivePublisher(env, backend, start_time=1_700_000_000)
    warned: list[tuple[str, str, str]] = []
    base: Any = env.unwrapped
    navigation = LiveNavigation(base, publisher, publisher.topics, lambda *w: warned.append(w))
    publisher.reset(seed=0)
    return backend, navigation, warned


def test_a_goal_in_odom_is_moved_by_map_to_odom_and_planned_from_the_estimate():
    backend, navigation, warned = started()
    backend.callbacks[GOAL_INPUT](goal_bytes(1.0, 0.3, "odom"), None, "test")
    navigation.apply(Localizer())  # type: ignore[arg-type]
    assert not warned
    # map = (0.5, -0.2) + R(90 deg) (1.0, 0.3) = (0.5 - 0.3, -0.2 + 1.0)
    goal = deserialize(DISTRO, backend.sent["/move_base/current_goal"][-1], GOAL_TYPE)
    placed = (goal.pose.position.x, goal.pose.position.y)
    assert np.allclose(placed, (0.2, 0.8), atol=1e-12), placed
    plan = deserialize(DISTRO, backend.sent["/plan"][-1], "nav_msgs/msg/Path")
    first = plan.poses[0].pose.position
    assert (first.x, first.y) == (0.1, -1.3)  # the estimate, not the truth (0, -1.4)
    reached = backend.sent["/goal_reached"]
    assert deserialize(DISTRO, reached[-1], "std_msgs/msg/Bool").data is False
    assert navigation.goals == 1


def test_bad_goals_are_one_warning_each_and_change_nothing():
    backend, navigation, warned = started()
    sent = len(backend.sent["/move_base/current_goal"])
    callback = backend.callbacks[GOAL_INPUT]
    callback(b"\x01\x02\x03", None, "a")  # too short for the type
    callback(goal_bytes(0.0, 0.0, "map"), "geometry_msgs/Twist", "b")
    callback(goal_bytes(0.0, 0.0, "world"), None, "c")
    callback(goal_bytes(math.nan, 0.0, "map"), None, "d")
    navigation.apply(None)
    callback(goal_bytes(1.95, 0.0, "map"), None, "e")
    navigation.apply(None)
    reasons = [reason for _, reason, _ in warned]
    assert reasons == ["malformed", "wrong type", "wrong-frame", "bad goal", "bad goal"], warned
    assert "frame_id 'world'" in warned[2][2] and "'map' or 'odom'" in warned[2][2]
    assert "goal (nan, 0.0) is outside the arena" in warned[3][2]
    assert "inside an obstacle or a wall" in warned[4][2]
    assert len(backend.sent["/move_base/current_goal"]) == sent and navigation.goals == 0


def test_with_a_driver_wheel_commands_are_unused_and_said_so_once():
    from bubblerob_env.ros.live.node import NodeConfig, SimNode

    backend = InProcessBackend()
    env = gym.make("BubbleRobNav-v0", num_obstacles=[0, 0], action_type="wheels")
    seen: list[Any] = []

    def driver(obs: Any, episode_start: bool) -> np.ndarray:
        seen.append((obs["goal"].copy(), episode_start))
        return np.array([0.3, 0.3], dtype=np.float32)

    config = NodeConfig(rate_factor=0.0, watchdog=0.0, start_time=1_700_000_000)
    node = SimNode(env, backend, config=config, driver=driver)
    types = typestore(DISTRO).types
    vector = types["geometry_msgs/msg/Vector3"]
    twist = types["geometry_msgs/msg/Twist"](
        linear=vector(x=-0.2, y=0.0, z=0.0), angular=vector(x=0.0, y=0.0, z=0.0)
    )
    backend.callbacks["/cmd_vel"](
        serialize(DISTRO, twist, "geometry_msgs/msg/Twist"), "geometry_msgs/Twist", "t"
    )
    assert node.run(max_steps=3) == 3
    node.close()
    assert [start for _, start in seen] == [True, False, False]
    assert all(goal.shape == (2,) for goal, _ in seen)
    actions = [deserialize(DISTRO, raw, "std_msgs/msg/Float64MultiArray").data
               for raw in backend.sent["/bubblerob/action"]]  # fmt: skip
    assert len(actions) == 3 and np.allclose(actions, np.float32(0.3), rtol=0, atol=0)
    unused = [line for line in backend.lines if "wheel command" in line]
    assert unused == ["ignoring a wheel command message on /cmd_vel: --policy drives the robot: "
                      "commands are unused"], backend.lines  # fmt: skip
