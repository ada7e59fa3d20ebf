"""Evaluation of N episodes serially and as Ray tasks on a local cluster (``evaluate --ray local``).

Usage: ``python bench/ray_evaluate.py [--episodes 200] [--policy ppo] [--cpus 2] [--quick]``

Runs itself in a new network namespace with only loopback up (``unshare -n``; Ray binds the
machine's address otherwise). Three times are reported: the serial run (one env and policy, the
loop of :func:`policies.evaluation.evaluate`), the cluster's start-up (a local cluster of
``--cpus`` CPUs, started as ``--ray local`` starts it, workers at niceness 0) and the Ray run
once the cluster is up (:func:`evaluate_on_ray`:
task submission, the workers' first imports, the episodes); the speed-up is given both without
and with the start-up. The two take turns on ``--rounds`` blocks of seeds, the order swapped each
round, so that both see the same background load; their episodes must be equal (the script fails
otherwise). The load average before and after is printed.
"""

from __future__ import annotations

import argparse
import os
import shlex
import socket
import subprocess
import sys
import time
from typing import Any


def _in_loopback_namespace() -> bool:
    return sorted(name for _, name in socket.if_nameindex()) == ["lo"]


def _reexec_in_namespace() -> int:
    command = "ip link set lo up && exec " + shlex.join([sys.executable, *sys.argv])
    return subprocess.run(["unshare", "-n", "bash", "-c", command], check=False).returncode


def _load() -> str:
    return "/".join(f"{value:.2f}" for value in os.getloadavg())


def measure(
    policy: str, episodes: int, cpus: int, env_kwargs: dict[str, Any], rounds: int
) -> dict[str, Any]:
    """Serial, start-up and Ray seconds over ``rounds`` alternating blocks of seeds.

    Serial and Ray take turns on consecutive blocks of seeds (the order swapped every round), so
    both see the same background load. Every episode of the two must be equal.
    """
    from contextlib import ExitStack

    import gymnasium as gym

    from bubblerob_cli.ray.evaluate import evaluate_on_ray
    from bubblerob_cli.ray.session import LOCAL, ray_session
    from policies.evaluation import run_episode
    from policies.loading import load_policy

    start = time.perf_counter()
    cluster = ExitStack()  # the cluster of `--ray local` (its settings), started here to time it
    cluster.enter_context(ray_session(LOCAL, cpus))
    startup_s = time.perf_counter() - start
    env = gym.make("BubbleRob-v0", **env_kwargs)  # one env and policy for all, as evaluate does
    loaded = load_policy(policy, env)
    times = {"serial": 0.0, "ray": 0.0}
    episodes_of: dict[str, list[Any]] = {"serial": [], "ray": []}
    tasks = 0
    try:
        for index, block in enumerate(_blocks(1000, episodes, rounds)):
            for run in ("serial", "ray") if index % 2 == 0 else ("ray", "serial"):
                start = time.perf_counter()
                if run == "serial":
                    done = [run_episode(env, loaded, seed) for seed in block]
                else:
                    _, chunks = evaluate_on_ray(
                        [policy], len(block), block.start, env_kwargs=env_kwargs
                    )
                    done = [episode for chunk in chunks for episode in chunk.episodes]
                    tasks += len(chunks)
                times[run] += time.perf_counter() - start
                episodes_of[run] += done
    finally:
        cluster.close()
        env.close()
    if episodes_of["serial"] != episodes_of["ray"]:
        raise SystemExit("the serial and Ray episodes differ")
    return {**times, "startup": startup_s, "tasks": tasks}


def _blocks(first: int, episodes: int, rounds: int) -> list[range]:
    size = -(-episodes // rounds)
    return [range(s, min(s + size, first + episodes)) for s in range(first, first + episodes, size)]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--policy", default="ppo")
    parser.add_argument("--cpus", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--rounds", type=int, default=4, help="alternating blocks of seeds")
    parser.add_argument(
        "--quick", action="store_true", help="8 episodes of 100 steps (a smoke run)"
    )
    args = parser.parse_args()
    if not _in_loopback_namespace():
        return _reexec_in_namespace()
    episodes, env_kwargs = (8, {"max_episode_steps": 100}) if args.quick else (args.episodes, {})
    load_before = _load()
    times = measure(args.policy, episodes, args.cpus, env_kwargs, args.rounds)
    print(
        f"{episodes} episodes of {args.policy}, {args.cpus} CPUs, {args.rounds} rounds, "
        f"{times['tasks']} Ray tasks"
    )
    print("| run | seconds | speed-up |")
    print("|---|---|---|")
    print(f"| serial | {times['serial']:.1f} | 1.00 |")
    print(
        f"| --ray local, cluster up | {times['ray']:.1f} | {times['serial'] / times['ray']:.2f} |"
    )
    total = times["ray"] + times["startup"]
    print(f"| --ray local, with start-up | {total:.1f} | {times['serial'] / total:.2f} |")
    print(f"cluster start-up: {times['startup']:.1f} s; episodes equal: yes")
    print(f"load average (1/5/15 min) before: {load_before}, after: {_load()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
