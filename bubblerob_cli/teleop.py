"""Placeholder during the house move (issue #35): replaced by the moved command code."""

from policies.teleop import add_subcommands

__all__ = ["add_subcommands"]
