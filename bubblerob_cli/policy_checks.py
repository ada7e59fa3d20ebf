"""What ``evaluate`` and ``demo`` check before any episode: their seeds, files and policies."""

from __future__ import annotations

import argparse
import functools
from pathlib import Path
from typing import Any

from bubblerob_cli.action_type import load_checked, refuse_unused
from bubblerob_cli.errors import fail
from policies.evaluation import DEFAULT_EVAL_SEED
from policies.protocol import SPLITS

__all__ = ["check_episode_arguments", "check_policies"]


def check_policies(
    command: str, names: list[str], env_id: str, env_kwargs: Any, action_type: str | None = None
) -> None:
    """Load each policy once before any episode: a wrong name or file is one line, exit 2.

    A bare SB3 zip needs ``action_type``, the env's (:mod:`bubblerob_cli.action_type`).
    """
    import gymnasium as gym

    from policies.loading import load_policy

    any_bare = False
    for name in names:
        try:
            env = gym.make(env_id, **(env_kwargs or {}))
        except (gym.error.Error, TypeError, ValueError) as error:  # a usage error: exit 2
            fail(command, f"--env {env_id} --env-kwargs: {error}")
        try:
            load = functools.partial(load_policy, name, env)
            any_bare |= load_checked(command, name, env, action_type, load)[1]
        except (ValueError, TypeError, OSError) as error:  # a usage error: exit 2
            env.close()
            fail(command, str(error).strip().splitlines()[0])
        except Exception as error:  # noqa: BLE001 - a damaged .zip or .onnx: zipfile, onnxruntime
            env.close()
            fail(
                command,
                f"cannot load the policy file {name}: "
                f"{type(error).__name__}: {(str(error).strip().splitlines() or [''])[0]}",
            )
        env.close()
    refuse_unused(command, action_type, any_bare)


def check_episode_arguments(command: str, args: argparse.Namespace) -> None:
    """Exit 2 with one line if ``--seed``, ``--episodes`` or ``--video``'s folder is unusable.

    Sets ``args.seed`` where it was not given: the default, or the ``--split``'s first seed.
    """
    problem = None
    split = SPLITS.get(getattr(args, "split", None) or "")
    if args.seed is None:
        args.seed = DEFAULT_EVAL_SEED if split is None else split.start
    if args.episodes < 1:
        problem = f"--episodes must be >= 1, got {args.episodes}"
    elif not 0 <= args.seed <= 2**32 - 1 - args.episodes:
        problem = f"--seed must be from 0 to {2**32 - 1 - args.episodes}, got {args.seed}"
    elif split is not None and (outside := split.outside(args.seed, args.episodes)):
        problem = f"--split {split.name}: {outside}"
    elif getattr(args, "video", None) is not None:
        try:
            Path(args.video).resolve().parent.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            problem = f"--video {args.video}: cannot create its folder ({error.strerror or error})"
    if problem is None and getattr(args, "per_episode", None) is not None:
        try:
            Path(args.per_episode).resolve().parent.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            problem = f"--per-episode {args.per_episode}: cannot create its folder ({error})"
    if problem is not None:
        fail(command, problem)
