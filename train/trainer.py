"""Train an SB3 agent on a BubbleRob env with hyperparameters from ``train/hyperparams/*.yml``.

The hyperparameters are rl-baselines3-zoo's (:mod:`train.zoo`); the envs are built by
:mod:`train.envs`; a run writes the folder :mod:`policies.runs` describes: ``config.yml`` (the
hyperparameters used, after overrides), ``settings.json`` (the project-only settings),
``command.txt`` (the command that reproduces it), ``versions.json`` (package versions),
TensorBoard logs, checkpoints, ``evaluations.npz`` and ``best_model.zip`` from periodic
evaluation on validation seeds (``train/validation.py``: the same ``--eval-episodes`` seeds every
time), and the final ``model.zip``.

rl-zoo's ``env_wrapper`` key (``"module.Class"``, ``{"module.Class": {kwargs}}`` or a list of
those) wraps every training and evaluation env, e.g. ``bubblerob_env.wrappers.LaserPooling``;
``load_policy`` and the ONNX export replay that pooling on the env's full scan.
"""

from __future__ import annotations

import shlex
import time
from pathlib import Path
from typing import Any

import bubblerob_env  # noqa: F401  (registers BubbleRob-v0)
from policies.runs import (
    CHECKPOINTS,
    FINAL_MODEL,
    TENSORBOARD,
    machine_moment,
    normalization_path,
    write_run_record,
    write_train_time,
)
from train.checks import check_hyperparams
from train.envs import DEFAULT_VEC_ENV, VEC_ENVS, training_envs
from train.validation import check_training_seeds, keep_best_model, validation_evaluation
from train.zoo import (
    algo_kwargs,
    configured_callbacks,
    load_hyperparams,
    reject_project_settings,
)

__all__ = ["DEFAULT_TORCH_THREADS", "default_command", "run_config", "train"]

DEFAULT_TORCH_THREADS = 1
"""A 64x64 MLP gains nothing from more threads, and they steal the envs' CPU."""


def run_config(
    algo: str,
    env_id: str,
    timesteps: int | None,
    n_envs: int | None,
    seed: int,
    overrides: dict[str, Any] | None,
    conf_file: Path | None = None,
) -> dict[str, Any]:
    """The hyperparameters a run uses: the YAML's, overridden, checked (``ValueError``)."""
    config = load_hyperparams(algo, env_id, conf_file)
    config.update(overrides or {})
    reject_project_settings(config)
    if timesteps is not None:
        config["n_timesteps"] = timesteps
    if n_envs is not None:
        config["n_envs"] = n_envs
    config["seed"] = seed
    check_hyperparams(algo, config)
    check_training_seeds(seed, int(config["n_envs"]))
    return config


def train(
    algo: str,
    env_id: str,
    out: Path,
    timesteps: int | None = None,
    n_envs: int | None = None,
    seed: int = 0,
    eval_freq: int = 50_000,
    eval_episodes: int = 10,
    progress_bar: bool = True,
    command: str | None = None,
    overrides: dict[str, Any] | None = None,
    vec_env: str = DEFAULT_VEC_ENV,
    torch_threads: int = DEFAULT_TORCH_THREADS,
    robots: int = 8,
    foxglove: tuple[str, int] | None = None,
    conf_file: Path | None = None,
) -> Path:
    """Train and save; returns the path of the final model.

    ``overrides`` replace hyperparameters from the YAML (``--set key=value`` on the command line);
    the YAML is ``hyperparams/<algo>.yml``, or ``conf_file`` (``--conf-file``).
    ``vec_env`` (``dummy``, ``subproc`` or ``batched``) says how the ``n_envs`` training envs are
    stepped; ``batched`` is :class:`train.sb3_vec.BubbleRobSB3VecEnv`, same episodes; ``worlds``
    is :class:`train.worlds_vec.WorldsSB3VecEnv`, ``n_envs`` worlds of ``robots`` robots.
    ``progress_bar`` is SB3's own (tqdm/rich), the only thing training shows. ``foxglove``
    (host, port): publish the first training env live to Foxglove (within 4% of the wall time).
    """
    import torch

    if vec_env not in VEC_ENVS:
        raise ValueError(f"vec_env must be one of {list(VEC_ENVS)}, got {vec_env!r}")
    config = run_config(algo, env_id, timesteps, n_envs, seed, overrides, conf_file)
    settings: dict[str, Any] = {"vec_env": vec_env, "torch_threads": torch_threads}
    if vec_env == "worlds":
        settings["robots"] = robots
    write_run_record(out, env_id, config, command or default_command(algo, env_id, out), settings)
    torch.set_num_threads(int(torch_threads))
    envs, eval_env = training_envs(env_id, config, seed, eval_episodes, vec_env, robots, foxglove)
    model = _model(algo, config, envs, seed, out)
    callbacks, eval_env = _callbacks(model, config, eval_env, eval_freq, eval_episodes, out)
    start, started = time.perf_counter(), machine_moment("start")
    model.learn(int(config["n_timesteps"]), callback=callbacks, progress_bar=progress_bar)
    final = out / FINAL_MODEL
    model.save(final)
    normalizer = model.get_vec_normalize_env()  # under a VecFrameStack too
    if normalizer is not None:
        normalizer.save(str(normalization_path(final)))
    wall = time.perf_counter() - start
    write_train_time(out, wall, model.num_timesteps, {**started, **machine_moment("end")})
    envs.close()
    eval_env.close()
    return final


def _model(algo: str, config: dict[str, Any], envs: Any, seed: int, out: Path) -> Any:
    """The SB3 algorithm ``algo`` on ``envs``, with ``config``'s keyword arguments."""
    from stable_baselines3 import PPO, SAC

    algo_cls = {"ppo": PPO, "sac": SAC}[algo]
    return algo_cls(
        config["policy"],
        envs,
        seed=seed,
        verbose=0,
        tensorboard_log=str(out / TENSORBOARD),
        device="cpu",
        **algo_kwargs(config),
    )


def _callbacks(
    model: Any,
    config: dict[str, Any],
    eval_env: Any,
    eval_freq: int,
    eval_episodes: int,
    out: Path,
) -> tuple[list[Any], Any]:
    """Evaluation on validation seeds, checkpoints, and rl-zoo's ``callback`` key; the eval env.

    The eval env is ``eval_env`` transposed where SB3 transposed the training envs' images.
    """
    from stable_baselines3.common.callbacks import CheckpointCallback
    from stable_baselines3.common.vec_env import VecTransposeImage, is_vecenv_wrapped

    count = int(model.get_env().num_envs)  # slots: n_envs, or n_envs x robots (worlds)
    configured = configured_callbacks(config.get("callback"))
    # A warm start (imitation) makes a model before the first update: evaluate that one too.
    warm_start = any(getattr(callback, "warm_start", False) for callback in configured)
    if is_vecenv_wrapped(model.get_env(), VecTransposeImage):
        # SB3 transposes image observations (the camera) for the policy: the eval env alike.
        eval_env = VecTransposeImage(eval_env)
    callbacks: list[Any] = [
        validation_evaluation(
            eval_env,
            at_start=warm_start,
            n_eval_episodes=eval_episodes,
            eval_freq=max(1, eval_freq // count),
            callback_after_eval=keep_best_model(out),
            log_path=str(out),
            deterministic=True,
            verbose=0,
        ),
        # With their VecNormalize statistics: a checkpoint without them cannot be evaluated.
        CheckpointCallback(
            save_freq=max(1, 100_000 // count),
            save_path=str(out / CHECKPOINTS),
            save_vecnormalize=True,
        ),
    ]
    return callbacks + configured, eval_env


def default_command(algo: str, env_id: str, out: Path) -> str:
    """The command that reproduces a run started without one (``command.txt``)."""
    return shlex.join(["python", "-m", "train", "--algo", algo, "--env", env_id, "--out", str(out)])
