"""``bubblerob evaluate --robots N``: one policy on every robot of a world, per robot-episode.

The options and their checks; the episodes are :mod:`policies.multi_evaluation`'s. With a Nav
env (``--env BubbleRobNav-v0``) every robot drives to its own goal and the table is the crowd
one (:mod:`policies.crowd_metrics`: success, robot and obstacle hits, extra time and distance,
speed).
"""

from __future__ import annotations

import argparse
import json

from bubblerob_cli.errors import fail
from bubblerob_cli.outputs import write_output
from bubblerob_env.extras import MissingExtraError

__all__ = ["add_robots_arguments", "run_robots"]


def add_robots_arguments(parser: argparse.ArgumentParser) -> None:
    """``--robots N`` and ``--scenario``."""
    parser.add_argument(
        "--robots",
        type=int,
        metavar="N",
        help="run each policy on every robot of a world of N robots (parallel_env; the [multi] "
        "extra) and report per robot-episode: success, obstacle and robot-robot collisions "
        "with Wilson 95%% intervals, speed; --episodes counts worlds",
    )
    parser.add_argument(
        "--scenario",
        choices=["random", "circle"],
        default="random",
        help="with --robots: free random start poses, or on a circle facing its centre "
        "(default: random)",
    )
    parser.add_argument(
        "--circle-jitter",
        type=float,
        default=0.0,
        metavar="M",
        help="with --scenario circle: each seed turns the circle by a random angle and moves each "
        "robot along it by up to M metres (default 0: the same circle for every seed)",
    )


def run_robots(args: argparse.Namespace) -> int:
    """Evaluate ``args.policy`` on worlds of ``args.robots`` robots and print one table."""
    from policies.crowd_metrics import format_crowd_table
    from policies.multi_evaluation import evaluate_robots, format_multi_table

    if args.robots < 1:
        fail("evaluate", f"--robots must be >= 1, got {args.robots}")
    unsupported = [
        option
        for option, value in (("--video", args.video), ("--ray", args.ray),
                              ("--foxglove", args.foxglove))
        if value is not None
    ]  # fmt: skip
    if unsupported:
        fail("evaluate", f"--robots runs in this process without video: not with {unsupported[0]}")
    results = []
    for name in args.policy:
        try:
            results.append(
                evaluate_robots(
                    name,
                    args.robots,
                    args.scenario,
                    args.episodes,
                    args.seed,
                    args.env,
                    args.env_kwargs,
                    progress=True,
                    circle_jitter=args.circle_jitter,
                )  # fmt: skip
            )
        except MissingExtraError as error:
            raise SystemExit(str(error)) from None
        except ValueError as error:  # too many robots, a bad env, a bad kwarg or jitter
            fail("evaluate", f"--robots {args.robots}: {error}")
    crowd = [(r.policy, r.num_robots, r.scenario, r.crowd) for r in results]
    if all(metrics is not None for *_, metrics in crowd):  # a Nav env: Long et al.'s metrics
        print(format_crowd_table([(p, n, s, m) for p, n, s, m in crowd if m], args.markdown))
    else:
        print(format_multi_table(results, markdown=args.markdown))
    if args.per_episode is not None:
        records = {r.policy: list(r.per_robot) for r in results}
        text = (
            "{\n"
            + ",\n".join(
                f"{json.dumps(name)}: [\n" + ",\n".join(json.dumps(e) for e in rows) + "\n]"
                for name, rows in records.items()
            )
            + "\n}\n"
        )
        # A full disk (or a folder gone) is one line, exit 1: the table is printed already.
        write_output("evaluate", "--per-episode", args.per_episode, lambda p: p.write_text(text))
        count = sum(len(rows) for rows in records.values())
        print(f"wrote {args.per_episode}: {count} robot-episodes")
    return 0
