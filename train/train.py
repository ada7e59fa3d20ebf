"""Train an SB3 agent on a BubbleRob env with hyperparameters from ``train/hyperparams/*.yml``.

The YAML files hold only rl-baselines3-zoo hyperparameters, so that rl_zoo3 loads them as they are
(``python -m rl_zoo3.train --algo ppo --env BubbleRob-v0 --gym-packages bubblerob_env -conf
train/hyperparams/ppo.yml``); this project's own settings, how the envs are stepped
(``--vec-env``) and torch's thread count (``--torch-threads``), are command-line options.

A run writes into its output folder: ``config.yml`` (the hyperparameters used, after command-line
overrides), ``settings.json`` (the project-only settings), ``command.txt`` (the command that
reproduces it), ``versions.json`` (package versions), TensorBoard logs, checkpoints,
``evaluations.npz`` and ``best_model.zip`` from periodic evaluation on validation seeds
(``train/validation.py``: the same ``--eval-episodes`` seeds every time), and the final
``model.zip``.

rl-zoo's ``env_wrapper`` key (``"module.Class"``, ``{"module.Class": {kwargs}}`` or a list of
those) wraps every training and evaluation env, e.g. ``bubblerob_env.wrappers.LaserPooling``;
``load_policy`` and the ONNX export replay that pooling on the env's full scan.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from collections.abc import Sequence
from importlib import metadata
from pathlib import Path
from typing import Any

import bubblerob_env  # noqa: F401  (registers BubbleRob-v0)
from policies.loading import NORMALIZATION_SUFFIX
from policies.protocol import VALIDATION
from policies.residual import residual_scale, without_residual
from train.checks import check_hyperparams, check_train_arguments, parse_overrides
from train.validation import (
    check_training_seeds,
    evaluation_score,
    keep_best_model,
    validation_evaluation,
)

__all__ = [
    "ALGOS",
    "evaluation_score",
    "keep_best_model",
    "load_hyperparams",
    "main",
    "train",
    "wrapper_class",
]

ALGOS = ("ppo", "sac")
HYPERPARAMS_DIR = Path(__file__).resolve().parent / "hyperparams"
_NOT_ALGO_KWARGS = (
    "normalize",
    "n_timesteps",
    "n_envs",
    "env_kwargs",
    "policy",
    "env_wrapper",
    "frame_stack",
    "callback",
)
PROJECT_SETTINGS = {"vec_env": "--vec-env", "torch_threads": "--torch-threads"}
"""Settings of this project's trainer that rl_zoo3 does not know: command-line options, not YAML."""
VEC_ENVS = ("dummy", "subproc", "batched")
DEFAULT_VEC_ENV = "dummy"
"""Step the envs in the training process: on 2 cores, faster than subprocesses for this env."""
DEFAULT_TORCH_THREADS = 1
"""A 64x64 MLP gains nothing from more threads, and they steal the envs' CPU."""


def load_hyperparams(algo: str, env_id: str) -> dict[str, Any]:
    """The hyperparameters of ``algo`` for ``env_id`` from ``hyperparams/<algo>.yml``."""
    if algo not in ALGOS:
        raise ValueError(f"unknown algo {algo!r}; choose one of {list(ALGOS)}")
    import yaml

    table = yaml.safe_load((HYPERPARAMS_DIR / f"{algo}.yml").read_text())
    if env_id not in table:
        raise ValueError(f"no {algo} hyperparameters for {env_id!r}; known: {sorted(table)}")
    return dict(table[env_id])


def _reject_project_settings(config: dict[str, Any]) -> None:
    for key, option in PROJECT_SETTINGS.items():
        if key in config:
            raise ValueError(
                f"{key!r} is not an rl_zoo3 hyperparameter: use the command-line option {option}"
            )


def _named_classes(spec: Any) -> list[tuple[Any, dict[str, Any]]]:
    """rl-zoo's ``"module.Class"`` entries (``env_wrapper``, ``callback``): ``(class, kwargs)``."""
    import importlib

    from bubblerob_env.wrappers import parse_env_wrapper

    classes = []
    for name, kwargs in parse_env_wrapper(spec):
        module, _, cls_name = name.rpartition(".")
        classes.append((getattr(importlib.import_module(module), cls_name), kwargs))
    return classes


def wrapper_class(spec: Any) -> Any:
    """rl-zoo's ``env_wrapper`` as one callable ``env -> wrapped env`` (``None`` without one).

    ``spec`` is a string ``"module.Class"``, a one-key mapping ``{"module.Class": {kwargs}}`` or
    a list of those, applied first to last, as rl_zoo3 applies them.
    """
    classes = _named_classes(spec)
    if not classes:
        return None

    def wrap(env: Any) -> Any:
        for cls, kwargs in classes:
            env = cls(env, **kwargs)
        return env

    return wrap


def _configured_callbacks(spec: Any) -> list[Any]:
    """rl-zoo's ``callback`` key (the ``env_wrapper`` forms): the callbacks it names."""
    return [cls(**kwargs) for cls, kwargs in _named_classes(spec)]


def _schedules(config: dict[str, Any]) -> dict[str, Any]:
    """rl-zoo's ``lin_<value>``: a value decaying linearly to 0 over training (for lr, clip)."""
    resolved = {}
    for key, value in config.items():
        if isinstance(value, str) and value.startswith("lin_"):
            start = float(value[len("lin_") :])
            resolved[key] = lambda progress_remaining, start=start: progress_remaining * start
        else:
            resolved[key] = value
    return resolved


def _versions() -> dict[str, str]:
    names = ("bubblerob", "mujoco", "gymnasium", "stable-baselines3", "torch", "numpy")
    found = {}
    for name in names:
        try:
            found[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            found[name] = "not installed"
    found["python"] = sys.version.split()[0]
    return found


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
) -> Path:
    """Train and save; returns the path of the final model.

    ``overrides`` replace hyperparameters from the YAML (``--set key=value`` on the command line).
    ``vec_env`` (``dummy``, ``subproc`` or ``batched``) says how the ``n_envs`` training envs are
    stepped; ``batched`` is :class:`bubblerob_env.sb3.BubbleRobSB3VecEnv`, same episodes.
    """
    import torch
    import yaml
    from stable_baselines3 import PPO, SAC
    from stable_baselines3.common.callbacks import CheckpointCallback
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import (
        DummyVecEnv,
        SubprocVecEnv,
        VecFrameStack,
        VecNormalize,
        VecTransposeImage,
        is_vecenv_wrapped,
    )

    if vec_env not in VEC_ENVS:
        raise ValueError(f"vec_env must be one of {list(VEC_ENVS)}, got {vec_env!r}")
    config = load_hyperparams(algo, env_id)
    config.update(overrides or {})
    _reject_project_settings(config)
    if timesteps is not None:
        config["n_timesteps"] = timesteps
    if n_envs is not None:
        config["n_envs"] = n_envs
    config["seed"] = seed
    check_hyperparams(algo, config)
    check_training_seeds(seed, int(config["n_envs"]))
    out.mkdir(parents=True, exist_ok=True)
    (out / "config.yml").write_text(yaml.safe_dump({env_id: config}, sort_keys=False))
    (out / "command.txt").write_text((command or _default_command(algo, env_id, out)) + "\n")
    (out / "versions.json").write_text(json.dumps(_versions(), indent=2) + "\n")
    settings = {"vec_env": vec_env, "torch_threads": torch_threads}
    (out / "settings.json").write_text(json.dumps(settings, indent=2) + "\n")

    env_kwargs = config.get("env_kwargs") or {}
    wrap = wrapper_class(config.get("env_wrapper"))
    count = int(config["n_envs"])
    # DummyVecEnv by default: with small, fast envs on a 2-core machine the inter-process round
    # trips of SubprocVecEnv cost more than stepping the envs in-process.
    vec_cls = SubprocVecEnv if count > 1 and vec_env == "subproc" else DummyVecEnv
    torch.set_num_threads(int(torch_threads))
    if vec_env == "batched":
        spec = config.get("env_wrapper")
        envs = batched_envs(env_id, count, seed, env_kwargs, spec)
        # The same wrapper chain as training's: VecNormalize's statistics are synced by walking
        # both chains in step.
        eval_env = batched_envs(env_id, eval_episodes, VALIDATION.start, env_kwargs, spec)
    else:
        envs = make_vec_env(
            env_id,
            n_envs=count,
            seed=seed,
            env_kwargs=env_kwargs,
            vec_env_cls=vec_cls,
            wrapper_class=wrap,
        )
        # One env per validation episode (train/validation.py), stepped in this process.
        eval_env = make_vec_env(
            env_id,
            n_envs=eval_episodes,
            seed=VALIDATION.start,
            env_kwargs=env_kwargs,
            wrapper_class=wrap,
        )
    if config.get("normalize", False):
        # rl-zoo's "normalize: true": running mean/std of observations (and returns for training).
        keys = _non_image_keys(envs.observation_space)
        envs = VecNormalize(envs, gamma=float(config.get("gamma", 0.99)), norm_obs_keys=keys)
        eval_env = VecNormalize(eval_env, training=False, norm_reward=False, norm_obs_keys=keys)
    if config.get("frame_stack"):
        # rl-zoo's "frame_stack: N", on top of the normalisation as rl_zoo3 stacks.
        envs = VecFrameStack(envs, int(config["frame_stack"]))
        eval_env = VecFrameStack(eval_env, int(config["frame_stack"]))
    algo_cls = {"ppo": PPO, "sac": SAC}[algo]
    algo_kwargs = _schedules(
        {k: v for k, v in config.items() if k not in (*_NOT_ALGO_KWARGS, "seed")}
    )
    model = algo_cls(
        config["policy"],
        envs,
        seed=seed,
        verbose=0,
        tensorboard_log=str(out / "tb"),
        device="cpu",
        **algo_kwargs,
    )
    if is_vecenv_wrapped(model.get_env(), VecTransposeImage):
        # SB3 transposes image observations (the camera) for the policy: the eval env alike.
        eval_env = VecTransposeImage(eval_env)
    callbacks: list[Any] = [
        validation_evaluation(
            eval_env,
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
            save_path=str(out / "checkpoints"),
            save_vecnormalize=True,
        ),
    ]
    callbacks += _configured_callbacks(config.get("callback"))
    start = time.perf_counter()
    model.learn(int(config["n_timesteps"]), callback=callbacks, progress_bar=progress_bar)
    final = out / "model.zip"
    model.save(final)
    normalizer = model.get_vec_normalize_env()  # under a VecFrameStack too
    if normalizer is not None:
        normalizer.save(str(out / f"model{NORMALIZATION_SUFFIX}"))
    (out / "train_time.json").write_text(
        json.dumps({"wall_time_s": time.perf_counter() - start, "timesteps": model.num_timesteps})
        + "\n"
    )
    envs.close()
    eval_env.close()
    return final


def _non_image_keys(space: Any) -> list[str] | None:
    """The observation keys VecNormalize should normalise: all but images (the camera).

    SB3 scales and transposes uint8 images itself; normalised, they would be a float box it
    takes for a vector. ``None`` (all) for a space that is not a dict.
    """
    from gymnasium import spaces
    from stable_baselines3.common.preprocessing import is_image_space

    if not isinstance(space, spaces.Dict):
        return None
    return [key for key, sub in space.spaces.items() if not is_image_space(sub)]


def batched_envs(
    env_id: str, count: int, seed: int, env_kwargs: dict[str, Any], env_wrapper: Any = None
) -> Any:
    """``--vec-env batched`` with rl-zoo's ``env_wrapper`` (see :func:`_batched_envs`)."""
    scale = residual_scale(env_wrapper)
    spec = env_wrapper if scale is None else without_residual(env_wrapper)
    return _batched_envs(env_id, count, seed, env_kwargs, wrapper_class(spec), scale)


def _batched_envs(
    env_id: str,
    count: int,
    seed: int,
    env_kwargs: dict[str, Any],
    wrap: Any = None,
    scale: float | None = None,
) -> Any:
    """``--vec-env batched``: the native batch (threads), as ``make_vec_env`` would seed it.

    An ``env_wrapper`` of observation wrappers is applied to the whole batch (``LaserPooling``);
    a residual on the gap follower (``scale``, its wrapper left out of ``wrap``) below them.
    """
    import gymnasium as gym

    from bubblerob_env.sb3 import BubbleRobSB3VecEnv, VecObservationWrapper
    from policies.loading import load_policy
    from train.vec_residual import VecResidualOnLaser

    if env_id != "BubbleRob-v0":
        raise ValueError(f"--vec-env batched steps BubbleRob-v0 only, not {env_id!r}")
    envs: Any = BubbleRobSB3VecEnv(count, **env_kwargs)
    envs.seed(seed)
    if wrap is None:
        return envs
    probe = gym.make(env_id, **env_kwargs)
    try:
        if scale is not None:  # the residual acts on the raw batch, below the observation ones
            envs = VecResidualOnLaser(envs, load_policy("laser", probe), scale)
        return VecObservationWrapper.from_env_wrapper(envs, wrap, probe)
    except ValueError:
        envs.close()
        raise
    finally:
        probe.close()


def _default_command(algo: str, env_id: str, out: Path) -> str:
    return shlex.join(["python", "-m", "train", "--algo", algo, "--env", env_id, "--out", str(out)])


def _override(text: str) -> tuple[str, str]:
    key, sep, value = text.partition("=")
    if not sep or not key:
        raise argparse.ArgumentTypeError(f"--set needs KEY=VALUE, got {text!r}")
    return key, value  # read as YAML once the [train] extra is known to be there


DESCRIPTION = (
    "Train an SB3 agent (PPO or SAC) on a BubbleRob env with hyperparameters from "
    "train/hyperparams/<algo>.yml (rl-baselines3-zoo format)."
)
EXAMPLE = (
    "python -m train --algo ppo --timesteps 2048 --eval-freq 1024 --set n_steps=128 "
    "--out runs/quick"
)


def build_parser(prog: str = "python -m train") -> argparse.ArgumentParser:
    """Command-line arguments of ``python -m train``."""
    from bubblerob_cli.args import HelpFormatter

    parser = argparse.ArgumentParser(
        prog=prog,
        description=DESCRIPTION,
        epilog=f"example:\n  {EXAMPLE}",
        formatter_class=HelpFormatter,
    )
    add_arguments(parser)
    return parser


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``python -m train`` and ``bubblerob train``."""
    parser.add_argument(
        "--algo", choices=ALGOS, default="ppo", help="the SB3 algorithm (default: ppo)"
    )
    parser.add_argument("--env", default="BubbleRob-v0", help="env id (default BubbleRob-v0)")
    parser.add_argument("--timesteps", type=int, help="override n_timesteps from the YAML")
    parser.add_argument("--n-envs", type=int, help="override n_envs from the YAML")
    parser.add_argument(
        "--vec-env",
        choices=VEC_ENVS,
        default=DEFAULT_VEC_ENV,
        help="step the envs in this process (dummy), one subprocess each (subproc), or as one "
        "native batch on threads (batched; BubbleRob-v0 only)",
    )
    parser.add_argument(
        "--torch-threads", type=int, default=DEFAULT_TORCH_THREADS, help="torch's CPU threads"
    )
    parser.add_argument(
        "--seed",
        type=int,
        default=0,
        help="the run's seed: torch, and env i's first episode is seed SEED+i, which stays "
        "below 1000, the first validation seed (policies/protocol.py) (default: 0)",
    )
    parser.add_argument("--eval-freq", type=int, default=50_000, help="env steps between evals")
    parser.add_argument(
        "--eval-episodes",
        type=int,
        default=10,
        help="episodes of each evaluation: validation seeds 1000, 1001, ..., the same ones "
        "every time; the best model is chosen on them (default: 10)",
    )
    parser.add_argument("--out", type=Path, help="output folder (default runs/<algo>-<env>-<seed>)")
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        type=_override,
        help="override a hyperparameter (YAML value), e.g. --set n_steps=512",
    )
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    from train.sweep import add_sweep_arguments  # --ray, --seeds (Ray is imported only to run)

    add_sweep_arguments(parser)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``python -m train``."""
    args = build_parser().parse_args(argv)
    command = shlex.join(["python", "-m", "train", *(sys.argv[1:] if argv is None else argv)])
    return run(args, command, "python -m train")


def run(args: argparse.Namespace, command: str, program: str) -> int:
    """Train as the parsed command line of ``program`` says."""
    from bubblerob_env.extras import require_extra

    require_extra("train", program)

    sweep = args.ray is not None or args.seeds is not None
    out = args.out or Path("runs") / f"{args.algo}-{args.env}-{'sweep' if sweep else args.seed}"
    try:
        check_train_arguments(args)
        overrides = parse_overrides(args.set)
        _reject_project_settings(overrides)
        config = {**load_hyperparams(args.algo, args.env), **overrides}
        check_hyperparams(args.algo, config)
        for seed in args.seeds or [args.seed]:
            check_training_seeds(seed, int(args.n_envs or config.get("n_envs", 1)))
        out.mkdir(parents=True, exist_ok=True)
    except (ValueError, OSError) as error:
        reason = error.strerror if isinstance(error, OSError) and error.strerror else error
        where = f"--out {out}: " if isinstance(error, OSError) else ""
        print(f"{program}: {where}{reason}", file=sys.stderr)
        return 2
    if sweep:  # one run per --seeds seed, as Ray tasks
        from train.sweep import run_sweep

        return run_sweep(args, overrides, out, command, program)
    final = train(
        args.algo,
        args.env,
        out,
        timesteps=args.timesteps,
        n_envs=args.n_envs,
        seed=args.seed,
        eval_freq=args.eval_freq,
        eval_episodes=args.eval_episodes,
        progress_bar=not args.no_progress,
        command=command,
        overrides=overrides,
        vec_env=args.vec_env,
        torch_threads=args.torch_threads,
    )
    print(f"saved {final} (best model: {out / 'best_model.zip'}, logs: {out / 'tb'})")
    return 0
