"""The rl-baselines3-zoo hyperparameter format: ``train/hyperparams/<algo>.yml`` and its keys.

The YAML files hold only rl-baselines3-zoo hyperparameters, so that rl_zoo3 loads them as they are
(``python -m rl_zoo3.train --algo ppo --env BubbleRob-v0 --gym-packages bubblerob_env -conf
train/hyperparams/ppo.yml``); this project's own settings, how the envs are stepped
(``--vec-env``) and torch's thread count (``--torch-threads``), are command-line options
(:data:`PROJECT_SETTINGS`).

rl-zoo's ``env_wrapper`` and ``callback`` keys name classes as ``"module.Class"``,
``{"module.Class": {kwargs}}`` or a list of those (:func:`policies.runs.parse_env_wrapper`);
``lin_<value>`` is a value decaying linearly to 0 over training.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from policies.runs import parse_env_wrapper
from train.checks import NOT_ALGO_KWARGS, imported_class, schedule_start

__all__ = [
    "ALGOS",
    "HYPERPARAMS_DIR",
    "NOT_ALGO_KWARGS",
    "PROJECT_SETTINGS",
    "algo_kwargs",
    "configured_callbacks",
    "load_hyperparams",
    "named_classes",
    "reject_project_settings",
    "schedules",
    "wrapper_class",
]

ALGOS = ("ppo", "sac")
HYPERPARAMS_DIR = Path(__file__).resolve().parent / "hyperparams"
PROJECT_SETTINGS = {"vec_env": "--vec-env", "torch_threads": "--torch-threads"}
"""Settings of this project's trainer that rl_zoo3 does not know: command-line options, not YAML."""


def load_hyperparams(algo: str, env_id: str, conf_file: Path | None = None) -> dict[str, Any]:
    """The hyperparameters of ``algo`` for ``env_id`` from ``hyperparams/<algo>.yml``.

    ``conf_file``: another file of the same format instead (rl_zoo3's ``--conf-file``), e.g.
    ``train/hyperparams/crowd.yml``, the shared crowd policy's recipe.
    """
    if algo not in ALGOS:
        raise ValueError(f"unknown algo {algo!r}; choose one of {list(ALGOS)}")
    import yaml

    path = HYPERPARAMS_DIR / f"{algo}.yml" if conf_file is None else Path(conf_file)
    try:
        table = yaml.safe_load(path.read_text())
    except OSError as error:
        raise ValueError(f"--conf-file {path}: {error.strerror or error}") from None
    if not isinstance(table, dict) or env_id not in table:
        known = sorted(table) if isinstance(table, dict) else []
        raise ValueError(f"no {algo} hyperparameters for {env_id!r} in {path}; known: {known}")
    return dict(table[env_id])


def reject_project_settings(config: dict[str, Any]) -> None:
    """``ValueError`` for a project setting (:data:`PROJECT_SETTINGS`) among hyperparameters."""
    for key, option in PROJECT_SETTINGS.items():
        if key in config:
            raise ValueError(
                f"{key!r} is not an rl_zoo3 hyperparameter: use the command-line option {option}"
            )


def named_classes(spec: Any) -> list[tuple[Any, dict[str, Any]]]:
    """rl-zoo's ``"module.Class"`` entries (``env_wrapper``, ``callback``): ``(class, kwargs)``."""
    return [(imported_class(name), kwargs) for name, kwargs in parse_env_wrapper(spec)]


def wrapper_class(spec: Any) -> Any:
    """rl-zoo's ``env_wrapper`` as one callable ``env -> wrapped env`` (``None`` without one).

    ``spec`` is a string ``"module.Class"``, a one-key mapping ``{"module.Class": {kwargs}}`` or
    a list of those, applied first to last, as rl_zoo3 applies them.
    """
    classes = named_classes(spec)
    if not classes:
        return None

    def wrap(env: Any) -> Any:
        for cls, kwargs in classes:
            env = cls(env, **kwargs)
        return env

    return wrap


def configured_callbacks(spec: Any) -> list[Any]:
    """rl-zoo's ``callback`` key (the ``env_wrapper`` forms): the callbacks it names."""
    return [cls(**kwargs) for cls, kwargs in named_classes(spec)]


def schedules(config: dict[str, Any]) -> dict[str, Any]:
    """rl-zoo's ``lin_<value>``: a value decaying linearly to 0 over training (for lr, clip)."""
    resolved = {}
    for key, value in config.items():
        if isinstance(value, str) and value.startswith("lin_"):
            start = schedule_start(key, value)
            resolved[key] = lambda progress_remaining, start=start: progress_remaining * start
        else:
            resolved[key] = value
    return resolved


def algo_kwargs(config: dict[str, Any]) -> dict[str, Any]:
    """The keyword arguments of the SB3 algorithm in ``config``, schedules resolved."""
    kwargs = schedules({k: v for k, v in config.items() if k not in (*NOT_ALGO_KWARGS, "seed")})
    if isinstance(kwargs.get("policy_kwargs"), dict):
        kwargs["policy_kwargs"] = resolved_policy_kwargs(kwargs["policy_kwargs"])
    return kwargs


def resolved_policy_kwargs(policy_kwargs: dict[str, Any]) -> dict[str, Any]:
    """``policy_kwargs`` with a ``"module.Class"`` features extractor imported.

    As ``callback`` and ``env_wrapper`` name theirs; rl_zoo3 itself takes a class there only in
    its string form of ``policy_kwargs``, evaluated with its own imports.
    """
    name = policy_kwargs.get("features_extractor_class")
    if not isinstance(name, str):
        return policy_kwargs
    cls = imported_class(name, "features_extractor_class")
    return {**policy_kwargs, "features_extractor_class": cls}
