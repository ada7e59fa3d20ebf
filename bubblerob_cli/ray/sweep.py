"""``bubblerob train --ray ADDRESS --seeds 0,1,2``: independent training runs as Ray tasks.

Each seed trains in its own task and folder (``OUT/seed_<k>``, the files of a single run). When
all are done, each run's best model is evaluated on the same validation episodes (seeds from
:data:`VALIDATION_SEED`, as Ray tasks too) and one table names the best run: highest success
rate, then mean return, as training's own ``best_model`` is chosen. ``sweep.json`` in ``OUT``
keeps the table.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import asdict
from pathlib import Path
from typing import Any

from bubblerob_cli.outputs import write_output
from bubblerob_env.extras import require_extra
from policies.protocol import VALIDATION
from policies.runs import BEST_MODEL, SWEEP_FILE, run_env_kwargs
from train.checks import MAX_SEED
from train.trainer import train

__all__ = [
    "VALIDATION_SEED",
    "add_sweep_arguments",
    "best_run",
    "run_sweep",
    "seed_list",
    "train_run",
]

VALIDATION_SEED = VALIDATION.start + 10_000
"""First seed of the sweep's comparison: validation seeds (``policies/protocol.py``), but not
the ones each run's checkpoints were chosen on (the first ``--eval-episodes`` from 1000), so
the best checkpoint's luck on those does not pick the run. Never test seeds."""


def seed_list(text: str) -> list[int]:
    """``--seeds``: distinct ints from 0 to 2^32 - 1, comma separated."""
    try:
        seeds = [int(part) for part in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"--seeds must be ints separated by commas, e.g. 0,1,2; got {text!r}"
        ) from None
    if len(set(seeds)) != len(seeds) or not all(0 <= s <= MAX_SEED for s in seeds):
        raise argparse.ArgumentTypeError(
            f"--seeds must be distinct ints from 0 to {MAX_SEED}, got {text!r}"
        )
    return seeds


def add_sweep_arguments(parser: argparse.ArgumentParser) -> None:
    """``--ray``, ``--seeds`` and ``--validation-episodes``."""
    parser.add_argument(
        "--ray",
        metavar="ADDRESS",
        help="train one run per --seeds seed as Ray tasks ('local' starts a cluster for this "
        "run, anything else is ray.init's address), then compare their best models; needs the "
        "[ray] extra",
    )
    parser.add_argument(
        "--seeds", type=seed_list, metavar="S,S,...", help="with --ray: the runs' seeds"
    )
    parser.add_argument(
        "--validation-episodes",
        type=int,
        default=20,
        help=f"with --ray: episodes each best model is evaluated on (validation seeds from "
        f"{VALIDATION_SEED:,})",
    )


def train_run(out: str, seed: int, settings: dict[str, Any]) -> str:
    """One training run (the task's body); the model the sweep evaluates.

    ``best_model.zip`` when an evaluation during training saved one, else the final model.
    """
    final = train(out=Path(out), seed=seed, progress_bar=False, **settings)
    best = Path(out) / BEST_MODEL
    return str(best if best.is_file() else final)


def best_run(results: list[Any]) -> int:
    """Index of the best :class:`~policies.evaluation.EvalResult`: success rate, then return."""
    return max(range(len(results)), key=lambda i: (results[i].success_rate, results[i].mean_return))


def _settings(args: argparse.Namespace, overrides: dict[str, Any], command: str) -> dict[str, Any]:
    return {
        "algo": args.algo,
        "env_id": args.env,
        "timesteps": args.timesteps,
        "n_envs": args.n_envs,
        "eval_freq": args.eval_freq,
        "eval_episodes": args.eval_episodes,
        "command": command,
        "overrides": overrides,
        "vec_env": args.vec_env,
        "torch_threads": args.torch_threads,
        "conf_file": args.conf_file,
    }


def _usage_error(args: argparse.Namespace) -> str | None:
    """What is wrong with ``--ray``, ``--seeds`` and ``--validation-episodes`` (None: nothing)."""
    if args.ray is None or args.seeds is None:
        return "--ray and --seeds go together (e.g. --ray local --seeds 0,1,2)"
    if args.validation_episodes < 1:
        return f"--validation-episodes must be >= 1, got {args.validation_episodes}"
    return None


def run_sweep(
    args: argparse.Namespace, overrides: dict[str, Any], out: Path, command: str, program: str
) -> int:
    """Train ``args.seeds`` as Ray tasks into ``out/seed_<k>``; evaluate and compare them."""
    problem = _usage_error(args)
    if problem is not None:
        print(f"{program}: {problem}", file=sys.stderr)
        return 2
    require_extra("ray", f"{program} --ray")
    from bubblerob_cli.ray.evaluate import evaluate_on_ray
    from bubblerob_cli.ray.session import (
        TASK_RETRIES,
        check_address,
        command_errors,
        gather,
        ray_session,
    )

    runs = [out / f"seed_{seed}" for seed in args.seeds]
    settings = _settings(args, overrides, command)
    with command_errors(program.removeprefix("bubblerob ")):
        check_address(args.ray)
        with ray_session(args.ray) as ray:
            task = ray.remote(num_cpus=1, max_retries=TASK_RETRIES)(train_run)
            start = time.perf_counter()
            refs = [
                task.remote(str(run), seed, settings)
                for run, seed in zip(runs, args.seeds, strict=True)
            ]
            models = gather(
                ray,
                refs,
                lambda model: print(f"trained {model} ({time.perf_counter() - start:.0f} s)"),
            )
            # All runs share one config, hence one env: one evaluation, every model at once.
            env_kwargs = run_env_kwargs(runs[0], args.env)
            results, _ = evaluate_on_ray(
                models, args.validation_episodes, VALIDATION_SEED, args.env, env_kwargs,
                address=args.ray,
            )  # fmt: skip
    _report(results, runs, args.seeds, out)
    return 0


def _report(results: list[Any], runs: list[Path], seeds: list[int], out: Path) -> None:
    """Print the table and the best run; keep both in ``out/sweep.json``."""
    from policies.evaluation import format_table

    best = best_run(results)
    print(format_table(results))
    print(f"best run: seed {seeds[best]} ({results[best].policy})")
    record = {
        "validation_seed": VALIDATION_SEED,
        "runs": [
            {"seed": seed, "folder": str(run), **asdict(result)}
            for seed, run, result in zip(seeds, runs, results, strict=True)
        ],
        "best": {"seed": seeds[best], "model": results[best].policy},
    }
    text = json.dumps(record, indent=2) + "\n"
    # A full disk at the end of the sweep is one line, exit 1: the runs' own folders are written.
    write_output("train", "--out", out / SWEEP_FILE, lambda path: path.write_text(text))
