"""What several commands share: the help formatter, --env and --env-kwargs, making the env."""

from __future__ import annotations

import argparse
from typing import Any

from bubblerob_cli.errors import fail

__all__ = ["HelpFormatter", "add_env_arguments", "env_kwargs_json", "make_env", "with_options"]


class HelpFormatter(argparse.HelpFormatter):
    """``--help`` names each option's default and keeps indented example lines as they are."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        default = action.default
        if (
            "default" in text
            or any(default is hidden for hidden in (None, False, argparse.SUPPRESS))
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
    mode = value.get("render_mode")
    if mode is not None and not isinstance(mode, str):  # gym.make itself fails on it
        raise argparse.ArgumentTypeError(
            f"--env-kwargs render_mode must be a string or null, got {mode!r}"
        )
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


def with_options(
    command: str, env_kwargs: dict[str, Any], options: dict[str, tuple[str, Any]]
) -> dict[str, Any]:
    """``env_kwargs`` with each option's kwarg set: ``options`` maps a kwarg to (option, value).

    An option that says otherwise than ``--env-kwargs`` (``--camera`` beside ``{"camera":
    false}``, ``--max-steps 5`` beside ``{"max_episode_steps": 9}``) is one line, exit 2: neither
    is silently dropped.
    """
    kwargs = dict(env_kwargs)
    for key, (option, value) in options.items():
        if key in kwargs and kwargs[key] != value:
            fail(
                command,
                f"{option} contradicts --env-kwargs {key}={kwargs[key]!r}: give one of them",
            )
        kwargs[key] = value
    return kwargs


def make_env(
    command: str,
    env_id: str,
    env_kwargs: dict[str, Any],
    dict_observations: bool = False,
    **fixed: Any,
) -> Any:
    """``gym.make(env_id, **env_kwargs, **fixed)``; a bad id or kwarg is one line, exit 2.

    ``dict_observations``: the command turns observations into ROS messages (``record``,
    ``node``), which needs the ``Dict`` observation: ``obs_mode='flat'`` is refused before any
    bag or ROS node is made.
    """
    import gymnasium as gym

    if dict_observations and env_kwargs.get("obs_mode", "dict") != "dict":
        fail(
            command,
            f"--env-kwargs obs_mode {env_kwargs['obs_mode']!r}: {command} makes ROS messages "
            "from the Dict observation; leave obs_mode 'dict' (the default)",
        )

    if "=" in env_id:  # the node's old `--env KEY=JSON`: an env id never holds '='
        key, _, value = env_id.partition("=")
        fail(
            command,
            f"--env takes an env id such as PioneerP3DX-v0, got "
            f"{env_id!r}; give keyword arguments as one JSON object: "
            f"--env-kwargs '{{\"{key}\": {value}}}'",
        )
    clash = sorted(key for key in fixed if key in env_kwargs and env_kwargs[key] != fixed[key])
    if clash:
        fail(
            command,
            f"--env-kwargs cannot set {', '.join(clash)} here "
            f"(it uses {', '.join(f'{key}={fixed[key]!r}' for key in clash)})",
        )
    try:
        return gym.make(env_id, **{**env_kwargs, **fixed})
    except (gym.error.Error, TypeError, ValueError) as error:
        fail(command, f"--env {env_id} --env-kwargs: {error}")
