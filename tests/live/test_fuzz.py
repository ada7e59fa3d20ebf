"""No command message can kill the node: huge, NaN, infinite, short, long and random ones.

In process, with a backend that hands the node's subscriptions to the test (ROS 1 wire bytes).
"""

from __future__ import annotations

import struct

import gymnasium as gym
import numpy as np
from live_helpers import InProcessBackend

from bubblerob_env.ros.live.node import SimNode


def _twist(linear: float, angular: float) -> bytes:
    return struct.pack("<6d", linear, 0.0, 0.0, 0.0, 0.0, angular)


def test_fuzzed_commands_never_kill_the_node_and_the_action_stays_finite():
    backend = InProcessBackend()
    node = SimNode(gym.make("BubbleRob-v0", action_type="wheels"), backend)
    node.publisher.reset(seed=0)
    rng = np.random.default_rng(0)
    big = [1e308, -1e308, 1.7976931348623157e308, 1e300, 5e-324, 1e6, -3.0]
    odd = [float("nan"), float("inf"), -float("inf")]
    payloads = [_twist(a, b) for a in big + odd for b in big + odd]
    payloads += [struct.pack("<f", v) for v in (3.4e38, -3.4e38, float("nan"), 1.0)]
    payloads += [b"", b"\x01", b"\x02", b"\xff" * 3, b"\x00" * 47, b"\x00" * 49]
    payloads += [rng.bytes(int(n)) for n in rng.integers(0, 64, size=200)]
    for i, raw in enumerate(payloads):
        for topic, callback in backend.callbacks.items():
            if "Simulation" in topic or "triggerNextStep" in topic or "SyncMode" in topic:
                continue  # events pile up for the loop; the switches and commands are the inputs
            callback(raw, "*" if i % 2 else None, "/fuzzer")
        if i % 10 == 0:
            action = node.state.action(node.sim_time)
            assert np.all(np.isfinite(action)) and np.all(np.abs(action) <= 1.0), (raw, action)
            node.step_once()
    assert backend.lines  # rejected ones are said, not raised


def test_a_huge_twist_drives_at_full_speed_in_its_direction():
    backend = InProcessBackend()
    node = SimNode(gym.make("BubbleRob-v0", action_type="wheels"), backend)
    node.publisher.reset(seed=0)
    backend.callbacks["/cmd_vel"](_twist(1e308, 0.0), None, "/user")
    np.testing.assert_array_equal(node.state.action(node.sim_time), [1.0, 1.0])
    backend.callbacks["/cmd_vel"](_twist(-1e308, -1e308), None, "/user")
    left, right = node.state.action(node.sim_time)
    assert left < 0 and right < 0 and max(abs(left), abs(right)) == 1.0  # backwards, at full
    assert abs(left) != abs(right)  # and turning, as asked
    backend.callbacks["/leftMotorSpeed"](struct.pack("<f", 3.4e38), None, "/user")
    assert node.state.action(node.sim_time)[0] == 1.0  # a wheel command: clamped to the motor
