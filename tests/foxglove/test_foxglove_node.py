"""The node on a Foxglove server, seen through Foxglove's own client (``client.mjs``).

Oracles: the env stepped here with the node's seed (its laser readings, its start poses), the
message definitions ``rosbags`` generates, and the stamps the node's start time implies.
"""

from __future__ import annotations

import base64
import math
from typing import Any

import numpy as np
from conftest import (
    DT_NS,
    SEED,
    START_NS,
    bool_cdr,
    finish_client,
    make_env,
    received,
    rosbags_store,
    run_client,
    start_client,
)

from bubblerob_env.ros.messages.distros import message_definition

K = 5


def test_channels_schemas_and_scans_match_the_env(serve: Any) -> None:
    served = serve(sync=True)
    report = run_client(
        served.url,
        [
            {"op": "subscribe", "topics": ["/scan", "/clock", "/simulationStepDone"]},
            {"op": "advertise", "topic": "/triggerNextStep", "encoding": "cdr",
             "schemaName": "std_msgs/msg/Bool"},
            {"op": "publish", "topic": "/triggerNextStep", "base64": bool_cdr(True), "repeat": K},
            # After each step's messages (not after the reset's, which may come first).
            {"op": "waitFor", "topic": "/simulationStepDone", "count": K},
        ],
    )  # fmt: skip
    info = report["serverInfo"]
    assert {"clientPublish", "services", "time"} <= set(info["capabilities"])
    assert info["supportedEncodings"] == ["json", "cdr"]

    # Every topic the ROS node publishes, with its ROS 2 type and definition, as CDR.
    sink, names = served.node.publisher.sink, served.node.names
    expected = {topic: sink.msgtype(topic) for topic in sink.topics}
    expected |= {names["step_done"]: "std_msgs/msg/Bool", names["state"]: "std_msgs/msg/Int32"}
    expected |= {"/bubblerob/robot_model": "visualization_msgs/msg/Marker"}  # the robot's body
    assert {c["topic"]: c["schemaName"] for c in report["channels"]} == expected
    assert {"/scan", "/odom", "/tf", "/tf_static", "/clock", "/map"} <= set(expected)
    for channel in report["channels"]:
        assert (channel["encoding"], channel["schemaEncoding"]) == ("cdr", "ros2msg")
        assert channel["schema"] == message_definition("jazzy", channel["schemaName"])[0]

    # K scans, one per triggered step (and the reset's, if the client was in time for it), equal
    # to the env's own readings at the same stamps.
    scans = received(report, "/scan", "sensor_msgs/msg/LaserScan")
    env = make_env()
    obs, _ = env.reset(seed=SEED)
    readings = [obs["laser"]] + [
        env.step(np.zeros(2, dtype=np.float32))[0]["laser"] for _ in range(K)
    ]
    env.close()
    steps = []
    for log_time, scan in scans:
        stamp = scan.header.stamp.sec * 10**9 + scan.header.stamp.nanosec
        step, rest = divmod(stamp - START_NS, DT_NS)
        assert stamp == log_time and rest == 0
        steps.append(step)
        laser = readings[step].astype(np.float32)
        laser[laser >= scan.range_max] = np.inf
        laser[laser < scan.range_min] = -np.inf
        np.testing.assert_array_equal(scan.ranges, laser)
    assert steps[-K:] == list(range(1, K + 1))
    clocks = received(report, "/clock", "rosgraph_msgs/msg/Clock")
    last = clocks[-1][1].clock
    assert int(report["time"]) == last.sec * 10**9 + last.nanosec == START_NS + K * DT_NS


def test_late_subscribers_get_the_latched_topics_and_two_clients_both_receive(serve: Any) -> None:
    served = serve(rate_factor=2.0)
    served.wait_steps(5)
    topics = ["/tf_static", "/map", "/simulationState", "/odom"]
    plan = [{"op": "subscribe", "topics": topics}] + [
        {"op": "waitFor", "topic": topic, "count": 1 if topic != "/odom" else 10}
        for topic in topics
    ]
    reports = [finish_client(p) for p in [start_client(served.url, plan) for _ in range(2)]]
    for report in reports:
        (_, tf_static), *_ = received(report, "/tf_static", "tf2_msgs/msg/TFMessage")
        frames = {(t.header.frame_id, t.child_frame_id) for t in tf_static.transforms}
        assert ("map", "odom") in frames
        (_, grid), *_ = received(report, "/map", "nav_msgs/msg/OccupancyGrid")
        assert grid.info.width * grid.info.height == len(grid.data) > 0
        (_, state), *_ = received(report, "/simulationState", "std_msgs/msg/Int32")
        assert state.data == 1  # running
        odoms = received(report, "/odom", "nav_msgs/msg/Odometry")
        assert len(odoms) >= 10 and all(a[0] < b[0] for a, b in zip(odoms, odoms[1:], strict=False))


def _twist(linear: float, angular: float) -> dict[str, Any]:
    return {"linear": {"x": linear, "y": 0, "z": 0}, "angular": {"x": 0, "y": 0, "z": angular}}


def _pose(odom: Any) -> tuple[float, float, float]:
    p, q = odom.pose.pose.position, odom.pose.pose.orientation
    return p.x, p.y, math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y**2 + q.z**2))


def _drive(message: dict[str, Any]) -> list[dict[str, Any]]:
    """Publish ``message`` on /cmd_vel every 0.05 s for half a second (2 simulated s at rate 4;
    the watchdog is 0.5 simulated s)."""
    step = {"op": "publish", "topic": "/cmd_vel", **message}
    return [s for _ in range(10) for s in (step, {"op": "sleep", "ms": 50})]


def test_teleop_twists_move_odom_and_the_reset_service_starts_the_next_episode(
    serve: Any,
) -> None:
    store = rosbags_store()
    vector = store.types["geometry_msgs/msg/Vector3"]
    spin = store.types["geometry_msgs/msg/Twist"](linear=vector(0, 0, 0), angular=vector(0, 0, 1))
    spin_cdr = bytes(store.serialize_cdr(spin, "geometry_msgs/msg/Twist"))
    served = serve(rate_factor=4.0)
    report = run_client(
        served.url,
        [
            {"op": "subscribe", "topics": ["/odom"]},
            {"op": "waitFor", "topic": "/odom", "count": 2},
            # What Foxglove's Teleop panel sends: JSON, its schema named ROS 1 style.
            {"op": "advertise", "topic": "/cmd_vel", "encoding": "json",
             "schemaName": "geometry_msgs/Twist"},
            {"op": "mark"}, *_drive({"json": _twist(0.2, 0.0)}), {"op": "mark"},
            {"op": "advertise", "topic": "/cmd_vel", "encoding": "cdr",
             "schemaName": "geometry_msgs/msg/Twist"},
            *_drive({"base64": base64.b64encode(spin_cdr).decode()}), {"op": "mark"},
            {"op": "call", "service": "/reset_simulation", "encoding": "cdr",
             "base64": base64.b64encode(bytes([0, 1, 0, 0, 0])).decode()},
            {"op": "sleep", "ms": 200}, {"op": "mark"},
        ],
    )  # fmt: skip
    odoms = [  # (index among all messages, pose)
        (i, _pose(received({"messages": [m]}, "/odom", "nav_msgs/msg/Odometry")[0][1]))
        for i, m in enumerate(report["messages"])
        if m["topic"] == "/odom"
    ]
    first = odoms[0][1]
    driven, turned, reset = (
        next(pose for i, pose in reversed(odoms) if i < mark) for mark in report["marks"][1:]
    )
    starts = []
    for seed in (SEED, SEED + 1):
        env = make_env()
        _, info = env.reset(seed=seed)
        env.close()
        starts.append((info["odom_x"], info["odom_y"]))
    assert math.dist(first[:2], starts[0]) < 1e-3
    assert math.dist(first[:2], driven[:2]) > 0.1  # JSON: 0.2 m/s for about 2 simulated s
    assert abs(math.remainder(driven[2] - first[2], math.tau)) < 0.1
    assert abs(math.remainder(turned[2] - driven[2], math.tau)) > 0.5  # CDR: 1 rad/s
    assert math.dist(turned[:2], driven[:2]) < 0.05

    # Reset: the next episode starts where the env, reset with the next seed, starts.
    assert not report["failures"], report["failures"]
    (answer,) = report["responses"]
    assert answer["encoding"] == "cdr"
    response = base64.b64decode(answer["data"])
    assert response[4] == 1 and response[12:-1] == b"episode 2 queued"  # success, message
    assert math.dist(reset[:2], starts[1]) < 1e-3
