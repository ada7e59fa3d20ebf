"""Placeholder during the house move (issue #35): replaced by the moved command code."""

from train.cli import add_subcommands

__all__ = ["add_subcommands"]
