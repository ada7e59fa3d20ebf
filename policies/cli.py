"""``bubblerob evaluate`` (policies side by side, optionally a video) and ``bubblerob demo``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from bubblerob_cli.args import add_env_arguments
from policies.evaluation import (
    DEFAULT_EVAL_SEED,
    EvalResult,
    evaluate,
    format_table,
    record_video,
)
from policies.protocol import SPLITS, TEST, VALIDATION

__all__ = ["add_subcommands"]


def add_subcommands(subparsers: Any) -> None:
    """Register ``evaluate`` and ``demo``."""
    parser = subparsers.add_parser(
        "evaluate",
        help="evaluate policies on validation or test seeds and print one table",
        description="Run each policy for the same episodes (seeds SEED, SEED+1, ...; by "
        "default validation seeds from 1000, never started by training) and print one table "
        "with the success rate's Wilson 95% interval; optionally record one episode as a video. "
        "Choose on validation seeds; report on --split test (policies/protocol.py).",
    )
    parser.add_argument(
        "--policy",
        action="append",
        required=True,
        help="reactive, laser, random, ppo, or a path to an exported .onnx or an SB3 .zip; "
        "repeat to compare",
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
        help="also write each episode's seed, outcome, length, return and speed to this file",
    )
    parser.add_argument(
        "--video", type=Path, help="also write the first episode (seed SEED) as .mp4 or .gif"
    )
    parser.add_argument(
        "--video-policy",
        help="the policy --video records (default: the first --policy)",
    )
    parser.add_argument(
        "--ray",
        metavar="ADDRESS",
        help="spread the episodes over Ray tasks: 'local' starts a cluster for this run, "
        "anything else is ray.init's address ('auto', HOST:PORT); needs the [ray] extra",
    )
    parser.set_defaults(handler=_run_evaluate)

    demo = subparsers.add_parser(
        "demo",
        help="drive with the shipped policy: table, MCAP bag and video",
        description="Run a policy (default: the shipped PPO) for a few episodes, print its "
        "evaluation table, record the episodes as an MCAP bag and write a video.",
    )
    demo.add_argument(
        "--policy", default="ppo", help="ppo, laser, reactive, random, an .onnx or an SB3 .zip"
    )
    demo.add_argument("--episodes", type=int, default=3, help="episodes to drive and record")
    demo.add_argument("--seed", type=int, default=DEFAULT_EVAL_SEED, help="first episode seed")
    demo.add_argument("--out", type=Path, default=Path("demo_output"), help="output folder")
    demo.add_argument("--no-video", action="store_true", help="skip the video")
    add_env_arguments(demo)
    demo.set_defaults(handler=_run_demo)


def _check_policies(command: str, names: list[str], env_id: str, env_kwargs: Any) -> None:
    """Load each policy once before any episode: a wrong name or file is one line, exit 1."""
    import gymnasium as gym

    from policies.loading import load_policy

    for name in names:
        try:
            env = gym.make(env_id, **(env_kwargs or {}))
        except (gym.error.Error, TypeError, ValueError) as error:  # a usage error: exit 2
            print(f"bubblerob {command}: --env {env_id} --env-kwargs: {error}", file=sys.stderr)
            raise SystemExit(2) from None
        try:
            load_policy(name, env)
        except (ValueError, TypeError, OSError) as error:
            raise SystemExit(f"bubblerob {command}: {error}") from None
        except Exception as error:  # noqa: BLE001 - a damaged .zip or .onnx: zipfile, onnxruntime
            raise SystemExit(
                f"bubblerob {command}: cannot load the policy file {name}: "
                f"{type(error).__name__}: {str(error).strip().splitlines()[0]}"
            ) from None
        finally:
            env.close()


def _usage(command: str, args: argparse.Namespace) -> None:
    """Exit 2 with one line if ``--seed``, ``--episodes`` or ``--video``'s folder is unusable."""
    problem = None
    split = SPLITS.get(getattr(args, "split", None) or "")
    if args.seed is None:
        args.seed = DEFAULT_EVAL_SEED if split is None else split.start
    if args.episodes < 1:
        problem = f"--episodes must be >= 1, got {args.episodes}"
    elif not 0 <= args.seed <= 2**32 - 1 - args.episodes:
        problem = f"--seed must be from 0 to {2**32 - 1 - args.episodes}, got {args.seed}"
    elif split is not None and (outside := split.outside(args.seed, args.episodes)):
        problem = f"--split {split.name}: {outside}"
    elif getattr(args, "video", None) is not None:
        try:
            Path(args.video).resolve().parent.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            problem = f"--video {args.video}: cannot create its folder ({error.strerror or error})"
    if problem is None and getattr(args, "per_episode", None) is not None:
        try:
            Path(args.per_episode).resolve().parent.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            problem = f"--per-episode {args.per_episode}: cannot create its folder ({error})"
    if problem is not None:
        print(f"bubblerob {command}: {problem}", file=sys.stderr)
        raise SystemExit(2)


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


def _run_demo(args: argparse.Namespace) -> int:
    from policies.demo import main_demo

    _usage("demo", args)
    _check_policies("demo", [args.policy], args.env, args.env_kwargs)
    try:
        return main_demo(
            args.policy,
            args.episodes,
            args.seed,
            args.out,
            not args.no_video,
            env_id=args.env,
            env_kwargs=args.env_kwargs,
        )
    except OSError as error:  # an unwritable --out: the recorder or the video says where
        raise SystemExit(f"bubblerob demo: {error}") from None


def _run_evaluate(args: argparse.Namespace) -> int:
    _usage("evaluate", args)
    video_policy = args.video_policy or args.policy[0]
    if args.video is not None:
        if args.video.suffix.lower() not in (".mp4", ".gif"):
            raise SystemExit(f"--video must end in .mp4 or .gif, got {args.video}")
        if args.video_policy is not None and args.video_policy not in args.policy:
            raise SystemExit(f"--video-policy {args.video_policy} is not one of --policy")
    _check_policies("evaluate", list(args.policy), args.env, args.env_kwargs)
    if args.ray is not None:
        from policies.distributed import evaluate_command

        results = evaluate_command(args)
    else:
        results = [
            evaluate(name, args.episodes, args.seed, args.env, args.env_kwargs, progress=True)
            for name in args.policy
        ]
    print(format_table(results, markdown=args.markdown))
    if args.per_episode is not None:
        _write_per_episode(args.per_episode, results)
    if args.video is not None:
        frames = record_video(
            video_policy, args.video, args.seed, args.env, args.env_kwargs, progress=True
        )
        print(f"wrote {args.video}: policy {video_policy}, seed {args.seed}, {frames} frames")
    return 0
