"""Evaluation as Ray tasks, past one machine (``bubblerob evaluate --ray``; the [ray] extra).

Episodes are spread over tasks in chunks of consecutive seeds (:mod:`bubblerob_cli.ray.chunks`);
each task builds its own env and policy. See :mod:`bubblerob_cli.ray.session` for the addresses.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from dataclasses import dataclass
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
from policies.evaluation import EpisodeStats, EvalResult, run_episode, summarize

__all__ = ["EvalChunk", "evaluate_chunk", "evaluate_command", "evaluate_on_ray"]


@dataclass(frozen=True)
class EvalChunk:
    """What one evaluation task returns: its seeds' episodes, in seed order, and where it ran."""

    policy: str
    seeds: tuple[int, ...]
    episodes: tuple[EpisodeStats, ...]
    node_id: str


def _node_id() -> str:
    import ray

    return str(ray.get_runtime_context().get_node_id())


def evaluate_chunk(
    policy_name: str, seeds: Sequence[int], env_id: str, env_kwargs: dict[str, Any]
) -> EvalChunk:
    """Run one episode per seed, in order, with one env and one policy (the task's body).

    The same calls as :func:`policies.evaluation.evaluate`, so the same seed gives the same
    episode.
    """
    import gymnasium as gym

    from policies.loading import load_policy

    env = gym.make(env_id, **env_kwargs)
    try:
        policy = load_policy(policy_name, env)
        episodes = tuple(run_episode(env, policy, seed) for seed in seeds)
    finally:
        env.close()
    return EvalChunk(policy_name, tuple(seeds), episodes, _node_id())


def _check_seeds(chunks: Sequence[EvalChunk], policy: str, expected: range) -> None:
    """Raise unless ``chunks`` (one row's) hold each expected seed once, in order."""
    got = [seed for chunk in chunks for seed in chunk.seeds]
    if got != list(expected) or any(len(c.seeds) != len(c.episodes) for c in chunks):
        raise RuntimeError(f"Ray returned seeds {got} for {policy}, expected {list(expected)}")


def evaluate_on_ray(
    policy_names: Sequence[str],
    episodes: int,
    seed: int,
    env_id: str = "BubbleRob-v0",
    env_kwargs: dict[str, Any] | None = None,
    *,
    address: str = LOCAL,
    chunk_size: int | None = None,
    num_cpus: int | None = None,
    progress: bool = False,
    timeout_s: float | None = None,
) -> tuple[list[EvalResult], list[EvalChunk]]:
    """:func:`policies.evaluation.evaluate` for each policy, its episodes spread over Ray tasks.

    Returns the table's rows (equal to the serial ones: the same seeds, episodes summarised in
    seed order) and the chunks (per-episode results and the node each ran on). ``progress``
    shows a bar of finished episodes.
    """
    from tqdm import tqdm

    seeds = range(seed, seed + episodes)
    with ray_session(address, num_cpus) as ray:
        cpus = ray.cluster_resources().get("CPU", 1.0)
        task = ray.remote(num_cpus=1, max_retries=TASK_RETRIES)(evaluate_chunk)
        work = [
            (row, name, chunk)
            for row, name in enumerate(policy_names)
            for chunk in (
                [seeds]
                if name in ONE_STREAM_POLICIES
                else plan_chunks(seed, episodes, cpus, chunk_size)
            )
        ]
        refs = [
            task.remote(name, list(chunk), env_id, dict(env_kwargs or {}))
            for _, name, chunk in work
        ]
        total = episodes * len(policy_names)
        with tqdm(
            total=total, unit="episode", desc="evaluate", disable=not progress, file=sys.stderr
        ) as bar:
            chunks: list[EvalChunk] = gather(
                ray, refs, lambda c: bar.update(len(c.seeds)), timeout_s
            )
    results = []
    for row, name in enumerate(policy_names):  # a policy named twice gets two rows, as serially
        own = [chunk for (of, _, _), chunk in zip(work, chunks, strict=True) if of == row]
        _check_seeds(own, name, seeds)
        results.append(summarize(str(name), [e for chunk in own for e in chunk.episodes]))
    return results, chunks


def evaluate_command(args: Any) -> list[EvalResult]:
    """``bubblerob evaluate --ray ADDRESS``: the table's rows; a bad address exits with one line."""
    from bubblerob_env.extras import require_extra

    require_extra("ray", "bubblerob evaluate --ray")
    with command_errors("evaluate"):
        check_address(args.ray)
        results, chunks = evaluate_on_ray(
            args.policy, args.episodes, args.seed, args.env, args.env_kwargs, address=args.ray,
            progress=True,
        )  # fmt: skip
    nodes = len({chunk.node_id for chunk in chunks})
    print(f"{len(chunks)} Ray tasks on {nodes} node(s)", file=sys.stderr)
    return results
