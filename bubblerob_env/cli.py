"""The ``bubblerob`` command: one entry point, subcommands registered by the optional parts.

The env itself needs none of them. Every subcommand is always listed; one whose extra is not
installed exits at start with one line naming the extra to install (no traceback).
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Sequence
from importlib import metadata
from typing import Any

from bubblerob_env.extras import require_extra

__all__ = [
    "HelpFormatter",
    "add_env_arguments",
    "build_parser",
    "env_kwargs_json",
    "main",
    "make_env",
]

# Modules that define ``add_subcommands(subparsers)``: the extra their subcommands need, and the
# subcommands they add (listed here so that they show, and explain themselves, without the extra).
_SUBCOMMAND_MODULES: tuple[tuple[str, str | None, tuple[str, ...]], ...] = (
    ("policies.teleop", None, ("teleop",)),
    ("bubblerob_env.ros.cli", "ros", ("record", "info", "replay", "recover", "node")),
    ("bubblerob_env.ros.detect", "ros", ("detect",)),
    ("policies.bag_map", "ros", ("map",)),
    ("bubblerob_env.ros.localize", "ros", ("localize",)),
    ("policies.cli", "demo", ("evaluate", "demo")),
    ("train.cli", "train", ("train",)),
)
_OWN_PACKAGES = ("bubblerob_env", "policies", "train")

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


class HelpFormatter(argparse.HelpFormatter):
    """``--help`` names each option's default and keeps indented example lines as they are."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        default = action.default
        if (
            "default" in text
            or default in (None, False, argparse.SUPPRESS)
            or action.option_strings == []
            or isinstance(default, list)
            and not default
        ):
            return action.help
        return f"{text} (default: %(default)s)"

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        paragraphs = []
        for line in text.splitlines():
            if line.startswith(" "):
                paragraphs.append(indent + line)  # an example command: not re-wrapped
            else:
                paragraphs.append(super()._fill_text(line, width, indent))
        return "\n".join(paragraphs)


def env_kwargs_json(text: str) -> dict[str, Any]:
    """``--env-kwargs``: a JSON object of ``gym.make`` keyword arguments."""
    import json

    try:
        value = json.loads(text)
    except json.JSONDecodeError as error:
        raise argparse.ArgumentTypeError(f"--env-kwargs must be a JSON object: {error}") from error
    if not isinstance(value, dict):
        raise argparse.ArgumentTypeError(f"--env-kwargs must be a JSON object, got {text}")
    return value


def add_env_arguments(parser: argparse.ArgumentParser) -> None:
    """``--env ID`` and ``--env-kwargs JSON``, the env every env-making subcommand makes."""
    parser.add_argument("--env", default="BubbleRob-v0", metavar="ID", help="env id for gym.make")
    parser.add_argument(
        "--env-kwargs",
        type=env_kwargs_json,
        default={},
        metavar="JSON",
        help="gym.make keyword arguments as a JSON object, e.g. '{\"arena_size\": 3.0}'",
    )


def make_env(command: str, env_id: str, env_kwargs: dict[str, Any], **fixed: Any) -> Any:
    """``gym.make(env_id, **env_kwargs, **fixed)``; a bad id or kwarg is one line, exit 2."""
    import gymnasium as gym

    if "=" in env_id:  # the node's old `--env KEY=JSON`: an env id never holds '='
        key, _, value = env_id.partition("=")
        print(
            f"bubblerob {command}: --env takes an env id such as PioneerP3DX-v0, got "
            f"{env_id!r}; give keyword arguments as one JSON object: "
            f"--env-kwargs '{{\"{key}\": {value}}}'",
            file=sys.stderr,
        )
        raise SystemExit(2)
    clash = sorted(key for key in fixed if key in env_kwargs and env_kwargs[key] != fixed[key])
    if clash:
        print(
            f"bubblerob {command}: --env-kwargs cannot set {', '.join(clash)} here "
            f"(it uses {', '.join(f'{key}={fixed[key]!r}' for key in clash)})",
            file=sys.stderr,
        )
        raise SystemExit(2)
    try:
        return gym.make(env_id, **{**env_kwargs, **fixed})
    except (gym.error.Error, TypeError, ValueError) as error:
        print(f"bubblerob {command}: --env {env_id} --env-kwargs: {error}", file=sys.stderr)
        raise SystemExit(2) from None


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
    return parser


def _extra_of(parser: argparse.ArgumentParser, command: str) -> str | None:
    """The extra that ``command`` needs (None: none, or no such command)."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction) and command in action.choices:
            extra = action.choices[command].get_default("extra")
            if extra is not None:
                return str(extra)
    return next((e for _, e, names in _SUBCOMMAND_MODULES if command in names), None)


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``bubblerob`` with ``argv`` (default: the process arguments)."""
    arguments = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    # A missing extra is named before the command's own arguments are checked: a bare
    # 'bubblerob evaluate' without [demo] says to install it, not that --policy is missing.
    command = next((argument for argument in arguments if not argument.startswith("-")), None)
    if command is not None and not {"-h", "--help"} & set(arguments):
        extra = _extra_of(parser, command)
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
    try:
        result = handler(args)
        sys.stdout.flush()
    except BrokenPipeError:  # `bubblerob info BAG | head`: the reader left, nothing is wrong
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # so that the flush at exit does not fail again
        return 141  # 128 + SIGPIPE, as a shell reports it
    return int(result or 0)


if __name__ == "__main__":
    sys.exit(main())
