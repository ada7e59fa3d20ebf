"""Evaluation and bag recording as Ray tasks: past one machine (the [ray] extra).

Episodes are spread over tasks in chunks of consecutive seeds. A task builds its own env, policy
and (for recording) :class:`~bubblerob_env.ros.recorder.RosBagRecorder`, runs its seeds in order
and returns only when they are all done, so Ray's task retries make a killed worker cost one
chunk's work and never an episode lost or counted twice: the driver takes exactly one result per
chunk and checks that the seeds it got back are the seeds it asked for.

``address`` is ``"local"`` (start a local cluster for this run and stop it after) or anything
``ray.init(address=...)`` takes: ``"auto"`` (the cluster ``ray start`` runs on this machine),
``"HOST:PORT"`` or ``"ray://HOST:10001"`` (Ray Client, needs ``ray[client]``). Every node needs
this package installed: the tasks import it.
"""

from __future__ import annotations

import logging
import math
import os
import sys
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from policies.evaluation import EpisodeStats, EvalResult, run_episode, summarize

__all__ = [
    "LOCAL",
    "ONE_STREAM_POLICIES",
    "TASK_RETRIES",
    "check_address",
    "evaluate_command",
    "EvalChunk",
    "evaluate_chunk",
    "evaluate_on_ray",
    "gather",
    "plan_chunks",
    "ray_session",
    "seed_chunks",
]

LOCAL = "local"
"""The ``--ray`` address that starts a local cluster for one run."""

TASK_RETRIES = 3
"""How often Ray reruns a task whose worker died (killed, out of memory, node lost)."""

ONE_STREAM_POLICIES = ("random",)
"""Policies whose actions depend on the episodes before (``random`` draws every action from one
generator, seeded once): all their seeds go to one task, so that a run equals the serial one."""

WORKER_NICENESS = "0"
"""The niceness of a local cluster's workers (``RAY_worker_niceness``, unless already set).
Ray starts them at 15 to keep a driver responsive; here they do all the work, and at 15 any
other busy process starves them: 200 episodes on 2 cores at load ~4 ran at 0.72x the serial
speed, at niceness 0 at 1.38x (docs/BENCHMARKS.md). Ray's job API runs its jobs' workers at 0."""

CONNECT_TIMEOUT_S = 5.0
"""How long ``HOST:PORT`` gets to accept a connection before ``--ray`` gives up on it."""

MAX_CHUNK = 10
"""Most episodes in one task: small enough that a progress bar moves and a retry is cheap."""

TAIL_SHARES = 2
"""A chunk is the episodes still unplanned over ``TAIL_SHARES`` x the cluster's CPUs (see
:func:`plan_chunks`). Fixed chunks of 7 left one of 2 CPUs idle at the end of every run for up
to 7 episodes (evaluation on Ray measured 1.55-1.74x serial on 2 cores); shrinking chunks end
with one-episode tasks."""


def seed_chunks(first: int, count: int, chunk_size: int) -> list[range]:
    """Seeds ``first .. first + count - 1`` in consecutive ranges of at most ``chunk_size``."""
    if count < 1 or chunk_size < 1:
        raise ValueError(f"count and chunk_size must be >= 1, got {count} and {chunk_size}")
    return [
        range(start, min(start + chunk_size, first + count))
        for start in range(first, first + count, chunk_size)
    ]


def plan_chunks(first: int, count: int, cpus: float, chunk_size: int | None = None) -> list[range]:
    """Seeds ``first .. first + count - 1`` as consecutive chunks, one task each.

    ``chunk_size`` fixes their size. Otherwise they shrink as the work runs out (guided
    self-scheduling, Polychronopoulos and Kuck, 1987): each is the unplanned episodes over
    :data:`TAIL_SHARES` x ``cpus``, from 1 to :data:`MAX_CHUNK`, so the last tasks hold one
    episode and no CPU waits long for another's last chunk. Ray starts tasks in the order they
    are submitted, largest first.
    """
    if chunk_size is not None:
        return seed_chunks(first, count, chunk_size)
    if count < 1:
        raise ValueError(f"count must be >= 1, got {count}")
    chunks, start, end = [], first, first + count
    while start < end:
        size = max(1, min(MAX_CHUNK, math.ceil((end - start) / (TAIL_SHARES * max(1.0, cpus)))))
        chunks.append(range(start, min(start + size, end)))
        start += size
    return chunks


def check_address(address: str) -> None:
    """One-line ``ValueError``: not an address; ``ConnectionError``: nothing listens there.

    ``ray.init`` would wait two minutes on an address where nothing listens, then exit.
    """
    if not address.strip():
        raise ValueError("--ray needs an address: 'local', 'auto', HOST:PORT or ray://HOST:PORT")
    if address in (LOCAL, "auto") or address.startswith("ray://"):
        return
    host, sep, port = address.rpartition(":")
    if not sep or not host or not port.isdigit():
        raise ValueError(
            f"--ray {address!r} is not an address: use 'local', 'auto', HOST:PORT or "
            "ray://HOST:PORT"
        )
    import socket

    try:
        socket.create_connection((host, int(port)), timeout=CONNECT_TIMEOUT_S).close()
    except OSError as error:
        raise ConnectionError(f"--ray {address}: no Ray cluster answers there ({error})") from None


@contextmanager
def _environment(**defaults: str) -> Iterator[None]:
    """Environment variables set, where the user has not, for the ``with`` block only."""
    added = {name: value for name, value in defaults.items() if name not in os.environ}
    os.environ.update(added)
    try:
        yield
    finally:
        for name in added:
            os.environ.pop(name, None)


@contextmanager
def ray_session(address: str, num_cpus: int | None = None) -> Iterator[Any]:
    """Ray connected to ``address`` for the ``with`` block; yields the ``ray`` module.

    ``"local"`` starts a cluster of ``num_cpus`` CPUs (default: all) and stops it after. A Ray
    already initialised in this process (a test's cluster, a notebook's) is used as it is and
    left running.
    """
    import ray

    if ray.is_initialized():
        yield ray
        return
    options: dict[str, Any] = {
        "include_dashboard": False,
        "log_to_driver": False,  # the tasks' own output would interleave with the table
        "logging_level": logging.WARNING,
    }
    try:
        if address == LOCAL:
            with _environment(RAY_worker_niceness=WORKER_NICENESS):
                ray.init(address=LOCAL, num_cpus=num_cpus, **options)
        else:
            ray.init(address=address, **options)
    except (ConnectionError, ValueError) as error:  # 'auto' with no cluster, a bad ray:// URL
        raise ConnectionError(f"--ray {address}: {error}") from None
    try:
        yield ray
    finally:
        ray.shutdown()


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


def gather(
    ray: Any, refs: Sequence[Any], on_done: Callable[[Any], object], timeout_s: float | None = None
) -> list[Any]:
    """Every task's result in submission order, calling ``on_done`` as each one finishes.

    Raises ``TimeoutError`` when ``timeout_s`` passes with tasks still running (they are
    cancelled); a task that failed past its retries raises its error here.
    """
    import time

    deadline = None if timeout_s is None else time.monotonic() + timeout_s
    pending = list(refs)
    results: dict[Any, Any] = {}
    while pending:
        left = None if deadline is None else max(0.0, deadline - time.monotonic())
        done, pending = ray.wait(pending, num_returns=1, timeout=left)
        if not done:
            for ref in pending:
                ray.cancel(ref, force=True)
            raise TimeoutError(f"{len(pending)} Ray task(s) still running after {timeout_s} s")
        for ref in done:
            results[ref] = ray.get(ref)
            on_done(results[ref])
    return [results[ref] for ref in refs]


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


@contextmanager
def command_errors(command: str, stopped: str = "") -> Iterator[None]:
    """One line for what goes wrong with ``--ray``, and the exit status.

    2: a bad address or argument; 1: no cluster, or a task that failed past its retries; 130:
    Ctrl-C (``stopped`` is added to its line).
    """
    from ray.exceptions import RayError, RayTaskError

    try:
        yield
    except ValueError as error:
        print(f"bubblerob {command}: {error}", file=sys.stderr)
        raise SystemExit(2) from None
    except ConnectionError as error:
        print(f"bubblerob {command}: {error}", file=sys.stderr)
        raise SystemExit(1) from None
    except KeyboardInterrupt:
        print(
            f"\nbubblerob {command}: stopped; the cluster's tasks are cancelled{stopped}",
            file=sys.stderr,
        )
        raise SystemExit(130) from None
    except RayError as error:  # the remote traceback is in the worker's log; its cause here
        cause = error.cause if isinstance(error, RayTaskError) else error
        print(f"bubblerob {command}: a Ray task failed: {_first_line(cause)}", file=sys.stderr)
        raise SystemExit(1) from None


def _first_line(error: BaseException) -> str:
    lines = str(error).strip().splitlines()
    return f"{type(error).__name__}: {lines[0] if lines else ''}"


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
