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
from bubblerob_env.vision.segment import components, frame_objects, pixel_codes

__all__ = ["compile_kernels", "main"]


def compile_kernels() -> None:
    """Step one env with drifting odometry and a batch, segment a blank frame, build a field."""
    env = gym.make("BubbleRob-v0", odometry_noise=0.1, max_episode_steps=2)
    env.reset(seed=0)
    env.step(np.zeros(2, dtype=np.float32))
    env.close()
    # The batch steps through numba's dispatcher (the single env through step_packed).
    envs = gym.make_vec("BubbleRob-v0", num_envs=2, vectorization_mode="vector_entry_point")
    envs.reset(seed=0)
    envs.step(np.zeros((2, 2), dtype=np.float32))
    envs.close()
    # The recogniser's kernels on a frame of the camera's types (no rendering needed here).
    codes, value = pixel_codes(np.zeros((4, 4, 3), dtype=np.uint8), np.zeros(3))
    components(codes, value, 4)
    # The batched recogniser of a recording (a writable frame batch, as FrameBatch gathers it).
    frame_objects(np.zeros((1, 4, 4, 3), dtype=np.uint8), np.zeros(3), 8, 2)
    compile_field_kernel()


def main() -> None:
    """Compile (or load) every kernel and say how long it took."""
    start = time.perf_counter()
    compile_kernels()
    print(f"kernels ready in {time.perf_counter() - start:.1f} s (compiled or loaded)")
