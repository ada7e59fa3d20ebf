"""``python -m bubblerob_env.core``: compile the step kernel now (numba caches it on disk).

The first env step in a fresh install compiles the kernel (seconds); later processes load it from
``bubblerob_env/core/__pycache__`` (or numba's user-wide cache where that is not writable).
``make demo`` and ``make test`` run this once, so the demo's first step does not wait.
"""

from __future__ import annotations

import time

import gymnasium as gym
import numpy as np

import bubblerob_env  # noqa: F401  (registers BubbleRob-v0)


def main() -> None:
    """Reset and step one env (every kernel entry point), then say how long it took."""
    start = time.perf_counter()
    env = gym.make("BubbleRob-v0")
    env.reset(seed=0)
    env.step(np.zeros(2, dtype=np.float32))
    env.close()
    print(f"step kernel ready in {time.perf_counter() - start:.1f} s (compiled or loaded)")


if __name__ == "__main__":
    main()
