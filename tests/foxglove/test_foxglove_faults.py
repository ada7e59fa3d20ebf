"""Robustness of the Foxglove node, and the command's lines: what a bad client or a bad start does.

A flood of ``/cmd_vel``, malformed JSON and CDR, a message on a topic nobody reads and a client
that vanishes mid-frame must not stop the node or slow its rate; each kind of fault is logged
once. ``bubblerob node --foxglove`` says where to connect and with which subprotocol, and a port
in use or a missing extra is one line.
"""

from __future__ import annotations

import base64
import collections
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from conftest import bool_cdr, finish_client, received, run_client, start_client

import bubblerob_env.extras
from bubblerob_cli.main import main

TWIST = {"linear": {"x": 0.1}, "angular": {"z": 0.2}}
EMPTY = base64.b64encode(bytes([0, 1, 0, 0, 0])).decode()
"""An empty request (``std_srvs/srv/Trigger_Request``) in CDR."""
NAN_TWIST = base64.b64encode(
    bytes([0, 1, 0, 0]) + b"\0" * 40 + bytes.fromhex("000000000000f87f")
).decode()


def test_floods_and_malformed_messages_neither_stop_nor_slow_the_node(serve: Any) -> None:
    served = serve(rate_factor=1.0)
    bad = [
        ("json", "geometry_msgs/Twist", {"text": "{not json"}),
        ("json", "geometry_msgs/Twist", {"json": {"linear": 5}}),
        ("json", "geometry_msgs/Twist", {"json": {"linear": {"x": "fast"}}}),
        ("cdr", "geometry_msgs/msg/Twist", {"base64": "AAEAAAE="}),  # 1 byte of 48
        ("cdr", "geometry_msgs/msg/Twist", {"base64": NAN_TWIST}),
        ("cdr", "std_msgs/msg/Bool", {"base64": bool_cdr(True)}),  # the wrong type
    ]
    flood: list[dict[str, Any]] = [
        {"op": "advertise", "topic": "/cmd_vel", "encoding": "json",
         "schemaName": "geometry_msgs/Twist"},
        {"op": "publish", "topic": "/cmd_vel", "json": TWIST, "repeat": 5000},
    ]  # fmt: skip
    for encoding, schema, message in bad:
        flood += [
            {"op": "advertise", "topic": "/cmd_vel", "encoding": encoding, "schemaName": schema},
            {"op": "publish", "topic": "/cmd_vel", "repeat": 50, **message},
        ]
    flood += [
        {"op": "advertise", "topic": "/nobody", "encoding": "json", "schemaName": "std_msgs/Bool"},
        {"op": "publish", "topic": "/nobody", "json": {"data": True}, "repeat": 20},
        {"op": "sleep", "ms": 200},
    ]
    vanishing = [{"op": "subscribe", "topics": ["/scan"]}, {"op": "abortMidMessage"}]
    watch = [
        {"op": "subscribe", "topics": ["/clock"]},
        {"op": "waitFor", "topic": "/clock", "count": 40},
    ]

    served.wait_steps(1)
    steps, began = served.node.steps, time.monotonic()
    time.sleep(1.0)
    quiet = (served.node.steps - steps) / (time.monotonic() - began)
    steps, began = served.node.steps, time.monotonic()
    watcher = start_client(served.url, watch)
    clients = [start_client(served.url, flood), start_client(served.url, vanishing)]
    reports = [finish_client(client) for client in clients[:1]]
    clients[1].wait(10)
    report = finish_client(watcher)
    rate = (served.node.steps - steps) / (time.monotonic() - began)
    # Its rate, flood or not (20 steps/s; relative, for a loaded machine).
    assert rate > 0.75 * quiet, f"{rate:.1f} steps/s under the flood, {quiet:.1f} before"
    clocks = received(report, "/clock", "rosgraph_msgs/msg/Clock")
    assert len(clocks) >= 40
    assert not reports[0].get("error")

    # Still serving: a new client gets /odom.
    after = run_client(
        served.url,
        [{"op": "subscribe", "topics": ["/odom"]}, {"op": "waitFor", "topic": "/odom", "count": 3}],
    )
    assert len(received(after, "/odom", "nav_msgs/msg/Odometry")) >= 3

    # One line per kind of fault.
    kinds = collections.Counter(re.sub(r":.*", "", text) for _, text in served.logs)
    assert kinds == {
        "ignoring malformed JSON on /cmd_vel": 1,
        "ignoring a malformed message on /cmd_vel": 1,
        "ignoring a wrong type message on /cmd_vel": 1,
        "ignoring messages on /nobody": 1,
    }, served.logs


def test_the_command_says_where_and_how_to_connect_and_serves_its_services(tmp_path: Path) -> None:
    args = [
        "node",
        "--foxglove",
        "--port",
        "0",
        "--duration",
        "6",
        "--rate-factor",
        "2",
        "--watchdog",
        "0",
    ]
    proc = subprocess.Popen(
        [sys.executable, "-m", "bubblerob_cli", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        ready = proc.stdout.readline()
        match = re.search(
            r"Foxglove at (ws://127\.0\.0\.1:\d+) \(WebSocket subprotocol foxglove\.sdk\.v1\)",
            ready,
        )
        assert match, ready
        url = match.group(1)
        for _ in range(2):  # foxglove-sdk logs each; the command, one line per kind
            assert run_client(url, [], "foxglove.websocket.v1") == {"httpStatus": 400}
        report = run_client(
            url,
            [
                {"op": "subscribe", "topics": ["/simulationState"]},
                {"op": "waitFor", "topic": "/simulationState", "count": 1},
                {"op": "call", "service": "/pause_simulation", "encoding": "cdr", "base64": EMPTY},
                {"op": "waitFor", "topic": "/simulationState", "count": 2},
                {"op": "call", "service": "/step_simulation", "encoding": "cdr", "base64": EMPTY},
                {"op": "waitFor", "topic": "/simulationState", "count": 3},
                {"op": "setParameters", "parameters": [{"name": "/bubblerob.seed", "value": 9}]},
                {"op": "getParameters", "names": []},
            ],
        )  # fmt: skip
        parameters = {p["name"]: p["value"] for p in report["parameters"]}
        assert parameters["/bubblerob.env"] == "BubbleRob-v0"
        assert (parameters["/bubblerob.seed"], parameters["/bubblerob.rate_factor"]) == (0, 2.0)
        names = {s["name"]: s["type"] for s in report["services"]}
        assert names == dict.fromkeys(
            ["/reset_simulation", "/pause_simulation", "/resume_simulation", "/step_simulation"],
            "std_srvs/srv/Trigger",
        )
        states = [m.data for _, m in received(report, "/simulationState", "std_msgs/msg/Int32")]
        assert states == [1, 2, 1]  # running, paused, running (in sync mode: one step)
        proc.send_signal(signal.SIGINT)  # Ctrl-C: the node closes and says what it did
        out, err = proc.communicate(timeout=20)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, err
    assert err.count("handshake failed") == 1, err
    assert err.count("ignoring a parameter change on /bubblerob.seed") == 1, err  # read-only
    assert re.fullmatch(
        r"bubblerob node: \d+ steps in [\d.]+ s \([\d.]+ steps/s\), \d+ messages published\n", out
    )


def test_a_port_in_use_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        with pytest.raises(SystemExit) as exit_info:
            main(["node", "--foxglove", "--port", str(port), "--steps", "1"])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert f"127.0.0.1:{port}" in err and "in use" in err and "--port" in err


def test_without_the_extra_one_line_names_it(monkeypatch: pytest.MonkeyPatch) -> None:
    real = bubblerob_env.extras.missing_requirements
    monkeypatch.setattr(
        bubblerob_env.extras,
        "missing_requirements",
        lambda extra: ["foxglove-sdk"] if extra == "foxglove" else real(extra),
    )
    with pytest.raises(SystemExit) as exit_info:
        main(["node", "--foxglove", "--steps", "1"])
    assert str(exit_info.value.code) == (
        "bubblerob node --foxglove needs the [foxglove] extra: pip install 'bubblerob[foxglove]' "
        "(missing: foxglove-sdk)"
    )
