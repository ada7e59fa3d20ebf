"""``python -m bubblerob_env.core``: compile every numba kernel now (numba caches them on disk).

A kernel's first call in a fresh install compiles it (seconds each; 7 s for the likelihood field
alone on this 2-core machine); later processes load it from the package's ``__pycache__`` (or
numba's user-wide cache where that is not writable). ``make demo`` and ``make test`` run this
once, so neither the demo's first step nor a node's first localisation waits.
"""

from __future__ import annotations

import time

import gymnasium as gym
import numpy as np

import bubblerob_env  # noqa: F401  (registers BubbleRob-v0)
from bubblerob_env.localisation.field import compile_field_kernel
from bubblerob_env.vision.recognise import Recogniser


def main() -> None:
    """Step one env with drifting odometry and a camera, recognise its frame, build a field."""
    start = time.perf_counter()
    env = gym.make(
        "BubbleRob-v0", odometry_noise=0.1, camera=True, obstacle_colours=True, max_episode_steps=2
    )
    obs, _ = env.reset(seed=0)
    obs, *_ = env.step(np.zeros(2, dtype=np.float32))
    Recogniser.for_env(env.unwrapped)(obs["camera"])
    env.close()
    compile_field_kernel()
    print(f"kernels ready in {time.perf_counter() - start:.1f} s (compiled or loaded)")


if __name__ == "__main__":
    main()
