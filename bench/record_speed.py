"""Env steps/s without recording and while recording each bag format, camera off and 64x64.

Usage: ``python bench/record_speed.py [--steps N] [--block B] [--out DIR]``

Every configuration gets its own ``BubbleRob-v0`` env, all alive at once, stepped with the same
fixed action sequence (episodes reset as they end). The configurations take turns in blocks of
``block`` steps (the order rotating each round), and each one's rate is that of its median block.
Fine interleaving puts every configuration under the same background load, so the ratios hold on
a busy machine, where best-of-a-few whole runs do not. Overhead is step time relative to the same
env without recording: ``steps/s(none) / steps/s(format) - 1``; finishing the bag (index,
metadata.yaml) is a fixed cost per bag, shown apart in milliseconds. The issue's target: MCAP
(zstd) adds at most 15% with the camera off. The load average is printed with the table.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import bubblerob_env  # noqa: F401  (registers BubbleRob-v0)
from bubblerob_env.ros import RosBagRecorder

CONFIGS = (
    ("none", None, None),
    ("mcap", "mcap", "zstd"),
    ("mcap", "mcap", "none"),
    ("sqlite3", "sqlite3", "none"),
    ("ros1", "ros1", "none"),
    ("ros1", "ros1", "lz4"),
    ("ros1", "ros1", "bz2"),
)


def measure(
    camera: bool, steps: int, block: int, out: Path
) -> dict[tuple[str, str | None], tuple[float, float]]:
    """``{(format, compression): (steps/s of the median block, seconds to finish the bag)}``."""
    envs: dict[tuple[str, str | None], Any] = {}
    for label, fmt, compression in CONFIGS:
        env = gym.make("BubbleRob-v0", camera=camera)
        if fmt is not None:
            target = out / f"{fmt}_{compression}_{int(camera)}"
            env = RosBagRecorder(env, target, format=fmt, compression=compression, overwrite=True)
        env.reset(seed=0)
        envs[(label, compression)] = env
    rng = np.random.default_rng(0)
    actions = rng.uniform(-0.2, 1.0, size=(steps, 2)).astype(np.float32)
    blocks: dict[tuple[str, str | None], list[float]] = {key: [] for key in envs}
    keys = list(envs)
    for round_, start in enumerate(range(0, steps - block + 1, block)):
        shift = round_ % len(keys)
        for key in keys[shift:] + keys[:shift]:
            env = envs[key]
            begin = time.perf_counter()
            for action in actions[start : start + block]:
                _, _, terminated, truncated, _ = env.step(action)
                if terminated or truncated:
                    env.reset()
            blocks[key].append(time.perf_counter() - begin)
    results = {}
    for key, env in envs.items():
        begin = time.perf_counter()
        env.close()  # finishing the bag: a fixed cost per bag, reported on its own
        results[key] = (block / statistics.median(blocks[key]), time.perf_counter() - begin)
    return results


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=6000, help="steps per config (default 6000)")
    parser.add_argument("--block", type=int, default=100, help="steps per turn (default 100)")
    parser.add_argument("--out", type=Path, default=None, help="where bags go (default: temp)")
    parser.add_argument("--quick", action="store_true", help="smoke test: 60 steps")
    args = parser.parse_args()
    if args.quick:
        args.steps, args.block = 60, 20
    out = args.out or Path(tempfile.mkdtemp(prefix="record_speed_"))
    try:
        load = os.getloadavg()
        rows = []
        for camera in (False, True):
            results = measure(camera, args.steps, args.block, out)
            base = results[("none", None)][0]
            for (label, compression), (rate, close_s) in results.items():
                row = (camera, label, compression or "-", rate, rate / base, base / rate - 1)
                rows.append((*row, close_s))
        header = f"{'camera':<8}{'format':<9}{'compress':<10}{'steps/s':>9}{'ratio':>8}"
        print(header + f"{'overhead':>10}{'close ms':>10}")
        for camera, label, compression, rate, ratio, overhead, close_s in rows:
            cam = "64x64" if camera else "off"
            line = f"{cam:<8}{label:<9}{compression:<10}{rate:>9.0f}{ratio:>8.2f}"
            print(line + f"{overhead:>+10.1%}{close_s * 1e3:>10.0f}")
        before, after = " ".join(f"{x:.2f}" for x in load), os.getloadavg()[0]
        print(f"load average: {before} (1/5/15 min) before, {after:.2f} after")
    finally:
        if args.out is None:
            shutil.rmtree(out, ignore_errors=True)


if __name__ == "__main__":
    main()
