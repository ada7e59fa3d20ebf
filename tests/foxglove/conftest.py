"""Fixtures of the Foxglove tests: a node served in this process, and Foxglove's own client.

The client is ``client.mjs`` (``@foxglove/ws-protocol`` on Node), installed by ``npm ci`` in this
directory (``make test-setup`` runs it). Without Node or those packages the tests skip, saying so.
Everything is on loopback, on a port the OS picks.
"""

from __future__ import annotations

import base64
import functools
import json
import shutil
import subprocess
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import pytest

CLIENT_DIR = Path(__file__).resolve().parent
SEED = 3
START_NS = 1_700_000_000 * 10**9
"""The node's first stamp (``NodeConfig.start_time``): stamps tell which step a message is of."""
DT_NS = 50_000_000

NODE_MISSING = (
    "the Foxglove client tests need Node.js and @foxglove/ws-protocol: run `make test-setup` "
    "(npm ci in tests/foxglove)"
    if shutil.which("node") is None
    or not (CLIENT_DIR / "node_modules/@foxglove/ws-protocol").is_dir()
    else None
)
"""Why the tests that run Foxglove's client skip (``None``: they run)."""


@pytest.fixture(autouse=True)
def _needs_the_sdk() -> None:
    """Every test here serves Foxglove: skip, saying why, without the [foxglove] extra."""
    pytest.importorskip("foxglove", reason="the Foxglove tests need the [foxglove] extra")


@dataclass
class Served:
    """A node on a Foxglove server in a background thread, and what its backend logged."""

    url: str
    node: Any
    backend: Any
    logs: list[tuple[str, str]] = field(default_factory=list)

    def wait_steps(self, count: int, timeout: float = 10.0) -> None:
        """Wait until the node has taken ``count`` steps (it starts with a reset and the map)."""
        deadline = time.monotonic() + timeout
        while self.node.steps < count:
            assert time.monotonic() < deadline, (
                f"the node took {self.node.steps} steps in {timeout} s"
            )
            time.sleep(0.01)


def make_env(**kwargs: Any) -> gym.Env[Any, Any]:
    """The node's env (wheels) with ``kwargs``."""
    return gym.make("BubbleRob-v0", action_type="wheels", **kwargs)


@pytest.fixture
def serve() -> Iterator[Any]:
    """``serve(sync=..., rate_factor=...)``: start a node served to Foxglove; stopped after."""
    from bubblerob_env.ros.live.foxglove import FoxgloveBackend
    from bubblerob_env.ros.live.foxglove_services import serve_simulation
    from bubblerob_env.ros.live.node import NodeConfig, SimNode

    started: list[tuple[Served, threading.Thread]] = []

    def start(**config: Any) -> Served:
        logs: list[tuple[str, str]] = []
        backend = FoxgloveBackend(port=0, logger=lambda level, text: logs.append((level, text)))
        settings = NodeConfig(seed=SEED, start_time=START_NS / 1e9, **config)
        node = SimNode(make_env(), backend, config=settings)
        serve_simulation(backend, node)
        thread = threading.Thread(target=node.run, kwargs={"duration": 60.0}, daemon=True)
        thread.start()
        served = Served(backend.url, node, backend, logs)
        started.append((served, thread))
        return served

    yield start
    for served, thread in started:
        served.node.request_stop()
        thread.join(10)
        served.node.close()
        served.backend.shutdown()


def run_client(url: str, plan: list[dict[str, Any]], subprotocol: str | None = None) -> Any:
    """Run ``client.mjs`` with ``plan`` against ``url``; its JSON report (fails on its error)."""
    proc = start_client(url, plan, subprotocol)
    return finish_client(proc)


def start_client(
    url: str, plan: list[dict[str, Any]], subprotocol: str | None = None
) -> subprocess.Popen[str]:
    """``client.mjs`` started in the background (see :func:`finish_client`); skips without Node."""
    if NODE_MISSING:
        pytest.skip(NODE_MISSING)
    args = ["node", str(CLIENT_DIR / "client.mjs"), url, json.dumps(plan)]
    return subprocess.Popen(
        args + ([subprotocol] if subprotocol else []),
        cwd=CLIENT_DIR,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def finish_client(proc: subprocess.Popen[str], timeout: float = 30.0) -> Any:
    """The JSON report of a client started with :func:`start_client`."""
    out, err = proc.communicate(timeout=timeout)
    assert proc.returncode == 0, f"client failed ({proc.returncode}): {out[-2000:]} {err[-2000:]}"
    return json.loads(out)


def received(report: Any, topic: str, msgtype: str, since: int = 0) -> list[tuple[int, Any]]:
    """``(log time, decoded message)`` of every ``topic`` message in ``report`` (rosbags' CDR)."""
    store = rosbags_store()
    return [
        (int(m["t"]), store.deserialize_cdr(base64.b64decode(m["data"]), msgtype))
        for m in report["messages"][since:]
        if m["topic"] == topic
    ]


@functools.cache
def rosbags_store() -> Any:
    """``rosbags``' own type store of ROS 2 Jazzy (not the project's: an independent decoder)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_JAZZY)


def bool_cdr(value: bool) -> str:
    """A ``std_msgs/msg/Bool`` in CDR, base64 (hand-packed: header, one byte)."""
    return base64.b64encode(bytes([0, 1, 0, 0, int(value)])).decode()
