"""``bubblerob train``: the same as ``python -m train`` (the [train] extra)."""

from __future__ import annotations

import argparse
import shlex
import sys
from typing import Any

from train.train import DESCRIPTION, add_arguments, run

__all__ = ["add_subcommands"]


def add_subcommands(subparsers: Any) -> None:
    """Register ``train``."""
    parser = subparsers.add_parser(
        "train", help="train a PPO or SAC agent (python -m train)", description=DESCRIPTION
    )
    add_arguments(parser)
    parser.set_defaults(handler=_run_train)


def _run_train(args: argparse.Namespace) -> int:
    return run(args, shlex.join(["bubblerob", *sys.argv[1:]]), "bubblerob train")
