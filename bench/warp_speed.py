"""``backend="warp"`` robot-steps/s against the number of worlds, with its anchors in the same run.

Usage: ``python bench/warp_speed.py [--device cuda:0] [--sizes 1024,4096,16384,65536]
[--steps 50] [--json FILE]`` (prints Markdown). Needs the ``[warp]`` extra.

Rows, per N: the env's ``step`` with numpy outputs (what a CPU learner gets: observations,
rewards and the full ``info`` on the host), with ``outputs="warp"`` (observations stay on the
device), and MuJoCo Warp's floor for the same worlds: 4 x (``step2`` + ``step1``) and one
``mjw.rays`` call of the 360-ray laser, nothing else. Anchor: the CPU native batch
(``BubbleRobVectorEnv``, N=64, every core) in the same run. The device is named in the output;
on a CPU device (``--device cpu``) the numbers only show that the path runs: MuJoCo Warp is built
for GPUs. Issue #29's target: >= 1M robot-steps/s with the 360-ray laser on one H100.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import time
from typing import Any

import numpy as np
import warp as wp

import bubblerob_env  # noqa: F401  (registers the env ids)
from bubblerob_env.mjwarp import WarpVectorEnv
from bubblerob_env.vector import BubbleRobVectorEnv


def _rate(step: Any, n: int, steps: int) -> float:
    step()  # the first call loads kernels
    wp.synchronize()
    start = time.perf_counter()
    for _ in range(steps):
        step()
    wp.synchronize()
    return n * steps / (time.perf_counter() - start)


def _warp_rows(n: int, steps: int, device: str | None) -> dict[str, float]:
    started = time.perf_counter()
    env = WarpVectorEnv(n, device=device, max_episode_steps=1000)
    env.reset(seed=0)
    reset_s = time.perf_counter() - started
    actions = np.random.default_rng(0).uniform(-1, 1, (n, 2)).astype(np.float32)
    numpy_rate = _rate(lambda: env.step(actions), n, steps)
    device_env = WarpVectorEnv(n, device=device, max_episode_steps=1000, outputs="warp")
    device_env.reset(seed=0)
    device_actions = wp.array(actions, device=env.device)
    device_rate = _rate(lambda: device_env.step(device_actions), n, steps)
    worlds = env.worlds

    def floor() -> None:
        worlds.physics()
        worlds.sense(active=None, resetting=np.zeros(n, dtype=bool))

    return {
        "numpy": numpy_rate,
        "device": device_rate,
        "floor": _rate(floor, n, steps),
        "reset_s": reset_s,
    }


def _cpu_batch(steps: int) -> float:
    env = BubbleRobVectorEnv(64)
    env.reset(seed=0)
    actions = np.random.default_rng(0).uniform(-1, 1, (64, 2)).astype(np.float32)
    rate = _rate(lambda: env.step(actions), 64, steps * 10)
    env.close()
    return rate


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default=None, help="Warp device (default: Warp's)")
    parser.add_argument("--sizes", default="1024,4096,16384,65536", help="N, comma-separated")
    parser.add_argument("--steps", type=int, default=50, help="timed steps per row")
    parser.add_argument("--json", default=None, help="also write the numbers to this file")
    args = parser.parse_args()
    sizes = [int(size) for size in args.sizes.split(",")]
    device = wp.get_device(args.device)
    cpu = _cpu_batch(args.steps)
    rows = {n: _warp_rows(n, args.steps, args.device) for n in sizes}
    print(f"# backend='warp', {datetime.datetime.now(datetime.UTC):%Y-%m-%d %H:%M} UTC")
    print(
        f"device: {device.alias} ({device.name}); host: {platform.machine()}, "
        f"{os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}"
    )
    print(f"anchor: CPU native batch, N=64: {cpu:,.0f} robot-steps/s\n")
    print(
        "| N | step, numpy outputs | step, outputs='warp' | MuJoCo Warp floor | "
        "vs CPU batch | reset(seed) s |"
    )
    print("|---|---|---|---|---|---|")
    for n, row in rows.items():
        print(
            f"| {n} | {row['numpy']:,.0f} | {row['device']:,.0f} | {row['floor']:,.0f} | "
            f"{row['device'] / cpu:.2f}x | {row['reset_s']:.1f} |"
        )
    if args.json:
        with open(args.json, "w") as out:
            json.dump({"device": device.name, "cpu_batch": cpu, "rows": rows}, out, indent=1)


if __name__ == "__main__":
    main()
