"""Placeholder during the house move (issue #35): replaced by the moved command code."""

from typing import Any

__all__ = ["add_subcommands"]


def add_subcommands(subparsers: Any) -> None:
    """Nothing yet: bubblerob_env.ros.cli still registers node."""
