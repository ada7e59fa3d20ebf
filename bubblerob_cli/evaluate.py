"""``bubblerob evaluate`` (policies side by side, optionally a video) and ``bubblerob demo``."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from bubblerob_cli.action_type import add_action_type_option
from bubblerob_cli.args import add_env_arguments
from bubblerob_cli.demo import add_demo_subcommand
from bubblerob_cli.errors import fail
from bubblerob_cli.evaluate_robots import add_robots_arguments, run_robots
from bubblerob_cli.foxglove_view import add_foxglove_option, evaluate_live
from bubblerob_cli.outputs import Output, add_overwrite_option, require_outputs, write_output
from bubblerob_cli.policy_checks import check_episode_arguments, check_policies
from policies.evaluation import (
    DEFAULT_EVAL_SEED,
    EvalResult,
    FfmpegNotFoundError,
    evaluate,
    format_table,
    record_video,
)
from policies.protocol import TEST, VALIDATION

__all__ = ["add_subcommands"]


def add_subcommands(subparsers: Any) -> None:
    """Register ``evaluate`` and ``demo``."""
    parser = subparsers.add_parser(
        "evaluate",
        help="evaluate policies on validation or test seeds and print one table",
        description="Run each policy for the same episodes (seeds SEED, SEED+1, ...; by "
        "default validation seeds from 1000, never started by training) and print one table "
        "with the success rate's Wilson 95% interval (on a Nav env: success, collision and timeout "
        "with theirs, SPL, extra time and distance over the shortest path, speed); optionally "
        "record one episode as a video. "
        "Choose on validation seeds; report on --split test (policies/protocol.py).",
    )
    parser.add_argument(
        "--policy",
        action="append",
        required=True,
        help="reactive, laser, random, ppo, or a path to an exported .onnx or an SB3 .zip; "
        "nav, navigator, navigator_observed, pursuit, crowd, crowd_navigator or "
        "crowd_navigator_observed on a Nav env "
        "(--env BubbleRobNav-v0); repeat to compare",
    )
    parser.add_argument("--episodes", type=int, default=100, help="episodes per policy")
    parser.add_argument(
        "--seed",
        type=int,
        help=f"first episode seed (default: {DEFAULT_EVAL_SEED}, or the --split's first seed)",
    )
    parser.add_argument(
        "--split",
        choices=["validation", "test"],
        help="keep every episode seed in this range of policies/protocol.py: validation "
        f"({VALIDATION.start}-{VALIDATION.stop - 1}, for every choice) or test "
        f"({TEST.start}-{TEST.stop - 1}, for reported numbers only)",
    )
    add_env_arguments(parser)
    parser.add_argument("--markdown", action="store_true", help="print a Markdown table")
    parser.add_argument(
        "--per-episode",
        type=Path,
        metavar="JSON",
        help="also write each episode's seed, outcome, length, return and speed to this file "
        "(on a Nav env also its goal, shortest and driven path, time and SPL)",
    )
    parser.add_argument(
        "--video", type=Path, help="also write the first episode (seed SEED) as .mp4 or .gif"
    )
    parser.add_argument(
        "--video-policy",
        help="the policy --video records (default: the first --policy)",
    )
    add_overwrite_option(parser)
    add_action_type_option(parser)
    parser.add_argument(
        "--ray",
        metavar="ADDRESS",
        help="spread the episodes over Ray tasks: 'local' starts a cluster for this run, "
        "anything else is ray.init's address ('auto', HOST:PORT); needs the [ray] extra",
    )
    add_foxglove_option(parser)
    add_robots_arguments(parser)
    parser.set_defaults(handler=_run_evaluate)

    add_demo_subcommand(subparsers)


def _write_per_episode(path: Path, results: list[EvalResult]) -> None:
    import json

    records = {r.policy: list(r.per_episode) for r in results}
    # One episode a line: a 1000-episode file stays readable and diffs by episode.
    policies = [
        f"{json.dumps(name)}: [\n" + ",\n".join(json.dumps(e) for e in episodes) + "\n]"
        for name, episodes in records.items()
    ]
    path.write_text("{\n" + ",\n".join(policies) + "\n}\n")
    print(f"wrote {path}: {sum(len(v) for v in records.values())} episodes")


def _run_evaluate(args: argparse.Namespace) -> int:
    check_episode_arguments("evaluate", args)
    video_policy = args.video_policy or args.policy[0]
    if args.video_policy is not None and args.video_policy not in args.policy:
        fail("evaluate", f"--video-policy {args.video_policy} is not one of --policy {args.policy}")
    require_outputs(
        "evaluate",
        [
            args.per_episode and Output("--per-episode", args.per_episode, (".json",)),
            args.video and Output("--video", args.video, (".mp4", ".gif")),
        ],
        args.overwrite,
    )
    check_policies("evaluate", list(args.policy), args.env, args.env_kwargs, args.action_type)
    if args.robots is not None:
        return run_robots(args)
    if args.ray is not None and args.foxglove is not None:
        fail("evaluate", "--foxglove publishes from this process: not with --ray")
    if args.ray is not None:
        from bubblerob_cli.ray.evaluate import evaluate_command

        results = evaluate_command(args)
    elif args.foxglove is not None:
        results = evaluate_live(args)
    else:
        results = [
            evaluate(name, args.episodes, args.seed, args.env, args.env_kwargs, progress=True)
            for name in args.policy
        ]
    print(format_table(results, markdown=args.markdown))
    if args.per_episode is not None:
        write_output(
            "evaluate",
            "--per-episode",
            args.per_episode,
            lambda path: _write_per_episode(path, results),
        )
    if args.video is not None:
        try:
            frames = record_video(
                video_policy, args.video, args.seed, args.env, args.env_kwargs, progress=True
            )
        except FfmpegNotFoundError as error:  # one line: what to install
            raise SystemExit(str(error)) from None
        except OSError as error:  # a full disk: the episodes' table is printed already
            fail("evaluate", f"cannot write --video {args.video}: {error.strerror or error}", 1)
        print(f"wrote {args.video}: policy {video_policy}, seed {args.seed}, {frames} frames")
    return 0
