"""Robot-steps/s of the native batch (``vector_entry_point``) for N robots, against one env,
IR-SIM and IR-SIM-X in the same run.

Usage: ``python bench/vector_speed.py [--sizes 1 8 64 256 1024] [--repeats R] [--quick]``

Rows, all with 360 laser rays, camera off, seeded random actions, episodes reset as they end:

- ``BubbleRob-v0`` through ``gym.make``, one env (the reference of the ``x single`` column);
- ``gym.make_vec("BubbleRob-v0", num_envs=N, vectorization_mode="vector_entry_point")`` for each
  N, on its default ``num_threads`` (the usable cores); a row's rate is robot-steps per second;
- IR-SIM (``ir-sim``) and IR-SIM-X (``irsim-x``) in BubbleRob's setting (``bench/irsim_speed.py``),
  one env each and IR-SIM-X's own batch at the same N. Both packages install a top-level ``irsim``,
  so each runs in a subprocess with its own install folder on ``PYTHONPATH``: set
  ``BUBBLEROB_IRSIM_PATH`` and ``BUBBLEROB_IRSIMX_PATH`` to folders made by
  ``pip install --target DIR --no-deps ir-sim`` (resp. ``irsim-x``), with their dependencies
  (``pip install --target DEPS shapely scipy loguru``) in ``BUBBLEROB_IRSIM_DEPS``. Rows whose
  folder is not set say so.

Our rows are timed ``repeats`` times, interleaved, best kept; the IR-SIM subprocesses keep their
own best of ``repeats``. The memory row is the resident memory the N=1024 batch added, per robot,
after stepping. The load average printed at the end says how busy the machine was.
"""

from __future__ import annotations

import argparse
import datetime
import gc
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np

import bubblerob_env  # registers BubbleRob-v0

SIZES = (1, 8, 64, 256, 1024)
# Issue 21's targets for N=64 on 2 threads (bench/fast_core.py measures them with the peers).
TARGET_X_SINGLE_AT_64 = 1.5
TARGET_X_IRSIMX_SINGLE = 3.0
TARGET_MB_PER_ROBOT = 1.0
IRSIM_SCRIPT = Path(__file__).with_name("irsim_speed.py")


def _rss_mb() -> float:
    with open("/proc/self/statm", encoding="ascii") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6


class Single:
    """One ``gym.make`` env."""

    def __init__(self, seed: int) -> None:
        self.env = gym.make("BubbleRob-v0")
        self.env.reset(seed=seed)
        self.actions = np.random.default_rng(seed).uniform(-1, 1, (2000, 2)).astype(np.float32)

    def run(self, steps: int) -> float:
        step, reset = self.env.step, self.env.reset
        start = time.perf_counter()
        for action in self.actions[:steps]:
            _, _, terminated, truncated, _ = step(action)
            if terminated or truncated:
                reset()
        return steps / (time.perf_counter() - start)


class Batch:
    """``num_envs`` robots from ``gym.make_vec(..., vectorization_mode="vector_entry_point")``."""

    def __init__(self, num_envs: int, seed: int, steps: int | None = None) -> None:
        before = _rss_mb()
        self.envs: Any = gym.make_vec(
            "BubbleRob-v0", num_envs=num_envs, vectorization_mode="vector_entry_point"
        )
        self.envs.reset(seed=seed)
        rng = np.random.default_rng(seed)
        count = steps or max(3, 4000 // num_envs)
        self.actions = rng.uniform(-1, 1, (count, num_envs, 2)).astype(np.float32)
        self.run(len(self.actions))  # warm-up, and memory after stepping
        gc.collect()
        self.mb_per_robot = (_rss_mb() - before) / num_envs

    def run(self, steps: int) -> float:
        """Robot-steps/s over (at most) ``steps`` batch steps."""
        actions = self.actions[:steps]
        start = time.perf_counter()
        for action in actions:
            self.envs.step(action)
        return len(actions) * self.envs.num_envs / (time.perf_counter() - start)


BATCH_LABEL = "BubbleRob-v0 vector_entry_point"


class BatchBench:
    """A row of ``bench/env_speed.py``: ``run(steps)`` is the time of ``steps`` robot-steps.

    An N-robot batch steps ``max(1, steps // N)`` times; the time is scaled to ``steps``
    robot-steps, so that env_speed's steps/s column reads robot-steps/s.
    """

    def __init__(self, num_envs: int, steps: int, seed: int) -> None:
        self.batch = Batch(num_envs, seed, max(1, steps // num_envs))

    def run(self, steps: int) -> float:
        return steps / self.batch.run(max(1, steps // self.batch.envs.num_envs))

    def close(self) -> None:
        self.batch.envs.close()


def batch_label(num_envs: int) -> str:
    """env_speed's label of the N-robot row."""
    return f"{BATCH_LABEL} N={num_envs}"


def env_speed_notes(
    single: float | None, rates: dict[int, float | None], repeats: int, quick: bool
) -> list[str]:
    """env_speed's lines for the batch: targets, and IR-SIM / IR-SIM-X measured here."""
    found = {n: r for n, r in rates.items() if r}
    others: list[Any] = []
    if not quick:
        others = [
            irsim("BUBBLEROB_IRSIM_PATH", (), min(repeats, 2)),
            irsim("BUBBLEROB_IRSIMX_PATH", tuple(sorted(found)), repeats),
        ]
    lines, irsimx = [], None
    for other in others:
        if isinstance(other, str):
            lines.append(f"info: IR-SIM row {other}")
            continue
        batch = ", ".join(f"N={n} {r:.0f}" for n, r in other["batch"].items() if r)
        lines.append(
            f"info: {other['package']} {other['version']}: 1 env {other['single']:.0f} steps/s"
            + (f"; its batch, robot-steps/s: {batch}" if batch else "")
        )
        irsimx = other if other["package"] == "irsim-x" else irsimx
    at64 = found.get(64)
    if at64 and single:
        ok = at64 / single >= TARGET_X_SINGLE_AT_64
        lines.append(
            f"{'PASS' if ok else 'FAIL'}: batch N=64 {at64:.0f} robot-steps/s = "
            f"{at64 / single:.2f}x the 360-ray env (target >= {TARGET_X_SINGLE_AT_64}x)"
        )
    if at64 and irsimx:
        ok = at64 / irsimx["single"] >= TARGET_X_IRSIMX_SINGLE
        lines.append(
            f"{'PASS' if ok else 'FAIL'}: batch N=64 = {at64 / irsimx['single']:.2f}x irsim-x's "
            f"single env (target >= {TARGET_X_IRSIMX_SINGLE}x)"
        )
        for n, rate in found.items():
            theirs = irsimx["batch"].get(str(n))
            if theirs:
                lines.append(f"info: batch N={n} = {rate / theirs:.2f}x irsim-x's batch")
    return lines


def irsim(package_env: str, sizes: tuple[int, ...], repeats: int) -> dict[str, Any] | str:
    """IR-SIM or IR-SIM-X measured by ``irsim_speed.py`` in a subprocess (or why not)."""
    folder = os.environ.get(package_env)
    if not folder:
        return f"not measured: set {package_env} (see the docstring)"
    path = os.pathsep.join(p for p in (folder, os.environ.get("BUBBLEROB_IRSIM_DEPS", "")) if p)
    command = [sys.executable, str(IRSIM_SCRIPT), "--repeats", str(repeats), "--batch"]
    command += [str(n) for n in sizes]
    env = {**os.environ, "PYTHONPATH": path, "MPLBACKEND": "Agg"}
    result = subprocess.run(command, capture_output=True, text=True, env=env, check=False)
    if result.returncode != 0:
        return "failed: " + (result.stderr.strip().splitlines() or ["?"])[-1][:120]
    return dict(json.loads(result.stdout.strip().splitlines()[-1]))


def _threads(batches: dict[int, Batch], n: int) -> str:
    return str(batches[n].envs.num_threads) if n in batches else "default"


def _ratio(a: float | None, b: float | None) -> str:
    return f"{a / b:.2f}" if a and b else "n/a"


def report(
    single: float, batches: dict[int, Batch], rates: dict[int, float], others: list[Any]
) -> list[str]:
    """The table and the target lines."""
    irsimx = next((o for o in others if isinstance(o, dict) and o["package"] == "irsim-x"), None)
    x_single = irsimx["single"] if irsimx else None
    lines = ["| configuration | robot-steps/s | x single | x irsim-x single | x irsim-x batch |"]
    lines.append("|:--|--:|--:|--:|--:|")
    lines.append(
        f"| BubbleRob-v0, gym.make, 1 env | {single:.0f} | 1.00 | {_ratio(single, x_single)} | - |"
    )
    for n, rate in rates.items():
        x_batch = (irsimx["batch"].get(str(n)) if irsimx else None) or None
        lines.append(
            f"| {batch_label(n)} ({_threads(batches, n)} threads) | "
            f"{rate:.0f} | {rate / single:.2f} | {_ratio(rate, x_single)} | "
            f"{_ratio(rate, x_batch)} |"
        )
    for other in others:
        if isinstance(other, str):
            lines.append(f"| IR-SIM row | {other} | | | |")
            continue
        name = f"{other['package']} {other['version']}"
        lines.append(
            f"| {name}, 1 env | {other['single']:.0f} | "
            f"{other['single'] / single:.2f} | {_ratio(other['single'], x_single)} | - |"
        )
        for n, rate in other["batch"].items():
            if rate:
                lines.append(
                    f"| {name} batch N={n} | {rate:.0f} | {rate / single:.2f} | "
                    f"{_ratio(rate, x_single)} | 1.00 |"
                )
    lines.append("")
    at64 = rates.get(64)
    if at64:
        ok = at64 / single >= TARGET_X_SINGLE_AT_64
        lines.append(
            f"{'PASS' if ok else 'FAIL'}: N=64 {at64:.0f} = {at64 / single:.2f}x the "
            f"single env (target >= {TARGET_X_SINGLE_AT_64}x)"
        )
        if x_single:
            ok = at64 / x_single >= TARGET_X_IRSIMX_SINGLE
            lines.append(
                f"{'PASS' if ok else 'FAIL'}: N=64 = {at64 / x_single:.2f}x irsim-x's "
                f"single env (target >= {TARGET_X_IRSIMX_SINGLE}x)"
            )
    if 1024 in batches:
        mb = batches[1024].mb_per_robot
        ok = mb <= TARGET_MB_PER_ROBOT
        lines.append(
            f"{'PASS' if ok else 'FAIL'}: N=1024 resident memory {mb:.3f} MB per robot "
            f"(target <= {TARGET_MB_PER_ROBOT} MB), arena "
            f"{batches[1024].envs.envs[0].model.narena} bytes per robot"
        )
    return lines


def main(argv: list[str] | None = None) -> int:
    """Measure and print the Markdown table, target lines and the machine."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--sizes", type=int, nargs="+", default=list(SIZES))
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--quick", action="store_true", help="smoke test: N=1 and 8, one run")
    args = parser.parse_args(argv)
    if args.quick:
        args.sizes, args.repeats = [1, 8], 1
    wall = time.perf_counter()
    sizes = tuple(sorted(args.sizes, reverse=True))  # the biggest first: its memory, cleanly
    batches = {n: Batch(n, args.seed) for n in sizes}
    single_env = Single(args.seed)
    single = 0.0
    rates = dict.fromkeys(sorted(sizes), 0.0)
    for _ in range(args.repeats):
        single = max(single, single_env.run(2000 if not args.quick else 50))
        for n in rates:
            batch = batches[n]
            rates[n] = max(rates[n], batch.run(len(batch.actions)))
    others = (
        []
        if args.quick
        else [
            irsim("BUBBLEROB_IRSIM_PATH", (), min(args.repeats, 2)),
            irsim("BUBBLEROB_IRSIMX_PATH", tuple(sorted(sizes)), args.repeats),
        ]
    )
    for line in report(single, batches, rates, others):
        print(line)
    load = " ".join(f"{v:.2f}" for v in os.getloadavg())
    now = datetime.datetime.now().astimezone().isoformat(timespec="seconds")
    print(
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"load average {load} (at the end); date {now}"
    )
    print(
        f"mujoco {mujoco.__version__}, gymnasium {gym.__version__}, numpy {np.__version__}, "
        f"bubblerob {bubblerob_env.__version__}; best of {args.repeats}; bench wall time "
        f"{time.perf_counter() - wall:.0f} s"
    )
    for batch in batches.values():
        batch.envs.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
