"""``python -m train.rllib_ppo``: RLlib's PPO on BubbleRob-v0 (config: :mod:`train.rllib_ppo`)."""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence

import train.rllib_ppo
from train.rllib_ppo import build_config

__all__ = ["build_parser", "main"]


def build_parser() -> argparse.ArgumentParser:
    """Command-line arguments of ``python -m train.rllib_ppo``."""
    parser = argparse.ArgumentParser(
        prog="python -m train.rllib_ppo", description=train.rllib_ppo.__doc__
    )
    parser.add_argument("--iterations", type=int, default=5)
    parser.add_argument("--env-runners", type=int, default=2)
    parser.add_argument("--envs-per-runner", type=int, default=4)
    parser.add_argument("--rollout-length", type=int, default=64)
    parser.add_argument("--max-episode-steps", type=int, default=None, help="shorter episodes")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Train for ``--iterations`` and print each iteration's mean episode return and steps."""
    parser = build_parser()
    args = parser.parse_args(argv)
    for option in ("iterations", "env_runners", "envs_per_runner", "rollout_length"):
        if getattr(args, option) < 1:
            parser.error(f"--{option.replace('_', '-')} must be >= 1, got {getattr(args, option)}")
    try:
        import ray
    except ModuleNotFoundError:
        print("python -m train.rllib_ppo needs ray[rllib] and torch (README)", file=sys.stderr)
        return 1
    kwargs = {} if args.max_episode_steps is None else {"max_episode_steps": args.max_episode_steps}
    config = build_config(args.env_runners, args.envs_per_runner, args.rollout_length, kwargs)
    ray.init(include_dashboard=False, logging_level=logging.WARNING)
    try:
        algo = config.build_algo()
        for iteration in range(1, args.iterations + 1):
            result = algo.train()
            runners = result["env_runners"]
            mean_return = runners.get("episode_return_mean", float("nan"))
            steps = runners.get("num_env_steps_sampled_lifetime", 0)
            print(f"iteration {iteration}: return {mean_return:.2f}, {steps} env steps")
        algo.stop()
    finally:
        ray.shutdown()
    return 0
