"""The ``bubblerob`` command: one entry point, subcommands registered by the optional parts.

The env itself needs none of them; each subcommand's module is imported only when its extra is
installed, so ``bubblerob --help`` says which subcommands need which extra.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

__all__ = ["main"]

# Modules that define ``add_subcommands(subparsers)``, with the extra each one needs.
_SUBCOMMAND_MODULES = (
    ("bubblerob_env.ros.cli", "ros"),
    ("policies.cli", "train"),
)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every available subcommand."""
    parser = argparse.ArgumentParser(
        prog="bubblerob", description="BubbleRob in MuJoCo: record, replay, evaluate, demo."
    )
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    missing = []
    for module_name, extra in _SUBCOMMAND_MODULES:
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as error:
            if error.name is not None and module_name.startswith(error.name):
                continue  # that part of the project does not exist (yet)
            missing.append(f"{module_name} needs the [{extra}] extra ({error.name} is missing)")
            continue
        module.add_subcommands(subparsers)
    if missing:
        parser.epilog = "unavailable: " + "; ".join(missing)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``bubblerob`` with ``argv`` (default: the process arguments)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    result = args.handler(args)
    return int(result or 0)


if __name__ == "__main__":
    sys.exit(main())
