"""Ray scenarios for the tests, run as ``scenarios.py RESULT_JSON '{"NAME": PARAMS, ...}'``.

ray_helpers.run_scenario starts this in a loopback-only network namespace; the test compares the
JSON it writes with what it computes itself, serially and without Ray.
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import json
import os
import signal
import socket
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import psutil
import ray

from bubblerob_cli.main import main as bubblerob
from bubblerob_cli.ray.evaluate import evaluate_on_ray

EVAL_POLICIES = ["reactive", "laser", "ppo", "random"]


def _rows_and_episodes(results: Any, chunks: Any) -> dict[str, Any]:
    return {
        "rows": [dataclasses.asdict(row) for row in results],
        "episodes": [
            {"policy": c.policy, "seed": s, **dataclasses.asdict(e)}
            for c in chunks
            for s, e in zip(c.seeds, c.episodes, strict=True)
        ],
        "nodes": sorted({c.node_id for c in chunks}),
        "tasks": len(chunks),
    }


@contextlib.contextmanager
def killing_one(task_name: str, after_s: float = 0.1) -> Iterator[list[int]]:
    """SIGKILL the first worker seen running ``task_name`` for ``after_s``: a mid-task death."""
    killed: list[int] = []
    stop = threading.Event()
    title = f"ray::{task_name}"

    def hunt() -> None:
        seen: dict[int, float] = {}
        while not stop.is_set() and not killed:
            # Only this cluster's workers (the raylet this process started is their parent):
            # another Ray run on the machine keeps its own.
            for proc in psutil.Process().children(recursive=True):
                try:
                    if (proc.cmdline() or [""])[0].strip() != title:
                        continue
                except psutil.Error:  # ended meanwhile
                    continue
                first = seen.setdefault(proc.pid, time.monotonic())
                if time.monotonic() - first >= after_s:
                    os.kill(proc.pid, signal.SIGKILL)
                    killed.append(proc.pid)
                    break
            time.sleep(0.02)

    hunter = threading.Thread(target=hunt, daemon=True)
    hunter.start()
    try:
        yield killed
    finally:
        stop.set()
        hunter.join(timeout=10)


def _cli(argv: list[str]) -> dict[str, Any]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = bubblerob(argv)
        except SystemExit as exit_:
            code = exit_.code if isinstance(exit_.code, int) else 1
    return {"code": code, "stdout": out.getvalue(), "stderr": err.getvalue()}


def evaluate(params: dict[str, Any]) -> dict[str, Any]:
    """The table and every episode of the policies, as Ray tasks of 2 seeds."""
    results, chunks = evaluate_on_ray(
        EVAL_POLICIES, params["episodes"], params["seed"], env_kwargs=params["env_kwargs"],
        chunk_size=2,
    )  # fmt: skip
    return _rows_and_episodes(results, chunks)


def evaluate_with_kill(params: dict[str, Any]) -> dict[str, Any]:
    """As :func:`evaluate`, one worker killed in the middle of a chunk."""
    with killing_one("evaluate_chunk") as killed:
        results, chunks = evaluate_on_ray(
            ["laser"], params["episodes"], params["seed"], env_kwargs=params["env_kwargs"],
            chunk_size=params["chunk_size"],
        )  # fmt: skip
    return {**_rows_and_episodes(results, chunks), "killed": killed}


def record(params: dict[str, Any]) -> dict[str, Any]:
    """``bubblerob record --ray``, optionally with a worker killed mid-bag."""
    argv = ["record", "--ray", "local", "--no-progress", *params["argv"]]
    if not params.get("kill"):
        return _cli(argv)
    with killing_one("record_chunk") as killed:
        done = _cli(argv)
    return {**done, "killed": killed}


def cli(params: dict[str, Any]) -> dict[str, Any]:
    """``bubblerob ARGV`` on this process's cluster: exit code, stdout and stderr."""
    return _cli(params["argv"])


def _trajectory(env: gym.Env[Any, Any], actions: np.ndarray) -> list[Any]:
    steps = []
    for action in actions:
        obs, reward, terminated, truncated, info = env.step(action)
        steps.append(({k: v.tolist() for k, v in obs.items()}, reward, terminated, truncated))
        if terminated or truncated:
            env.reset()
    return steps


@ray.remote
def _step_in_task(env: gym.Env[Any, Any], actions: np.ndarray) -> list[Any]:
    return _trajectory(env, actions)


def pickling(params: dict[str, Any]) -> dict[str, Any]:
    """An env mid-episode through ray.put/ray.get and into a task steps as the original does."""
    kwargs = params["env_kwargs"]
    actions = np.random.default_rng(0).uniform(-1, 1, (params["steps"], 2)).astype(np.float32)
    original = gym.make("BubbleRob-v0", **kwargs)
    original.reset(seed=5)
    _trajectory(original, actions[:10])  # mid-episode, the kernel's state not the reset's
    ref = ray.put(original)
    from_store = ray.get(ref)
    in_task = ray.get(_step_in_task.remote(ref, actions), timeout=120)
    through_store = _trajectory(from_store, actions)
    expected = _trajectory(original, actions)
    return {"same_after_get": through_store == expected, "same_in_task": in_task == expected}


def multi_node(params: dict[str, Any]) -> dict[str, Any]:
    """Evaluation and recording on a cluster of two nodes of one CPU each (one machine)."""
    from ray.cluster_utils import Cluster

    cluster = Cluster(initialize_head=True, head_node_args={"num_cpus": 1})
    cluster.add_node(num_cpus=1)
    cluster.wait_for_nodes(timeout=120)
    try:
        results, chunks = evaluate_on_ray(
            ["reactive"], params["episodes"], params["seed"], env_kwargs=params["env_kwargs"],
            address=cluster.address, chunk_size=1, timeout_s=180,
        )  # fmt: skip
        evaluated = _rows_and_episodes(results, chunks)
        recorded = _cli(["record", "--ray", cluster.address, "--no-progress", *params["record"]])
    finally:
        ray.shutdown()
        cluster.shutdown()
    return {"evaluate": evaluated, "record": recorded, "node_count": 2}


def rllib_ppo(params: dict[str, Any]) -> dict[str, Any]:
    """Iterations of train.rllib_ppo's PPO: what the env runners stepped, and the returns."""
    from train.rllib_ppo import build_config

    config = build_config(2, params["envs"], params["rollout"], params["env_kwargs"])
    algo = config.build_algo()
    try:
        results = [algo.train()["env_runners"] for _ in range(params["iterations"])]
        envs = algo.env_runner_group.foreach_env_runner(
            lambda runner: type(runner.env.unwrapped).__name__, local_env_runner=False
        )
    finally:
        algo.stop()
    return {
        "env_classes": envs,
        "steps": [r["num_env_steps_sampled_lifetime"] for r in results],
        "returns": [r.get("episode_return_mean") for r in results],
    }


SCENARIOS: dict[str, Callable[[dict[str, Any]], dict[str, Any]]] = {
    "rllib_ppo": rllib_ppo,
    "evaluate": evaluate,
    "evaluate_with_kill": evaluate_with_kill,
    "record": record,
    "cli": cli,
    "pickling": pickling,
    "multi_node": multi_node,
}


def main() -> None:
    result_file, wanted = Path(sys.argv[1]), json.loads(sys.argv[2])
    interfaces = sorted(n for _, n in socket.if_nameindex())
    if interfaces != ["lo"]:  # never run Ray where it could reach past loopback
        raise SystemExit(f"not in a loopback-only namespace: interfaces {interfaces}")
    if "multi_node" not in wanted:  # one local cluster for all the others
        ray.init(address="local", num_cpus=2, include_dashboard=False, logging_level="WARNING")
    try:
        results = {name: SCENARIOS[name](params) for name, params in wanted.items()}
    finally:
        ray.shutdown()
    result_file.write_text(json.dumps(results))


if __name__ == "__main__":
    main()
