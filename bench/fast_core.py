"""The fast core's targets, side by side in one run: one env and the batch against the peers.

Usage: ``python bench/fast_core.py [--rounds R] [--steps N] [--quick]`` (prints Markdown)

Rows, each measured once per round, rounds interleaved so every row sees the same load, best
round kept (load can only slow a run down):

- ``BubbleRob-v0`` from ``gym.make`` (360 rays, camera off, wrappers included), seeded random
  wheel actions, resets inside the timed loop;
- the native batch ``BubbleRobVectorEnv`` at N=64 with 1 and with 2 threads (robot-steps/s);
- f1tenth_gym with 360 beams over 360 degrees in the anchors' 4 x 4 m arena
  (``bench/f1tenth_speed.py`` in its own venv: ``BUBBLEROB_F1T_PYTHON``, default
  ``~/venv-f1t/bin/python``; the map ``BUBBLEROB_F1T_MAP``, default
  ``../shared/anchors/f1t_arena/arena``), one thread;
- irsim-x 1.1.4, one env (``bench/irsim_speed.py``, its install folders in
  ``BUBBLEROB_IRSIMX_PATH`` and ``BUBBLEROB_IRSIM_DEPS``, as for ``bench/vector_speed.py``).

A peer that is not installed prints why, and its targets say "not measured". The f1tenth step is
0.01 s of simulated time, BubbleRob's 0.05 s (4 physics substeps): the ratios compare steps.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import gymnasium as gym
import mujoco
import numpy as np

import bubblerob_env
from bubblerob_env.vector import BubbleRobVectorEnv

HERE = Path(__file__).resolve().parent
DEFAULT_F1T_PYTHON = Path.home() / "venv-f1t" / "bin" / "python"
DEFAULT_F1T_MAP = HERE.parent.parent / "shared" / "anchors" / "f1t_arena" / "arena"
BATCH = 64
TARGETS = (
    # (label, numerator row, denominator row, target)
    ("one env vs f1tenth_gym at 360 beams", "single", "f1tenth", 1.7),  # issue 40 (21: 1.5)
    ("one env vs irsim-x", "single", "irsim-x", 3.0),
    ("batch N=64, 2 threads vs one env", "batch2", "single", 1.5),
    ("batch N=64, 2 threads vs f1tenth_gym", "batch2", "f1tenth", 2.0),
    ("batch N=64, one thread to two", "batch2", "batch1", 1.8),
)


def _single(steps: int) -> Callable[[], float]:
    env = gym.make("BubbleRob-v0")
    actions = np.random.default_rng(0).uniform(-1, 1, (steps, 2)).astype(np.float32)
    env.reset(seed=0)
    for action in actions[:200]:  # warm-up (numba's cache loads on the first step)
        env.step(action)

    def run() -> float:
        env.reset(seed=0)
        start = time.perf_counter()
        for action in actions:
            _, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                env.reset()
        return steps / (time.perf_counter() - start)

    return run


def _batch(threads: int, steps: int) -> Callable[[], float]:
    envs = BubbleRobVectorEnv(BATCH, num_threads=threads)
    calls = max(1, steps * 4 // BATCH)
    actions = np.random.default_rng(1).uniform(-1, 1, (calls, BATCH, 2)).astype(np.float32)
    envs.reset(seed=0)
    for action in actions[:5]:
        envs.step(action)

    def run() -> float:
        envs.reset(seed=0)
        start = time.perf_counter()
        for action in actions:
            envs.step(action)
        return calls * BATCH / (time.perf_counter() - start)

    return run


def _peer(command: list[str], env: dict[str, str]) -> Callable[[], float | str]:
    def run() -> float | str:
        result = subprocess.run(command, capture_output=True, text=True, env=env, check=False)
        if result.returncode != 0:
            return "failed: " + (result.stderr.strip().splitlines() or ["?"])[-1][:160]
        return float(json.loads(result.stdout.strip().splitlines()[-1])["single"])

    return run


def _peers(steps: int) -> dict[str, Callable[[], float | str] | str]:
    peers: dict[str, Callable[[], float | str] | str] = {}
    python = Path(os.environ.get("BUBBLEROB_F1T_PYTHON", DEFAULT_F1T_PYTHON))
    map_path = os.environ.get("BUBBLEROB_F1T_MAP", str(DEFAULT_F1T_MAP))
    if python.exists():
        command = [str(python), str(HERE / "f1tenth_speed.py"), "--map", map_path]
        command += ["--steps", str(steps), "--repeats", "1"]
        env = {**os.environ, "NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
        peers["f1tenth"] = _peer(command, env)
    else:
        peers["f1tenth"] = f"not measured: no {python} (set BUBBLEROB_F1T_PYTHON)"
    folder = os.environ.get("BUBBLEROB_IRSIMX_PATH")
    if folder:
        deps = os.environ.get("BUBBLEROB_IRSIM_DEPS", "")
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (folder, deps) if p)}
        command = [sys.executable, str(HERE / "irsim_speed.py"), "--repeats", "1"]
        command += ["--steps", str(steps)]
        peers["irsim-x"] = _peer(command, env)
    else:
        peers["irsim-x"] = "not measured: set BUBBLEROB_IRSIMX_PATH (see bench/vector_speed.py)"
    return peers


def measure(rounds: int, steps: int) -> dict[str, float | str]:
    """Best steps/s of every row over interleaved rounds (or why a row did not run)."""
    rows: dict[str, Callable[[], float | str] | str] = {
        "single": _single(steps),
        "batch1": _batch(1, steps),
        "batch2": _batch(2, steps),
        **_peers(steps),
    }
    best: dict[str, float | str] = {name: row for name, row in rows.items() if isinstance(row, str)}
    for _ in range(rounds):
        for name, row in rows.items():
            if isinstance(row, str):
                continue
            rate = row()
            previous = best.get(name)
            if isinstance(rate, str):
                best.setdefault(name, rate)
            elif not isinstance(previous, float) or rate > previous:
                best[name] = rate
    return best


def report(best: dict[str, float | str]) -> list[str]:
    """The table, one PASS/FAIL line per target, and the machine."""
    names = {
        "single": "BubbleRob-v0, gym.make, 1 env (360 rays)",
        "batch1": f"BubbleRob batch N={BATCH}, 1 thread",
        "batch2": f"BubbleRob batch N={BATCH}, 2 threads",
        "f1tenth": "f1tenth_gym, 1 env, 360 beams",
        "irsim-x": "irsim-x 1.1.4, 1 env",
    }
    single = best.get("single")
    lines = ["| row | steps/s | x one env |", "|:--|--:|--:|"]
    for key, label in names.items():
        value = best.get(key, "not run")
        if isinstance(value, float) and isinstance(single, float):
            lines.append(f"| {label} | {value:.0f} | {value / single:.2f} |")
        else:
            lines.append(f"| {label} | {value} | |")
    lines.append("")
    for label, top, bottom, target in TARGETS:
        a, b = best.get(top), best.get(bottom)
        if isinstance(a, float) and isinstance(b, float):
            verdict = "PASS" if a / b >= target else "FAIL"
            lines.append(f"{verdict}: {label}: {a / b:.2f}x (target >= {target}x)")
        else:
            lines.append(f"NOT MEASURED: {label}: {b if isinstance(b, str) else a}")
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    load = " ".join(f"{v:.2f}" for v in os.getloadavg())
    now = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    lines += [
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores "
        f"({usable} usable), load average {load} (1/5/15 min, at the end); date {now}",
        f"python {platform.python_version()}, mujoco {mujoco.__version__}, "
        f"bubblerob {bubblerob_env.__version__}",
    ]
    return lines


def main(argv: list[str] | None = None) -> int:
    """Measure and print; the exit status is 0 whatever the targets say."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--rounds", type=int, default=5, help="interleaved rounds (5)")
    parser.add_argument("--steps", type=int, default=3000, help="steps per row and round (3000)")
    parser.add_argument("--quick", action="store_true", help="smoke test: 1 round of 100 steps")
    args = parser.parse_args(argv)
    if args.quick:
        args.rounds, args.steps = 1, 100
    if args.rounds < 1 or args.steps < 1:
        parser.error("--rounds and --steps must be >= 1")
    print("\n".join(report(measure(args.rounds, args.steps))))
    return 0


if __name__ == "__main__":
    sys.exit(main())
