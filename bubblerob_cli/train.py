"""``bubblerob train`` and ``python -m train``: train a PPO or SAC agent (the [train] extra).

The options, their checks and what is printed live here; the training itself is
:func:`train.train`, a sweep over seeds on Ray :mod:`bubblerob_cli.ray.sweep`.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from bubblerob_cli.args import HelpFormatter
from bubblerob_cli.foxglove_view import add_foxglove_option, quiet_sdk_log
from bubblerob_cli.outputs import Output, add_overwrite_option, check_outputs
from bubblerob_cli.ray.sweep import add_sweep_arguments
from bubblerob_cli.stdout_guard import guarded
from bubblerob_env.extras import require_extra
from train.checks import check_hyperparams, check_train_arguments, parse_overrides
from train.envs import DEFAULT_VEC_ENV, VEC_ENVS, WATCH_BUDGET
from train.trainer import DEFAULT_TORCH_THREADS, train
from train.validation import check_training_seeds
from train.zoo import ALGOS, load_hyperparams, reject_project_settings

__all__ = [
    "DESCRIPTION",
    "EXAMPLE",
    "add_arguments",
    "add_subcommands",
    "build_parser",
    "main",
    "run",
]

DESCRIPTION = (
    "Train an SB3 agent (PPO or SAC) on a BubbleRob env with hyperparameters from "
    "train/hyperparams/<algo>.yml (rl-baselines3-zoo format)."
)
EXAMPLE = (
    "python -m train --algo ppo --timesteps 2048 --eval-freq 1024 --set n_steps=128 "
    "--out runs/quick"
)


def add_subcommands(subparsers: Any) -> None:
    """Register ``train``."""
    parser = subparsers.add_parser(
        "train", help="train a PPO or SAC agent (python -m train)", description=DESCRIPTION
    )
    add_arguments(parser)
    parser.set_defaults(handler=_run_train)


def _run_train(args: argparse.Namespace) -> int:
    return run(args, shlex.join(["bubblerob", *sys.argv[1:]]), "bubblerob train")


def build_parser(prog: str = "python -m train") -> argparse.ArgumentParser:
    """Command-line arguments of ``python -m train``."""
    parser = argparse.ArgumentParser(
        prog=prog,
        description=DESCRIPTION,
        epilog=f"example:\n  {EXAMPLE}",
        formatter_class=HelpFormatter,
    )
    add_arguments(parser)
    return parser


def _override(text: str) -> tuple[str, str]:
    key, sep, value = text.partition("=")
    if not sep or not key:
        raise argparse.ArgumentTypeError(f"--set needs KEY=VALUE, got {text!r}")
    return key, value  # read as YAML once the [train] extra is known to be there


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
        "native batch on threads (batched; BubbleRob-v0 only); worlds: N_ENVS worlds of --robots "
        "robots, one slot per robot, for one policy shared by all; warp: N_ENVS MuJoCo Warp "
        "worlds on a GPU where there is one (else Warp's CPU device), evaluated on the CPU env",
    )
    parser.add_argument(
        "--robots",
        type=int,
        metavar="N",
        help="robots in each world of --vec-env worlds (default: 8)",
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
    add_overwrite_option(parser)  # a folder with files in it: refused without it
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        type=_override,
        help="override a hyperparameter (YAML value), e.g. --set n_steps=512",
    )
    parser.add_argument(
        "--conf-file",
        "-conf",
        type=Path,
        metavar="YML",
        help="hyperparameters from this file (rl-zoo's format, keyed by env id) instead of "
        "train/hyperparams/<algo>.yml, e.g. train/hyperparams/crowd.yml",
    )
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    add_foxglove_option(parser)  # the first training env, within WATCH_BUDGET of the wall time
    add_sweep_arguments(parser)  # --ray, --seeds (Ray is imported only to run)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``python -m train``."""
    args = build_parser().parse_args(argv)
    command = shlex.join(["python", "-m", "train", *(sys.argv[1:] if argv is None else argv)])
    return guarded("python -m train", lambda: run(args, command, "python -m train"))


def _checked(args: argparse.Namespace, out: Path) -> dict[str, Any]:
    """The ``--set`` overrides, once every option is checked and ``out`` made.

    Raises ``ValueError`` for a bad option or hyperparameter, ``OSError`` where ``out`` cannot be
    made.
    """
    check_train_arguments(args)
    overrides = parse_overrides(args.set)
    reject_project_settings(overrides)
    config = {**load_hyperparams(args.algo, args.env, args.conf_file), **overrides}
    check_hyperparams(args.algo, config)
    for seed in args.seeds or [args.seed]:
        check_training_seeds(seed, int(args.n_envs or config.get("n_envs", 1)))
    check_outputs([Output("--out", out, kind="run")], args.overwrite)  # an OutputError: ValueError
    out.mkdir(parents=True, exist_ok=True)
    return overrides


def _remove_earlier_run(out: Path) -> None:
    """Remove the files an earlier run (or sweep) wrote in ``out``; other files stay.

    ``--overwrite`` replaces a run: a best model or checkpoint this run never writes (no
    evaluation before its end, fewer steps) must not pass as this run's.
    """
    import shutil

    from policies import runs

    models = [out / runs.FINAL_MODEL, out / runs.BEST_MODEL]
    files = [*models, *(runs.normalization_path(m) for m in models), out / "evaluations.npz"]
    records = (runs.CONFIG_FILE, runs.SETTINGS_FILE, runs.COMMAND_FILE, runs.VERSIONS_FILE)
    files += [out / name for name in (*records, runs.TRAIN_TIME_FILE, runs.SWEEP_FILE)]
    for path in files:
        path.unlink(missing_ok=True)
    for folder in [out / runs.CHECKPOINTS, out / runs.TENSORBOARD, *out.glob("seed_*")]:
        if folder.is_dir() and not folder.is_symlink():
            shutil.rmtree(folder)


def run(args: argparse.Namespace, command: str, program: str) -> int:
    """Train as the parsed command line of ``program`` says."""
    require_extra("train", program)

    sweep = args.ray is not None or args.seeds is not None
    out = args.out or Path("runs") / f"{args.algo}-{args.env}-{'sweep' if sweep else args.seed}"
    if args.robots is not None and (args.vec_env != "worlds" or args.robots < 1 or sweep):
        print(
            f"{program}: --robots takes an int >= 1, with --vec-env worlds, without --ray "
            f"(got --robots {args.robots} --vec-env {args.vec_env})",
            file=sys.stderr,
        )
        return 2
    try:
        overrides = _checked(args, out)
    except (ValueError, OSError) as error:
        reason = error.strerror if isinstance(error, OSError) and error.strerror else error
        where = f"--out {out}: " if isinstance(error, OSError) else ""
        print(f"{program}: {where}{reason}", file=sys.stderr)
        return 2
    if args.foxglove is not None and (sweep or args.vec_env != "dummy" or not args.foxglove[1]):
        print(
            f"{program}: --foxglove watches one run's first env: a port (not 0), --vec-env "
            "dummy, no --ray or --seeds",
            file=sys.stderr,
        )
        return 2
    if args.foxglove is not None:
        require_extra("foxglove", f"{program} --foxglove")
        quiet_sdk_log("train")
        host, port = args.foxglove
        print(
            f"{program}: the first training env goes to Foxglove at ws://{host}:{port} (whole "
            f"episodes, within {WATCH_BUDGET:.1%} of the wall time)",
            flush=True,
        )
    if args.overwrite:  # every option checked: the earlier run goes only now
        _remove_earlier_run(out)
    if sweep:  # one run per --seeds seed, as Ray tasks
        from bubblerob_cli.ray.sweep import run_sweep

        return run_sweep(args, overrides, out, command, program)
    return _train_one(args, overrides, out, command, program)


def _train_one(
    args: argparse.Namespace, overrides: dict[str, Any], out: Path, command: str, program: str
) -> int:
    """One run into ``out``; an ``OSError`` on the way (a full disk) is one line, exit 1."""
    from policies.runs import BEST_MODEL

    try:
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
            foxglove=args.foxglove,
            robots=args.robots or 8,
            conf_file=args.conf_file,
        )
    except OSError as error:
        where = f" ({error.filename})" if error.filename else ""
        print(f"{program}: training stopped: {error.strerror or error}{where}", file=sys.stderr)
        return 1
    best = out / BEST_MODEL
    kept = f"best model: {best}" if best.is_file() else "no best model: no evaluation ran"
    print(f"saved {final} ({kept}, logs: {out / 'tb'})")
    return 0
