"""Fixtures for the live-node tests: a real ``rosmaster`` on a free loopback port, and nodes.

Everything runs as subprocesses with ``ROS_MASTER_URI``/``ROS_HOSTNAME`` set to that master; each
fixture stops what it started, also when a test fails.
"""

from __future__ import annotations

import subprocess
from collections.abc import Iterator
from typing import Any

import pytest
from live_helpers import SKIP_REASON, Master, Node, free_port, stop

from bubblerob_env.ros.live.ros1 import check_master


@pytest.fixture(scope="session")
def master(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Master]:
    """A ``rosmaster --core`` on a free loopback port, stopped at the end."""
    if SKIP_REASON is not None:
        pytest.skip(SKIP_REASON)
    home = tmp_path_factory.mktemp("ros_home")
    for _ in range(3):
        port = free_port()
        m = Master(port, home)
        proc = m.popen(
            ["/usr/bin/rosmaster", "--core", "-p", str(port)],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
        )
        try:
            check_master(m.uri, timeout=10)
        except Exception:
            stop(proc)
            continue
        try:
            yield m
        finally:
            m.clients.close()
            stop(proc)
        return
    pytest.fail("could not start rosmaster")


@pytest.fixture(scope="module")
def start_node(master: Master) -> Iterator[Any]:
    """``start_node(*args)`` starts a node (module scope: shared by a module's tests)."""
    nodes: list[Node] = []

    def start(*args: str) -> Node:
        node = Node(master, list(args))
        nodes.append(node)
        return node

    yield start
    for node in nodes:
        node.stop()
