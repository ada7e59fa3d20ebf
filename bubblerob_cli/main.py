"""The ``bubblerob`` command: one entry point, one module of ``bubblerob_cli`` per command group.

The env itself needs none of them. Every subcommand is always listed; one whose extra is not
installed exits at start with one line naming the extra to install (no traceback).
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence
from importlib import metadata
from typing import Any

from bubblerob_cli.args import HelpFormatter
from bubblerob_cli.stdout_guard import guarded
from bubblerob_env.extras import require_extra

__all__ = ["EXAMPLES", "build_parser", "main"]

# Modules that define ``add_subcommands(subparsers)``: the extra their subcommands need, and the
# subcommands they add (listed here so that they show, and explain themselves, without the extra).
_SUBCOMMAND_MODULES: tuple[tuple[str, str | None, tuple[str, ...]], ...] = (
    ("bubblerob_cli.teleop", None, ("teleop",)),
    ("bubblerob_cli.record", "ros", ("record", "info", "replay", "recover")),
    ("bubblerob_cli.node", "ros", ("node",)),
    ("bubblerob_cli.detect", "ros", ("detect",)),
    ("bubblerob_cli.map", "ros", ("map",)),
    ("bubblerob_cli.localize", "ros", ("localize",)),
    ("bubblerob_cli.evaluate", "demo", ("evaluate", "demo")),
    ("bubblerob_cli.train", "train", ("train",)),
)
_OWN_PACKAGES = ("bubblerob_cli", "bubblerob_env", "policies", "train")

EXAMPLES = {
    "demo": "bubblerob demo --episodes 3 --out demo_output",
    "evaluate": "bubblerob evaluate --policy laser --policy ppo --episodes 20 "
    "--video ppo.mp4 --video-policy ppo",
    "train": "bubblerob train --algo ppo --timesteps 2048 --eval-freq 1024 --set n_steps=128 "
    "--out runs/quick",
    "record": "bubblerob record --policy laser --episodes 2 --seed 0 --format mcap --out bags",
    "info": "bubblerob info bags/bubblerob_laser_seed0",
    "replay": "bubblerob replay bags/bubblerob_laser_seed0",
    "recover": "bubblerob recover bags/bubblerob_laser_seed0",
    "node": "bubblerob node --rate-factor 1 --namespace robot2",
    "map": "bubblerob map bags/bubblerob_laser_seed0 --out map.png",
    "detect": "bubblerob detect bags/seen/bubblerob_random_seed9100 --json",
    "localize": "bubblerob localize bags/bubblerob_laser_seed0 --global --json",
    "teleop": "bubblerob teleop --start-pose 0 0 0 --record bags/drive",
}


def _version() -> str:
    try:
        return metadata.version("bubblerob")
    except metadata.PackageNotFoundError:
        from bubblerob_env import __version__

        return __version__


def _missing_extra_stub(subparsers: Any, name: str, extra: str) -> None:
    parser = subparsers.add_parser(
        name, help=f"(needs the [{extra}] extra)", add_help=False, prefix_chars="\0"
    )
    parser.add_argument("rest", nargs=argparse.REMAINDER)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every subcommand."""
    return _build()[0]


def _build() -> tuple[argparse.ArgumentParser, dict[str, argparse.ArgumentParser]]:
    """The parser, and each subcommand's own parser by name."""
    parser = argparse.ArgumentParser(
        prog="bubblerob",
        description="BubbleRob in MuJoCo: demo, evaluate, train, record, replay, live ROS node.",
        epilog="Run 'bubblerob COMMAND --help' for a command's options, defaults and an example.",
        formatter_class=HelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"bubblerob {_version()}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for module_name, extra, names in _SUBCOMMAND_MODULES:
        before = set(subparsers.choices)
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as error:
            if extra is None or error.name is None or error.name.split(".")[0] in _OWN_PACKAGES:
                raise  # a bug in this package, not a missing extra
            for name in names:
                _missing_extra_stub(subparsers, name, extra)
            continue
        module.add_subcommands(subparsers)
        for name in set(subparsers.choices) - before:
            sub = subparsers.choices[name]
            sub.formatter_class = HelpFormatter
            if sub.get_default("extra") is None:
                sub.set_defaults(extra=extra)
            if sub.epilog is None and name in EXAMPLES:
                sub.epilog = f"example:\n  {EXAMPLES[name]}"
    for sub in subparsers.choices.values():
        if sub.get_default("extra") is None:
            sub.set_defaults(extra=None)
    return parser, dict(subparsers.choices)


def _extra_of(commands: dict[str, argparse.ArgumentParser], command: str) -> str | None:
    """The extra that ``command`` needs (None: none, or no such command)."""
    if command in commands:
        extra = commands[command].get_default("extra")
        if extra is not None:
            return str(extra)
    return next((e for _, e, names in _SUBCOMMAND_MODULES if command in names), None)


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``bubblerob`` with ``argv`` (default: the process arguments)."""
    arguments = list(sys.argv[1:] if argv is None else argv)
    parser, commands = _build()
    # A missing extra is named before the command's own arguments are checked: a bare
    # 'bubblerob evaluate' without [demo] says to install it, not that --policy is missing.
    command = next((argument for argument in arguments if not argument.startswith("-")), None)
    if command is not None and not {"-h", "--help"} & set(arguments):
        extra = _extra_of(commands, command)
        if extra is not None:
            require_extra(extra, f"bubblerob {command}")
    args = parser.parse_args(arguments)
    if args.extra is not None:
        require_extra(args.extra, f"bubblerob {args.command}")
    handler = getattr(args, "handler", None)
    if handler is None:  # a stub: the module that defines the command could not be imported
        extra = next(e for _, e, names in _SUBCOMMAND_MODULES if args.command in names)
        assert extra is not None  # a module without an extra is never stubbed
        require_extra(extra, f"bubblerob {args.command}")
        raise SystemExit(
            f"bubblerob {args.command} needs the [{extra}] extra: pip install 'bubblerob[{extra}]'"
        )
    return guarded(f"bubblerob {args.command}", lambda: handler(args))


if __name__ == "__main__":
    sys.exit(main())
