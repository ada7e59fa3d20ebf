"""Env steps/s without recording and while recording each bag format, camera off and 64x64.

Usage: ``python bench/record_speed.py [--steps N] [--block B] [--out DIR]``

Each recording configuration is measured as a pair: a plain ``BubbleRob-v0`` and the same env
wrapped in a ``RosBagRecorder``, stepped with the same fixed action sequence (episodes reset as
they end) and taking turns in blocks of ``block`` steps, the order alternating each round. Its
overhead is the median over rounds of ``time(recording block) / time(plain block beside it) - 1``:
paired blocks see the same background load, so the ratio holds on a busy machine, and only two
envs are alive at a time, as in a user's loop (an earlier version kept all 14 configurations alive
and switched every 100 steps, which charged each one the others' cache misses). ``steps/s`` is
that of the median block; the ``none`` row is the median of every plain block. Finishing the bag
(index, metadata.yaml) is a fixed cost per bag, shown apart in milliseconds. The camera rows use a
quarter of the steps and blocks. The issue's target: MCAP
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
from bubblerob_env.ros.messages.topics import Topics

NO_DETECTIONS = False
"""``--no-detections``: camera recordings leave ``/detections`` out (no recogniser runs)."""

RECORDINGS = (
    ("mcap", "zstd"),
    ("mcap", "none"),
    ("sqlite3", "none"),
    ("ros1", "none"),
    ("ros1", "lz4"),
    ("ros1", "bz2"),
)


def _run_block(env: Any, actions: np.ndarray) -> float:
    begin = time.perf_counter()
    for action in actions:
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
    return time.perf_counter() - begin


def measure_pair(
    camera: bool, fmt: str, compression: str, steps: int, block: int, out: Path
) -> tuple[list[float], list[float], float]:
    """Block times of a plain env and a recording one, taking turns; seconds to finish the bag."""
    plain = gym.make("BubbleRob-v0", camera=camera)
    target = out / f"{fmt}_{compression}_{int(camera)}"
    recording = RosBagRecorder(
        gym.make("BubbleRob-v0", camera=camera),
        target,
        format=fmt,
        compression=compression,
        overwrite=True,
        topics=Topics(detections=None) if NO_DETECTIONS else None,
    )
    plain.reset(seed=0)
    recording.reset(seed=0)
    rng = np.random.default_rng(0)
    actions = rng.uniform(-0.2, 1.0, size=(steps, 2)).astype(np.float32)
    plain_times: list[float] = []
    recording_times: list[float] = []
    for round_, start in enumerate(range(0, steps - block + 1, block)):
        chunk = actions[start : start + block]
        # Alternate who goes first, so neither always runs right after the other's cache misses.
        order = ((plain, plain_times), (recording, recording_times))
        for env, times in order if round_ % 2 == 0 else order[::-1]:
            times.append(_run_block(env, chunk))
    plain.close()
    begin = time.perf_counter()
    recording.close()  # finishing the bag: a fixed cost per bag, reported on its own
    return plain_times, recording_times, time.perf_counter() - begin


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=6000, help="steps per config (default 6000)")
    parser.add_argument("--block", type=int, default=500, help="steps per turn (default 500)")
    parser.add_argument("--out", type=Path, default=None, help="where bags go (default: temp)")
    parser.add_argument("--quick", action="store_true", help="smoke test: 60 steps")
    parser.add_argument(
        "--no-detections", action="store_true", help="camera rows without /detections"
    )
    args = parser.parse_args()
    global NO_DETECTIONS  # noqa: PLW0603 - one switch for every pair measured
    NO_DETECTIONS = args.no_detections
    if args.quick:
        args.steps, args.block = 80, 20
    out = args.out or Path(tempfile.mkdtemp(prefix="record_speed_"))
    try:
        load = os.getloadavg()
        rows = []
        for camera in (False, True):
            # The camera makes a step ~4x slower: a quarter of the steps keeps the time per row.
            steps = args.steps if not camera else max(args.steps // 4, 2 * args.block // 4)
            block = args.block if not camera else max(args.block // 4, 1)
            plain_all: list[float] = []
            camera_rows = []
            for fmt, compression in RECORDINGS:
                plain, recording, close_s = measure_pair(
                    camera, fmt, compression, steps, block, out
                )
                plain_all += plain
                # Paired rounds: each recording block against the plain block beside it in time.
                ratios = [r / p for p, r in zip(plain, recording, strict=True)]
                overhead = statistics.median(ratios) - 1
                rate = block / statistics.median(recording)
                camera_rows.append((camera, fmt, compression, rate, 1 / (1 + overhead), overhead))
                camera_rows[-1] += (close_s,)
            base = block / statistics.median(plain_all)
            rows.append((camera, "none", "-", base, 1.0, 0.0, 0.0))
            rows += camera_rows
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
