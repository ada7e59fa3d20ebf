"""Evaluation of N episodes serially and as Ray tasks on a local cluster (``evaluate --ray local``).

Usage: ``python bench/ray_evaluate.py [--episodes 200] [--policy ppo] [--cpus 2] [--quick]``

Runs itself in a new network namespace with only loopback up (``unshare -n``; Ray binds the
machine's address otherwise). Three times are reported: the serial run
(:func:`policies.evaluation.evaluate`), the cluster's start-up (``ray.init`` of a local cluster
of ``--cpus`` CPUs) and the Ray run once the cluster is up (:func:`evaluate_on_ray`: task
submission, the workers' first imports, the episodes); the speed-up is given both without and
with the start-up. The two tables must be equal (the script fails otherwise). The load average
before and after is printed: other work on the machine takes CPUs from both runs.
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


def measure(policy: str, episodes: int, cpus: int, env_kwargs: dict[str, Any]) -> dict[str, Any]:
    """Serial, start-up and Ray seconds; the two tables (which must be equal)."""
    import ray

    from policies.distributed import evaluate_on_ray
    from policies.evaluation import evaluate

    start = time.perf_counter()
    serial = evaluate(policy, episodes, 1000, env_kwargs=env_kwargs)
    serial_s = time.perf_counter() - start
    start = time.perf_counter()
    ray.init(address="local", num_cpus=cpus, include_dashboard=False, logging_level="WARNING")
    startup_s = time.perf_counter() - start
    try:
        start = time.perf_counter()
        (distributed,), chunks = evaluate_on_ray([policy], episodes, 1000, env_kwargs=env_kwargs)
        ray_s = time.perf_counter() - start
    finally:
        ray.shutdown()
    if distributed != serial:
        raise SystemExit(f"the tables differ:\nserial {serial}\nray    {distributed}")
    return {"serial": serial_s, "startup": startup_s, "ray": ray_s, "tasks": len(chunks)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--policy", default="ppo")
    parser.add_argument("--cpus", type=int, default=os.cpu_count() or 1)
    parser.add_argument(
        "--quick", action="store_true", help="8 episodes of 100 steps (a smoke run)"
    )
    args = parser.parse_args()
    if not _in_loopback_namespace():
        return _reexec_in_namespace()
    episodes, env_kwargs = (8, {"max_episode_steps": 100}) if args.quick else (args.episodes, {})
    load_before = _load()
    times = measure(args.policy, episodes, args.cpus, env_kwargs)
    print(f"{episodes} episodes of {args.policy}, {args.cpus} CPUs, {times['tasks']} Ray tasks")
    print("| run | seconds | speed-up |")
    print("|---|---|---|")
    print(f"| serial | {times['serial']:.1f} | 1.00 |")
    print(
        f"| --ray local, cluster up | {times['ray']:.1f} | {times['serial'] / times['ray']:.2f} |"
    )
    total = times["ray"] + times["startup"]
    print(f"| --ray local, with start-up | {total:.1f} | {times['serial'] / total:.2f} |")
    print(f"cluster start-up: {times['startup']:.1f} s; tables equal: yes")
    print(f"load average (1/5/15 min) before: {load_before}, after: {_load()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
