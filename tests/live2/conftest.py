"""Fixtures for the live ROS 2 tests: ``bubblerob node --ros 2`` subprocesses on real rclpy.

Skipped (with the set-up command) only where ``.venv-ros2`` is missing; CI makes it.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest
from ros2_helpers import Node, require_ros2


@pytest.fixture(scope="module")
def start_node() -> Iterator[Any]:
    """``start_node(*args)`` starts a ROS 2 node (module scope: shared by a module's tests)."""
    require_ros2()
    nodes: list[Node] = []

    def start(*args: str) -> Node:
        node = Node(list(args))
        nodes.append(node)
        return node

    yield start
    for node in nodes:
        node.stop()
