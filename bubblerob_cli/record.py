"""``bubblerob record``, ``bubblerob info``, ``bubblerob replay`` and ``bubblerob recover``."""

from __future__ import annotations

import argparse
import json
import shlex
import sqlite3
import sys
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import bubblerob_env  # noqa: F401  (registers BubbleRob-v0)
from bubblerob_cli.action_type import add_action_type_option, load_checked, refuse_unused
from bubblerob_cli.args import add_env_arguments, make_env, with_options
from bubblerob_cli.errors import report
from bubblerob_cli.outputs import Output, OutputError, add_overwrite_option, check_outputs
from bubblerob_env.mapping import check_resolution
from bubblerob_env.ros.bags.sinks import COMPRESSIONS, FORMATS
from bubblerob_env.ros.messages.topics import PRESETS, topics_preset
from bubblerob_env.ros.readback.replay import ReplayError, replay_bag
from bubblerob_env.ros.readback.summary import read_summary
from bubblerob_env.ros.recorder import RosBagRecorder

__all__ = ["MAX_SEED", "add_subcommands", "bag_name", "record_env_kwargs"]

MAX_SEED = 2**63 - 1
"""Largest seed ``reset`` takes here (NumPy seeds are ints >= 0; the bag's metadata keeps int64)."""


def add_subcommands(subparsers: Any) -> None:
    """Add ``record``, ``info``, ``replay`` and ``recover`` to the ``bubblerob`` command."""
    _add_record(subparsers)
    _add_bag_readers(subparsers)


def _add_record(subparsers: Any) -> None:
    record = subparsers.add_parser(
        "record",
        help="run a policy and record its episodes as a ROS bag",
        description="Run a policy in BubbleRob-v0 and record every step as a ROS bag "
        "(ROS 2 MCAP or sqlite3, or ROS 1 .bag). Episode k is reset with seed S+k.",
    )
    record.add_argument(
        "--policy", required=True, help="reactive, laser, random, ppo or an SB3 .zip / .onnx"
    )
    add_env_arguments(record)
    record.add_argument("--episodes", type=int, default=1, help="episodes to record (default 1)")
    record.add_argument("--seed", type=int, default=0, help="seed of the first episode (default 0)")
    record.add_argument("--format", choices=FORMATS, default="mcap", help="bag format")
    all_compressions = sorted({c for options in COMPRESSIONS.values() for c in options})
    record.add_argument(
        "--compression",
        choices=all_compressions,
        default=None,
        help="mcap: zstd (default) or none; ros1: none (default), bz2 or lz4; sqlite3: none",
    )
    record.add_argument("--distro", default=None, help="jazzy (default) or humble; ros1: noetic")
    record.add_argument("--camera", action="store_true", help="record the camera (64x64)")
    record.add_argument(
        "--no-detections",
        action="store_true",
        help="with the camera: no /detections (the recogniser does not run; faster)",
    )
    record.add_argument(
        "--max-steps",
        type=int,
        default=None,
        help="step limit per episode (default: the env's time limit)",
    )
    record.add_argument("--topics", choices=sorted(PRESETS), default="default", help="names")
    record.add_argument("--namespace", default="", help="prefix for the robot's topics")
    record.add_argument("--per-episode", action="store_true", help="one bag per episode")
    add_overwrite_option(record)
    add_action_type_option(record)
    record.add_argument(
        "--start-time",
        default=None,
        help="stamp of the first frame: Unix seconds or an ISO 8601 date (default: now)",
    )
    record.add_argument(
        "--map-resolution",
        default="0.05",
        metavar="M",
        help="metres per cell of each episode's /map, 0.005 to 1",
    )
    record.add_argument("--no-progress", action="store_true", help="no progress bar")
    record.add_argument(
        "--ray",
        metavar="ADDRESS",
        help="record as Ray tasks, one bag per task named by its seeds: 'local' starts a "
        "cluster for this run, anything else is ray.init's address; needs the [ray] extra",
    )
    record.add_argument(
        "--robots",
        type=int,
        default=1,
        metavar="N",
        help="N robots in one world, each driven by --policy, in one bag (robot i's topics "
        "under /robot_i, frames robot_i/...)",
    )
    record.add_argument("--out", type=Path, required=True, help="directory for the bag")
    record.set_defaults(handler=_record)


def _add_bag_readers(subparsers: Any) -> None:
    """``info``, ``replay`` and ``recover``: each reads a bag."""
    info = subparsers.add_parser(
        "info", help="show a bag's topics, counts, duration and episodes", description=None
    )
    info.add_argument("bag", type=Path, help="a .bag, .mcap or .db3 file, or a ROS 2 bag folder")
    info.add_argument("--json", action="store_true", help="print JSON instead of text")
    info.add_argument(
        "--robot", default=None, help="a record --robots bag: one robot's topics (robot_1)"
    )
    info.set_defaults(handler=_info)

    replay = subparsers.add_parser(
        "replay",
        help="re-simulate a recorded bag and check it matches",
        description="Re-create the env of every episode from the bag's metadata, feed the "
        "recorded actions and compare every message; report the first divergence.",
    )
    replay.add_argument("bag", type=Path, help="a .bag, .mcap or .db3 file, or a ROS 2 bag folder")
    replay.add_argument("--episodes", type=int, default=None, help="replay only the first N")
    replay.add_argument(
        "--robot", default=None, help="a record --robots bag: compare one robot's topics (robot_1)"
    )
    replay.set_defaults(handler=_replay)

    recover = subparsers.add_parser(
        "recover",
        help="finish a bag whose recording was killed, or salvage a damaged one",
        description="Write a finished bag from the complete episodes of an unfinished one (its "
        "recorder was killed) and put it in its place; the original is kept as BAG.orig. A "
        "damaged bag (a failed CRC, a chunk that does not decompress) is salvaged: its complete "
        "episodes before the damage go to BAG.recovered beside it, and the original is not "
        "touched.",
    )
    recover.add_argument("bag", type=Path, help="a .bag, .mcap or .db3 file, or a ROS 2 bag folder")
    recover.set_defaults(handler=_recover)


def _load_policy(name: str, env: gym.Env[Any, Any], seed: int) -> Any:
    """The policy called ``name`` (from the ``policies`` package)."""
    from policies import load_policy

    return load_policy(name, env=env, seed=seed)


def _check_action_type(args: argparse.Namespace) -> None:
    """``--robots``: a bare zip's ``--action-type``, checked on one robot's env before the world."""
    env = make_env("record", args.env, record_env_kwargs(args))
    try:
        _, bare = load_checked(
            "record", args.policy, env, args.action_type,
            lambda: _load_policy(args.policy, env, args.seed),
        )  # fmt: skip
    except Exception:  # noqa: BLE001 - the world's own load says it in one line
        bare = args.action_type is not None
    finally:
        env.close()
    refuse_unused("record", args.action_type, bare)


def _record_usage_error(args: argparse.Namespace) -> str | None:
    """What is wrong with ``record``'s arguments, in one line, or ``None``."""
    if args.episodes < 1:
        return f"--episodes must be at least 1, got {args.episodes}"
    last = MAX_SEED - args.episodes + 1
    if not 0 <= args.seed <= last:
        return f"--seed must be from 0 to {last} (episode k: seed + k), got {args.seed}"
    if args.max_steps is not None and args.max_steps < 1:
        return f"--max-steps must be at least 1, got {args.max_steps}"
    if args.namespace:
        try:
            topics_preset(args.topics, args.namespace)
        except ValueError as error:
            return f"--namespace: {error}"
    return None


def _policy_error(name: str, error: Exception) -> str:
    """Why the policy ``name`` did not load, in one line."""
    if isinstance(error, (ValueError, TypeError, OSError)):
        return str(error)  # ours: a wrong name, a missing file
    first = str(error).strip().splitlines()[0] if str(error).strip() else ""
    # A damaged .zip or .onnx: zipfile's, onnxruntime's own exception types.
    return f"cannot load the policy file {name}: {type(error).__name__}: {first}"


def bag_name(args: argparse.Namespace) -> str:
    """The bag ``record`` writes in ``--out`` (``--ray``: one per task, named by its seeds)."""
    robots = f"_{args.robots}robots" if args.robots != 1 else ""
    return f"bubblerob_{Path(args.policy).stem}{robots}_seed{args.seed}"


def _output_problem(args: argparse.Namespace) -> str | None:
    """Why ``--out`` or a bag in it cannot be written (an existing bag: without --overwrite)."""
    from bubblerob_env.ros.bags.sinks import bag_path

    outputs = [Output("--out", args.out, kind="folder")]
    if args.ray is None:  # Ray's bags are named by their tasks' seeds: checked once planned
        bag = args.out / bag_name(args)
        episodes = [bag / f"episode_{k:06d}" for k in range(args.episodes)]
        for path in episodes if args.per_episode and args.robots == 1 else [bag]:
            outputs.append(Output("--out", bag_path(path, args.format), kind="bag"))
    try:
        check_outputs(outputs, args.overwrite)
    except OutputError as error:
        return str(error)
    return None


def record_env_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    """``gym.make`` kwargs of ``record``: ``--env-kwargs``, then ``--camera``, ``--max-steps``."""
    options: dict[str, tuple[str, Any]] = {}
    if args.camera:
        options["camera"] = ("--camera", True)
    if args.max_steps is not None:
        options["max_episode_steps"] = (f"--max-steps {args.max_steps}", args.max_steps)
    return with_options("record", args.env_kwargs, options)


def _record(args: argparse.Namespace) -> int:
    problem = _record_usage_error(args) or _output_problem(args)
    if problem is not None:
        report("record", problem)
        return 2
    if args.robots != 1:
        from bubblerob_cli.record_robots import record_robots

        _check_action_type(args)

        return record_robots(args, record_env_kwargs(args), args.out / bag_name(args))
    if args.ray is not None:  # bubblerob_cli.ray.record imports Ray; this module does not
        from bubblerob_cli.ray.record import record_command

        return record_command(args, record_env_kwargs(args))
    env = make_env("record", args.env, record_env_kwargs(args), dict_observations=True)
    name = bag_name(args)
    try:
        policy, bare = load_checked(
            "record", args.policy, env, args.action_type,
            lambda: _load_policy(args.policy, env, args.seed),
        )  # fmt: skip
    except Exception as error:  # noqa: BLE001 - said in one line by _policy_error
        env.close()
        report("record", _policy_error(args.policy, error))
        return 2
    refuse_unused("record", args.action_type, bare)
    try:
        recorder = RosBagRecorder(
            env,
            args.out / name,
            format=args.format,
            distro=args.distro,
            compression=args.compression,
            topics=topics_preset(args.topics, args.namespace, not args.no_detections),
            overwrite=args.overwrite,
            metadata={"policy": args.policy, "command": shlex.join(["bubblerob", *sys.argv[1:]])},
            per_episode=args.per_episode,
            start_time=args.start_time,
            map_resolution=check_resolution(args.map_resolution),
        )
    except FileExistsError as error:  # the library's message names overwrite=True
        env.close()
        report("record", f"bag {error.filename} already exists; pass --overwrite to replace it")
        return 2
    except (OSError, ValueError) as error:
        env.close()
        report("record", str(error))
        return 2
    done, total_steps = 0, 0
    try:
        done, total_steps = _run_episodes(args, recorder, policy)
    except KeyboardInterrupt:
        print(f"\nstopped: {_saved(recorder, args)}", file=sys.stderr)
        return 130
    except (OSError, sqlite3.Error) as error:  # disk full: the bag is finished with what fit
        report("record", f"{_io_error(error)}; {_saved(recorder, args)}")
        return 1
    print(f"recorded {done} episode(s), {total_steps} steps to {_where(recorder, args)}")
    return 0


def _run_episodes(
    args: argparse.Namespace, recorder: RosBagRecorder, policy: Any
) -> tuple[int, int]:
    """Record ``args.episodes`` episodes; ``(episodes, steps)``. The recorder is closed after."""
    from tqdm import tqdm

    progress = tqdm(total=args.episodes, unit="episode", disable=args.no_progress, file=sys.stderr)
    total_steps = 0
    with recorder, progress:
        for episode in range(args.episodes):
            obs, _ = recorder.reset(seed=args.seed + episode)
            state, start, done, steps, ret = None, True, False, 0, 0.0
            while not done:
                action, state = policy.predict(
                    obs, state=state, episode_start=np.array([start]), deterministic=True
                )
                obs, reward, terminated, truncated, _ = recorder.step(action)
                start, done = False, terminated or truncated
                steps += 1
                ret += float(reward)
            total_steps += steps
            progress.set_postfix(steps=total_steps, last_return=f"{ret:.1f}")
            progress.update()
    return args.episodes, total_steps


def _where(recorder: RosBagRecorder, args: argparse.Namespace) -> Path:
    paths = recorder.bag_paths
    return paths[0] if len(paths) == 1 else recorder.path


def _saved(recorder: RosBagRecorder, args: argparse.Namespace) -> str:
    """What an interrupted recording kept, in words (the recorder has closed the bag)."""
    complete = recorder.completed_episodes
    return f"{complete} complete episode(s) saved to {_where(recorder, args)}"


def _io_error(error: OSError | sqlite3.Error) -> str:
    if not isinstance(error, OSError):
        return f"sqlite3: {error}"
    where = f" ({error.filename})" if error.filename else ""
    return f"{error.strerror or error}{where}"


def _info(args: argparse.Namespace) -> int:
    try:
        summary = read_summary(args.bag)
    except (FileNotFoundError, OSError) as error:
        report("info", str(error))
        return 2
    if args.robot is not None:
        from bubblerob_cli.record_robots import robot_summary

        summary = robot_summary(summary, args.robot)
    if args.json:
        print(json.dumps(summary.to_dict(), indent=2, sort_keys=True))
        return 0
    print(f"bag:       {summary.path}")
    if summary.unfinished:
        print(f"unfinished recording: {len(summary.episodes)} complete episodes")
    print(f"storage:   {summary.storage}")
    print(f"duration:  {summary.duration_s:.3f} s (simulated)")
    print(f"start/end: {_utc(summary.start_ns)} / {_utc(summary.end_ns)}")
    print(f"messages:  {summary.message_count}")
    width = max((len(t.name) for t in summary.topics), default=5)
    print("topics:")
    for topic in summary.topics:
        print(f"  {topic.name:<{width}}  {topic.count:>7}  {topic.msgtype}")
    where = f" (on {summary.episode_topic})" if summary.episodes else ""
    print(f"episodes:  {len(summary.episodes)}{where}")
    for meta in summary.episodes:
        kwargs = json.dumps(meta.get("env_kwargs") or {}, sort_keys=True)
        offset = (meta["start_time_ns"] - summary.start_ns) / 1e9
        print(
            f"  #{meta['episode']}: start +{offset:.3f} s, "
            f"seed {meta.get('seed')}, policy {meta.get('policy', '-')}, "
            f"env {meta.get('env_id')} {kwargs}, distro {meta.get('distro')}"
        )
    return 0


def _utc(ns: int) -> str:
    """A stamp as a UTC date with milliseconds (and its Unix seconds)."""
    date = datetime.fromtimestamp(ns // 10**9, timezone.utc).strftime("%Y-%m-%d %H:%M:%S")
    millis = f"{ns % 10**9 // 10**6:03d}"
    return f"{date}.{millis} UTC ({ns // 10**9}.{millis} s)"


def _replay(args: argparse.Namespace) -> int:
    if args.episodes is not None and args.episodes < 1:
        report("replay", f"--episodes must be at least 1, got {args.episodes}")
        return 2
    from bubblerob_cli.record_robots import replay_world_bag

    status = replay_world_bag(args.bag, args.robot)
    if status is not None:
        return status
    try:
        outcome = replay_bag(args.bag, max_episodes=args.episodes)
    except (ReplayError, OSError) as error:
        report("replay", str(error))
        return 2
    print(outcome)
    return 0 if outcome.ok else 1


def _recover(args: argparse.Namespace) -> int:
    from bubblerob_env.ros.recover import recover_bag

    try:
        outcome = recover_bag(args.bag)
    except OSError as error:
        report("recover", str(error))
        return 2
    print(outcome)
    return 0
