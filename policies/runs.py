"""The training-run folder: what ``python -m train`` writes; what loading, export and sweeps read.

One run is one folder (``--out``)::

    config.yml                   {env_id: hyperparameters}, after --set overrides (rl-zoo's format)
    settings.json                this project's own settings (vec_env, torch_threads)
    command.txt                  the command that reproduces the run
    versions.json                package versions
    model.zip                    the final model (+ model_vecnormalize.pkl with normalize: true)
    best_model.zip               the best on validation seeds (+ best_model_vecnormalize.pkl)
    evaluations.npz              SB3's EvalCallback log
    checkpoints/  tb/            checkpoints (with their statistics), TensorBoard logs
    train_time.json              wall time and timesteps

A sweep (``--ray``) writes one such folder per seed (``seed_<k>``) and ``sweep.json``. The shipped
policy's folder is ``policies/trained`` (:data:`TRAINED_DIR`).

rl-zoo's ``env_wrapper`` key (``"module.Class"``, ``{"module.Class": {kwargs}}`` or a list of
those, :func:`parse_env_wrapper`) wraps every training env; a trained policy replays its
``LaserPooling`` on the env's full scan (:func:`laser_pooling`) and its residual on the gap
follower (:data:`RESIDUAL_ON_LASER`).
"""

from __future__ import annotations

import json
import operator
import sys
from importlib import metadata
from pathlib import Path
from typing import Any

from policies.residual import RESIDUAL_ON_LASER, check_scale

__all__ = [
    "ACTION_NOISE",
    "BEST_MODEL",
    "CHECKPOINTS",
    "COMMAND_FILE",
    "CONFIG_FILE",
    "FINAL_MODEL",
    "LASER_POOLING",
    "NORMALIZATION_SUFFIX",
    "RESIDUAL_ON_LASER",
    "SETTINGS_FILE",
    "SHIPPED_MODEL",
    "SWEEP_FILE",
    "TENSORBOARD",
    "TRAINED_DIR",
    "TRAINING_ONLY",
    "TRAIN_TIME_FILE",
    "VERSIONS_FILE",
    "laser_pooling",
    "normalization_path",
    "parse_env_wrapper",
    "read_config",
    "recorded_config",
    "recorded_env",
    "recorded_env_kwargs",
    "recorded_pooling",
    "pool_size",
    "residual_scale",
    "run_env_kwargs",
    "versions",
    "without_residual",
    "write_run_record",
    "write_train_time",
]

CONFIG_FILE = "config.yml"
SETTINGS_FILE = "settings.json"
COMMAND_FILE = "command.txt"
VERSIONS_FILE = "versions.json"
TRAIN_TIME_FILE = "train_time.json"
FINAL_MODEL = "model.zip"
BEST_MODEL = "best_model.zip"
CHECKPOINTS = "checkpoints"
TENSORBOARD = "tb"
SWEEP_FILE = "sweep.json"
NORMALIZATION_SUFFIX = "_vecnormalize.pkl"
"""A model ``NAME.zip`` trained with ``normalize: true`` keeps its statistics in
``NAME_vecnormalize.pkl`` beside it (written by ``python -m train``)."""

TRAINED_DIR = Path(__file__).resolve().parent / "trained"
"""The shipped policy's run folder."""
SHIPPED_MODEL = TRAINED_DIR / "ppo_bubblerob_v0.zip"
"""The shipped SB3 model, exported to ``ppo_bubblerob_v0.onnx`` beside it."""

LASER_POOLING = "bubblerob_env.wrappers.LaserPooling"
ACTION_NOISE = "bubblerob_env.wrappers.ActionNoise"
TRAINING_ONLY = (ACTION_NOISE,)
"""``env_wrapper`` entries that act only while training: a trained policy replays nothing."""

_VERSIONED = ("bubblerob", "mujoco", "gymnasium", "stable-baselines3", "torch", "numpy")


def normalization_path(model: Path) -> Path:
    """Where the VecNormalize statistics of the model ``model`` (``NAME.zip``) are kept."""
    return model.with_name(model.stem + NORMALIZATION_SUFFIX)


def read_config(folder: Path) -> Any:
    """The YAML of ``folder``'s ``config.yml`` (None where there is none)."""
    config = folder / CONFIG_FILE
    if not config.is_file():
        return None
    import yaml

    return yaml.safe_load(config.read_text())


def recorded_config(model: Path) -> dict[str, Any] | None:
    """The hyperparameters in the run's ``config.yml`` beside ``model``, if there is one."""
    table = read_config(model.parent) or {}
    if not isinstance(table, dict) or len(table) != 1:
        return None
    (entry,) = table.values()
    return dict(entry or {})


def recorded_env_kwargs(model: Path) -> dict[str, Any] | None:
    """The ``env_kwargs`` of the run's ``config.yml`` beside ``model``, if there is one."""
    config = recorded_config(model)
    return None if config is None else dict(config.get("env_kwargs") or {})


def recorded_env(model: Path) -> tuple[str, dict[str, Any]]:
    """Env id and kwargs from the run's ``config.yml`` beside ``model`` (default env if none)."""
    if not (model.parent / CONFIG_FILE).is_file():
        return "BubbleRob-v0", {}
    table = read_config(model.parent) or {}
    env_id = next(iter(table), "BubbleRob-v0")
    return env_id, dict((table.get(env_id) or {}).get("env_kwargs") or {})


def run_env_kwargs(run: Path, env_id: str) -> dict[str, Any]:
    """The env kwargs the run in folder ``run`` trained ``env_id`` with (its ``config.yml``)."""
    import yaml

    config = yaml.safe_load((run / CONFIG_FILE).read_text())[env_id]
    return dict(config.get("env_kwargs") or {})


def recorded_pooling(model: Path) -> list[tuple[str, int]]:
    """The laser pooling (``env_wrapper``) of the run's ``config.yml`` beside ``model``.

    ``[(key, pool), ...]``, empty without a config or an ``env_wrapper``; ``ValueError`` for a
    wrapper other than :class:`~bubblerob_env.wrappers.LaserPooling`.
    """
    config = recorded_config(model)
    return [] if config is None else laser_pooling(config.get("env_wrapper"))


def parse_env_wrapper(spec: Any) -> list[tuple[str, dict[str, Any]]]:
    """rl-zoo's ``env_wrapper`` hyperparameter as ``[("module.Class", kwargs), ...]``.

    ``spec`` is what rl-baselines3-zoo accepts: ``None``, a string ``"module.Class"``, a one-key
    mapping ``{"module.Class": {kwargs}}``, or a list of those (applied first to last).
    """
    if spec is None:
        return []
    entries = spec if isinstance(spec, list) else [spec]
    parsed = []
    for entry in entries:
        kwargs: dict[str, Any]
        if isinstance(entry, str):
            name, kwargs = entry, {}
        elif isinstance(entry, dict) and len(entry) == 1:
            name, kwargs = next(iter(entry.items()))
            kwargs = dict(kwargs or {})
        else:
            raise ValueError(
                f"env_wrapper entries are 'module.Class' or {{'module.Class': {{kwargs}}}}, "
                f"got {entry!r}"
            )
        if not isinstance(name, str) or "." not in name:
            raise ValueError(f"env_wrapper names a class as 'module.Class', got {name!r}")
        parsed.append((name, kwargs))
    return parsed


def laser_pooling(spec: Any) -> list[tuple[str, int]]:
    """The ``(key, pool)`` of each ``LaserPooling`` in rl-zoo's ``env_wrapper`` ``spec``.

    What a trained policy must apply to the env's observation before predicting, in order.
    Raises ``ValueError`` for any other wrapper: a policy cannot replay it on an observation.
    """
    steps = []
    for name, kwargs in parse_env_wrapper(spec):
        if name in TRAINING_ONLY or name == RESIDUAL_ON_LASER:
            continue
        if name != LASER_POOLING:
            raise ValueError(
                f"env_wrapper {name!r}: trained policies can apply only {LASER_POOLING} "
                "to the env's observations"
            )
        unknown = sorted(set(kwargs) - {"pool", "key"})
        if unknown:
            raise ValueError(f"env_wrapper {name!r}: unknown arguments {unknown}")
        steps.append((str(kwargs.get("key", "laser")), pool_size(name, kwargs.get("pool", 10))))
    return steps


def pool_size(name: str, pool: Any) -> int:
    """A ``LaserPooling``'s ``pool`` as an int; ``ValueError`` in one line unless an int >= 1."""
    try:
        size = operator.index(pool) if not isinstance(pool, bool) else 0
    except TypeError:
        size = 0  # not an int: refused below
    if size < 1:
        raise ValueError(f"env_wrapper {name!r}: pool must be an int >= 1, got {pool!r}")
    return size


def residual_scale(env_wrapper: Any) -> float | None:
    """The ``scale`` of a ``ResidualOnLaser`` in rl-zoo's ``env_wrapper``, or None."""
    for name, kwargs in parse_env_wrapper(env_wrapper):
        if name == RESIDUAL_ON_LASER:
            unknown = sorted(set(kwargs) - {"scale"})
            if unknown:
                raise ValueError(f"env_wrapper {name!r}: unknown arguments {unknown}")
            return check_scale(kwargs.get("scale", 0.5))
    return None


def without_residual(env_wrapper: Any) -> list[dict[str, dict[str, Any]]]:
    """rl-zoo's ``env_wrapper`` without its ``ResidualOnLaser`` (the batch applies it)."""
    return [
        {name: kwargs}
        for name, kwargs in parse_env_wrapper(env_wrapper)
        if name != RESIDUAL_ON_LASER
    ]


def versions() -> dict[str, str]:
    """The versions of the packages a run depends on, and Python's (``versions.json``)."""
    found = {}
    for name in _VERSIONED:
        try:
            found[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            found[name] = "not installed"
    found["python"] = sys.version.split()[0]
    return found


def write_run_record(
    out: Path, env_id: str, config: dict[str, Any], command: str, settings: dict[str, Any]
) -> None:
    """Write what a run starts with: config, command, versions and settings (in that order)."""
    import yaml

    out.mkdir(parents=True, exist_ok=True)
    (out / CONFIG_FILE).write_text(yaml.safe_dump({env_id: config}, sort_keys=False))
    (out / COMMAND_FILE).write_text(command + "\n")
    (out / VERSIONS_FILE).write_text(json.dumps(versions(), indent=2) + "\n")
    (out / SETTINGS_FILE).write_text(json.dumps(settings, indent=2) + "\n")


def write_train_time(
    out: Path, wall_time_s: float, timesteps: int, context: dict[str, Any] | None = None
) -> None:
    """Write ``train_time.json``: the training's wall time and timesteps, and ``context``.

    ``context``: when it started and ended, the machine's load then (:func:`machine_moment`).
    """
    record = {"wall_time_s": wall_time_s, "timesteps": timesteps, **(context or {})}
    (out / TRAIN_TIME_FILE).write_text(json.dumps(record) + "\n")


def machine_moment(label: str) -> dict[str, Any]:
    """The UTC time and the 1, 5 and 15 min load averages, for ``label`` "start" or "end".

    A wall time means little without the load it was measured under (BENCHMARKS records both).
    """
    import datetime
    import os

    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    load = [round(value, 2) for value in os.getloadavg()] if hasattr(os, "getloadavg") else []
    return {{"start": "started", "end": "ended"}[label]: now, f"uptime_load_at_{label}": load}
