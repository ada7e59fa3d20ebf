"""Robot-steps/s of worlds of N robots (``WorldsVectorEnv``) against the single-robot batch.

Usage: ``python bench/multi_speed.py [--robots 1 4 8 16] [--total 64] [--threads T]
[--steps S] [--repeats R] [--json PATH] [--quick]`` (``--quick``: 16 robots, 10 steps, once; a
smoke run, no measurement).

Every row steps ``total`` robots (``total / N`` worlds of N robots each, or ``total`` one-robot
envs in ``gym.make_vec("BubbleRob-v0", num_envs=total, vectorization_mode="vector_entry_point")``)
with 360 laser rays, seeded random actions and episodes restarting as they end, on the same
number of threads. A row's rate is robot-steps per second of the whole vector step
(observations, rewards, ``info``, restarts); rows are timed ``repeats`` times, interleaved, best
kept. The target (issue 36): at 8 robots a world, at least 0.7x the single-robot batch.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from typing import Any

import gymnasium as gym
import numpy as np

import bubblerob_env  # noqa: F401  (registers BubbleRob-v0)
from bubblerob_env.multi.vector import WorldsVectorEnv

TARGET_AT_8 = 0.7


def _make(robots: int | None, total: int, threads: int) -> Any:
    """``None``: the single-robot batch; else worlds of ``robots`` robots."""
    if robots is None:
        return gym.make_vec(
            "BubbleRob-v0",
            num_envs=total,
            vectorization_mode="vector_entry_point",
            num_threads=threads,
        )
    return WorldsVectorEnv(total // robots, robots, num_threads=threads)


def _rate(venv: Any, total: int, steps: int, seed: int) -> float:
    venv.reset(seed=seed)
    actions = np.random.default_rng(seed).uniform(-0.3, 1.0, (steps, total, 2)).astype(np.float32)
    venv.step(actions[0])  # compiled and warm
    start = time.perf_counter()
    for action in actions:
        venv.step(action)
    return total * steps / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--robots", type=int, nargs="+", default=[1, 4, 8, 16])
    parser.add_argument("--total", type=int, default=64)
    parser.add_argument("--threads", type=int, default=len(os.sched_getaffinity(0)))
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", help="also write the results here")
    parser.add_argument("--quick", action="store_true", help="smoke run: 16 robots, 10 steps")
    args = parser.parse_args()
    if args.quick:
        args.total, args.steps, args.repeats = 16, 10, 1
    rows: list[int | None] = [None, *args.robots]
    envs = {n: _make(n, args.total, args.threads) for n in rows}
    best = dict.fromkeys(rows, 0.0)
    for repeat in range(args.repeats):
        for n in rows:
            best[n] = max(best[n], _rate(envs[n], args.total, args.steps, repeat))
    single = best[None]
    print(f"{args.total} robots, {args.threads} thread(s), {args.steps} steps, best of "
          f"{args.repeats}; load average {os.getloadavg()[0]:.2f}")  # fmt: skip
    print(f"{'robots a world':>16} {'robot-steps/s':>14} {'x single batch':>15}")
    print(f"{'single batch':>16} {single:14.0f} {1.0:15.2f}")
    for n in args.robots:
        print(f"{n:16d} {best[n]:14.0f} {best[n] / single:15.2f}")
    if 8 in args.robots:
        ratio = best[8] / single
        verdict = "met" if ratio >= TARGET_AT_8 else "NOT met"
        print(f"target at 8 robots a world: >= {TARGET_AT_8}x: {ratio:.2f}x, {verdict}")
    if args.json:
        results = {
            "total": args.total,
            "threads": args.threads,
            "single_batch": single,
            "worlds": {str(n): best[n] for n in args.robots},
        }
        with open(args.json, "w", encoding="utf-8") as file:
            json.dump(results, file, indent=2)
    for venv in envs.values():
        venv.close()


if __name__ == "__main__":
    main()
