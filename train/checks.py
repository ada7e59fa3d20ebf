"""Argument and hyperparameter checks of ``bubblerob train``: one line naming the bad value.

SB3 takes ``n_steps=-1`` or ``n_envs=0`` to an ``AssertionError`` or an ``IndexError`` deep in its
constructors, ``--timesteps 0`` to a saved model that never learned, and ``--eval-freq 0`` to an
evaluation after every step (a run that seems to hang). These are refused before anything starts.
"""

from __future__ import annotations

import importlib
import inspect
import math
from typing import Any

__all__ = [
    "MAX_SEED",
    "NOT_ALGO_KWARGS",
    "TrainArgumentError",
    "check_hyperparams",
    "check_train_arguments",
    "parse_overrides",
    "schedule_start",
]

MAX_SEED = 2**32 - 1
"""Largest seed: SB3 seeds NumPy's legacy generator, which takes 32-bit seeds."""

_INTS_FROM_ONE = ("n_timesteps", "n_envs", "n_steps", "n_epochs", "buffer_size", "frame_stack")
_INTS_FROM_ZERO = ("learning_starts",)
_FRACTIONS = ("gamma", "gae_lambda", "tau")  # in (0, 1]
_POSITIVE = ("max_grad_norm",)
_SCHEDULED = ("learning_rate", "clip_range")  # > 0, or an rl-zoo schedule string ("lin_3e-4")


class TrainArgumentError(ValueError):
    """A command-line option or hyperparameter that cannot train (the message names it)."""


NOT_ALGO_KWARGS = (
    "normalize",
    "n_timesteps",
    "n_envs",
    "env_kwargs",
    "policy",
    "env_wrapper",
    "frame_stack",
    "callback",
)
"""rl-zoo keys that are not keyword arguments of the SB3 algorithm (``seed`` neither)."""


def _is_int(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _is_number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def check_train_arguments(args: Any) -> None:
    """The options of ``python -m train`` / ``bubblerob train`` that need no SB3 to check.

    ``args`` has the options' values as attributes (``timesteps``, ``n_envs``, ``seed``, ...).

    Raises:
        TrainArgumentError: The first bad option.
    """
    rules = (
        ("--timesteps", args.timesteps, 1, True),
        ("--n-envs", args.n_envs, 1, True),
        ("--torch-threads", args.torch_threads, 1, False),
        ("--eval-freq", args.eval_freq, 1, False),
        ("--eval-episodes", args.eval_episodes, 1, False),
    )
    for option, value, low, optional in rules:
        if optional and value is None:
            continue
        if not (_is_int(value) and value >= low):
            raise TrainArgumentError(f"{option} must be an int >= {low}, got {value}")
    if not (_is_int(args.seed) and 0 <= args.seed <= MAX_SEED):
        raise TrainArgumentError(f"--seed must be an int from 0 to {MAX_SEED}, got {args.seed}")


def check_hyperparams(algo: str, config: dict[str, Any]) -> None:
    """The YAML hyperparameters after ``--set`` overrides: SB3's own checks, said in one line.

    Raises:
        TrainArgumentError: The first bad hyperparameter.
    """

    def bad(key: str, allowed: str) -> TrainArgumentError:
        return TrainArgumentError(
            f"hyperparameter {key} must be {allowed}, got {config[key]!r} (--set {key}=...)"
        )

    _check_known(algo, config)
    for key in _INTS_FROM_ONE:
        if key in config and not (_is_int(config[key]) and config[key] >= 1):
            raise bad(key, "an int >= 1")
    for key in _INTS_FROM_ZERO:
        if key in config and not (_is_int(config[key]) and config[key] >= 0):
            raise bad(key, "an int >= 0")
    for key in _FRACTIONS:
        if key in config and not (_is_number(config[key]) and 0 < config[key] <= 1):
            raise bad(key, "a number in (0, 1]")
    for key in _POSITIVE:
        if key in config and not (_is_number(config[key]) and config[key] > 0):
            raise bad(key, "a number > 0")
    for key in _SCHEDULED:
        value: Any = config.get(key)
        if isinstance(value, str):
            schedule_start(key, value)
        elif key in config and not (_is_number(value) and value > 0):
            raise bad(key, "a number > 0 or a schedule such as 'lin_3e-4'")
    _check_named_classes(config)
    _check_numbers_in_classes(config)
    if "batch_size" in config:
        low = 2 if algo == "ppo" else 1  # SB3's PPO normalises advantages over a minibatch
        if not (_is_int(config["batch_size"]) and config["batch_size"] >= low):
            raise bad("batch_size", f"an int >= {low}")
    if algo == "ppo" and int(config.get("n_steps", 2)) * int(config.get("n_envs", 1)) < 2:
        raise TrainArgumentError(
            f"n_steps * n_envs must be > 1 for PPO, got {config.get('n_steps')} * "
            f"{config.get('n_envs')}"
        )


def _check_known(algo: str, config: dict[str, Any]) -> None:
    """Every key is the run's own (``NOT_ALGO_KWARGS``) or the SB3 algorithm's keyword argument.

    An unknown one (``--set nope=1``) would otherwise fail inside SB3 after the envs are made.
    """
    import inspect

    from stable_baselines3 import PPO, SAC

    algo_cls: type = PPO if algo == "ppo" else SAC
    taken = set(inspect.signature(algo_cls).parameters)
    unknown = sorted(k for k in config if k not in taken and k not in (*NOT_ALGO_KWARGS, "seed"))
    if unknown:
        raise TrainArgumentError(
            f"unknown hyperparameter {unknown[0]} (--set {unknown[0]}=...): {algo.upper()} takes "
            f"the run's own keys {sorted(NOT_ALGO_KWARGS)} and its keyword arguments"
        )


def imported_class(name: str, key: str | None = None) -> Any:
    """The class a recipe names as ``"module.Class"``.

    ``key``: the hyperparameter that names it, for the message.

    Raises:
        TrainArgumentError: There is no such class, in one line that names it.
    """
    module, _, cls_name = name.rpartition(".")
    try:
        return getattr(importlib.import_module(module), cls_name)
    except (ImportError, AttributeError, ValueError) as error:
        where = f"{key} " if key else ""
        raise TrainArgumentError(
            f"{where}{name!r}: not an importable module.Class ({error})"
        ) from None


def _check_named_classes(config: dict[str, Any]) -> None:
    """Every class the recipe names (wrappers, callbacks, a features extractor) imports."""
    from policies.runs import parse_env_wrapper

    for key in ("env_wrapper", "callback"):
        for name, _ in parse_env_wrapper(config.get(key)):
            imported_class(name, key)
    policy_kwargs = config.get("policy_kwargs")
    if isinstance(policy_kwargs, dict):
        extractor = policy_kwargs.get("features_extractor_class")
        if isinstance(extractor, str):
            imported_class(extractor, "features_extractor_class")


def _check_numbers_in_classes(config: dict[str, Any]) -> None:
    """The numbers given to the project's own wrappers and callbacks, checked before training."""
    from policies.runs import LASER_POOLING, parse_env_wrapper, pool_size, residual_scale

    if config.get("env_wrapper"):
        residual_scale(config["env_wrapper"])  # a ResidualOnLaser's scale: a number in (0, 2]
    for name, kwargs in parse_env_wrapper(config.get("env_wrapper")):
        if name == LASER_POOLING:
            pool_size(name, kwargs.get("pool", 10))
    for name, kwargs in parse_env_wrapper(config.get("callback")):
        if name.startswith("train."):  # the project's own callbacks, made for the check alone
            cls = imported_class(name, "callback")
            try:
                cls(**kwargs)  # each says a bad value in its own one-line ValueError
            except TypeError:
                takes = ", ".join(inspect.signature(cls).parameters)
                raise TrainArgumentError(
                    f"callback {name}: unknown arguments {sorted(kwargs)} (it takes {takes})"
                ) from None


def schedule_start(key: str, text: str) -> float:
    """The start of rl-zoo's ``lin_<value>`` schedule ``text`` of ``key``: a number > 0.

    Raises:
        TrainArgumentError: Anything else, in one line that names ``key`` and the value.
    """
    try:
        start = float(text[len("lin_") :]) if text.startswith("lin_") else math.nan
    except ValueError:
        start = math.nan
    if not (math.isfinite(start) and start > 0):
        raise TrainArgumentError(
            f"hyperparameter {key} must be a number > 0 or a schedule such as 'lin_3e-4', "
            f"got {text!r}"
        )
    return start


def parse_overrides(pairs: list[tuple[str, str]]) -> dict[str, Any]:
    """``--set KEY=VALUE`` pairs, each value read as YAML.

    Raises:
        TrainArgumentError: A value that is not YAML.
    """
    import yaml

    overrides = {}
    for key, text in pairs:
        try:
            overrides[key] = yaml.safe_load(text)
        except yaml.YAMLError as error:
            problem = getattr(error, "problem", None) or "not YAML"
            raise TrainArgumentError(f"--set {key}={text}: the value is {problem}") from None
    return overrides
