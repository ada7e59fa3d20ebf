"""``bubblerob record --ray ADDRESS``: one bag per Ray task, named by its seeds.

Each task builds its env, policy and :class:`~bubblerob_env.ros.recorder.RosBagRecorder` itself
(nothing of them crosses the wire) and records its chunk of consecutive seeds into
``OUT/bubblerob_<policy>_seed<first>-<last>``. A task whose worker dies is rerun by Ray and
rewrites its own bag from the start, so the set of bags holds each episode of the serial run
exactly once. ``OUT`` must be a folder that every node writes to (one machine, or a shared file
system).
"""

from __future__ import annotations

import os
import shlex
import sys
from dataclasses import dataclass
from decimal import Decimal
from pathlib import Path
from typing import Any

from bubblerob_cli.ray.chunks import ONE_STREAM_POLICIES, plan_chunks
from bubblerob_cli.ray.session import (
    LOCAL,
    TASK_RETRIES,
    check_address,
    command_errors,
    gather,
    ray_session,
)

__all__ = ["RecordChunk", "chunk_bag_name", "record_chunk", "record_command", "record_on_ray"]


@dataclass(frozen=True)
class RecordChunk:
    """What one recording task returns."""

    seeds: tuple[int, ...]
    bags: tuple[str, ...]
    steps: int
    node_id: str


def chunk_bag_name(policy: str, seeds: range) -> str:
    """A chunk's bag name: the policy and the first and last seed it holds."""
    return f"bubblerob_{Path(policy).stem}_seed{seeds.start}-{seeds.stop - 1}"


def record_chunk(
    policy_name: str,
    seeds: list[int],
    path: str,
    env_kwargs: dict[str, Any],
    recorder_kwargs: dict[str, Any],
    topics: tuple[str, str, bool],
    env_id: str = "BubbleRob-v0",
) -> RecordChunk:
    """Record one episode per seed into the bag at ``path`` (the task's body).

    The loop of the serial ``bubblerob record``; the policy is seeded with the chunk's first
    seed (only ``random`` uses it, and records all its seeds in one chunk, as serially). The
    bag is written afresh: a retried task replaces what its killed predecessor left.
    """
    import gymnasium as gym
    import numpy as np
    import ray

    from bubblerob_env.ros.messages.topics import topics_preset
    from bubblerob_env.ros.recorder import RosBagRecorder
    from policies.loading import load_policy

    env = gym.make(env_id, **env_kwargs)
    policy = load_policy(policy_name, env=env, seed=seeds[0])
    recorder = RosBagRecorder(
        env, path, topics=topics_preset(*topics), overwrite=True, **recorder_kwargs
    )
    steps = 0
    with recorder:
        for seed in seeds:
            obs, _ = recorder.reset(seed=seed)
            state, start, done = None, True, False
            while not done:
                action, state = policy.predict(
                    obs, state=state, episode_start=np.array([start]), deterministic=True
                )
                obs, _, terminated, truncated, _ = recorder.step(action)
                start, done = False, terminated or truncated
                steps += 1
    bags = tuple(str(p) for p in recorder.bag_paths)
    return RecordChunk(tuple(seeds), bags, steps, str(ray.get_runtime_context().get_node_id()))


def _recorder_kwargs(args: Any) -> dict[str, Any]:
    """The recorder's settings from ``record``'s arguments; the start time fixed here, once."""
    from bubblerob_env.mapping import check_resolution
    from bubblerob_env.ros.episodes import start_time_ns

    start_ns = start_time_ns(args.start_time)
    return {
        "format": args.format,
        "distro": args.distro,
        "compression": args.compression,
        "metadata": {"policy": args.policy, "command": shlex.join(["bubblerob", *sys.argv[1:]])},
        "per_episode": args.per_episode,
        # Every bag starts at the same stamp: the run's start, not each task's.
        "start_time": str(Decimal(start_ns) / 10**9),
        "map_resolution": check_resolution(args.map_resolution),
    }


def _check_targets(out: Path, names: list[str], fmt: str, overwrite: bool) -> None:
    """Fail before any task on an existing bag (without --overwrite) or an unwritable folder."""
    from bubblerob_cli.outputs import Output, check_outputs
    from bubblerob_env.ros.bags.sinks import bag_path

    bags = [Output("--out", bag_path(out / name, fmt), kind="bag") for name in names]
    check_outputs([Output("--out", out, kind="folder"), *bags], overwrite)
    out.mkdir(parents=True, exist_ok=True)


def _plan(args: Any, chunk_size: int | None, cpus: float) -> list[range]:
    """The chunks of seeds, their bags checked (see :func:`_check_targets`)."""
    if args.policy in ONE_STREAM_POLICIES:
        chunk_size = args.episodes
    chunks = plan_chunks(args.seed, args.episodes, cpus, chunk_size)
    names = [chunk_bag_name(args.policy, chunk) for chunk in chunks]
    _check_targets(args.out, names, args.format, args.overwrite)
    return chunks


def record_on_ray(
    args: Any,
    env_kwargs: dict[str, Any],
    *,
    chunk_size: int | None = None,
    num_cpus: int | None = None,
) -> list[RecordChunk]:
    """Record ``args.episodes`` episodes from ``args.seed`` as Ray tasks; the chunks, in order.

    ``args`` are ``bubblerob record``'s parsed arguments (``args.ray`` the address), and
    ``env_kwargs`` the ``gym.make`` kwargs they give (``record_env_kwargs``).
    """
    from tqdm import tqdm

    recorder_kwargs = _recorder_kwargs(args)
    plan: list[range] | None = None
    if args.ray == LOCAL:  # the CPUs are known: refuse an existing bag before a cluster starts
        plan = _plan(args, chunk_size, num_cpus or os.cpu_count() or 1)
    with ray_session(args.ray, num_cpus) as ray:
        chunks = plan or _plan(args, chunk_size, ray.cluster_resources().get("CPU", 1.0))
        names = [chunk_bag_name(args.policy, chunk) for chunk in chunks]
        task = ray.remote(num_cpus=1, max_retries=TASK_RETRIES)(record_chunk)
        topics = (args.topics, args.namespace, not args.no_detections)
        refs = [
            task.remote(
                args.policy,
                list(chunk),
                str(args.out / name),
                dict(env_kwargs),
                recorder_kwargs,
                topics,
                args.env,
            )
            for chunk, name in zip(chunks, names, strict=True)
        ]
        bar = tqdm(total=args.episodes, unit="episode", disable=args.no_progress, file=sys.stderr)
        with bar:
            done: list[RecordChunk] = gather(ray, refs, lambda c: bar.update(len(c.seeds)))
    got = [seed for chunk in done for seed in chunk.seeds]
    if got != list(range(args.seed, args.seed + args.episodes)):
        raise RuntimeError(f"Ray returned the seeds {got}, not {args.episodes} from {args.seed}")
    return done


def _check_policy(args: Any, env_kwargs: dict[str, Any]) -> None:
    from bubblerob_cli.action_type import load_checked, refuse_unused
    from bubblerob_cli.args import make_env
    from policies.loading import load_policy

    env = make_env("record", args.env, dict(env_kwargs))
    try:
        _, bare = load_checked(
            "record", args.policy, env, args.action_type,
            lambda: load_policy(args.policy, env=env, seed=args.seed),
        )  # fmt: skip
    finally:
        env.close()
    refuse_unused("record", args.action_type, bare)


def record_command(args: Any, env_kwargs: dict[str, Any]) -> int:
    """``bubblerob record --ray ADDRESS`` (its other arguments checked by the caller).

    ``env_kwargs``: the ``gym.make`` kwargs of ``args`` (``record_env_kwargs``).
    """
    from bubblerob_env.extras import require_extra

    require_extra("ray", "bubblerob record --ray")
    unfinished = "; `bubblerob recover BAG` salvages an unfinished bag's complete episodes"
    with command_errors("record", unfinished):
        check_address(args.ray)
        try:
            _check_policy(args, env_kwargs)
        except TypeError as error:
            raise ValueError(str(error)) from None
        done = record_on_ray(args, env_kwargs)
    steps = sum(chunk.steps for chunk in done)
    bags = sum(len(chunk.bags) for chunk in done)
    nodes = len({chunk.node_id for chunk in done})
    print(
        f"recorded {args.episodes} episode(s), {steps} steps to {bags} bag(s) in {args.out} "
        f"({len(done)} Ray tasks on {nodes} node(s))"
    )
    return 0
