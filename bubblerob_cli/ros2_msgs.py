"""``python -m bubblerob_env.ros.live.ros2_msgs [PACKAGE ...] [--prefix DIR]``: ROS 2 messages.

Builds the ROS 2 message packages that have no wheel (``tf2_msgs``, ``vision_msgs``) into this
Python environment's pip-installed ROS 2 with
:func:`bubblerob_env.ros.live.ros2_msgs.build_package` (the Makefile runs it in ``.venv-ros2``).
One line per package built; a failure is one line, exit 1.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from bubblerob_env.ros.live.ros2_msgs import PACKAGES, build_package

__all__ = ["main"]


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m bubblerob_env.ros.live.ros2_msgs [PACKAGE ...] [--prefix DIR]``."""
    parser = argparse.ArgumentParser(
        prog="python -m bubblerob_env.ros.live.ros2_msgs",
        description="Generate and build ROS 2 message packages that have no wheel "
        "(tf2_msgs) into this Python environment's ROS 2.",
    )
    parser.add_argument("packages", nargs="*", help=f"default: {' '.join(sorted(PACKAGES))}")
    parser.add_argument("--prefix", type=Path, default=None, help="default: sys.prefix")
    args = parser.parse_args(argv)
    for package in args.packages or sorted(PACKAGES):
        if package not in PACKAGES:
            parser.error(f"no recipe for {package!r}; known: {', '.join(sorted(PACKAGES))}")
        try:
            target = build_package(package, args.prefix)
        except RuntimeError as error:
            print(f"ros2_msgs: {error}", file=sys.stderr)
            return 1
        print(f"ros2_msgs: built {package} into {target}")
    return 0
