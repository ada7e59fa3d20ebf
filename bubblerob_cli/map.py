"""Placeholder during the house move (issue #35): replaced by the moved command code."""

from policies.bag_map import add_subcommands

__all__ = ["add_subcommands"]
