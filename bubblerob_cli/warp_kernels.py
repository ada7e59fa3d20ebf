"""``python -m bubblerob_env.mjwarp [DEVICE ...]``: compile MuJoCo Warp's and the backend's kernels.

Warp compiles kernels on first use (about 90 s on two CPU cores for the CPU device) and keeps
them in its kernel cache (``~/.cache/warp``), where later runs load them in seconds. ``make
test``'s set-up runs this, so that the tests do not pay the compile; on a GPU machine, pass the
device (``cuda:0``) to compile its kernels too. No device named: ``cpu``.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Sequence

import numpy as np
import warp as wp

from bubblerob_env.mjwarp import WarpVectorEnv

__all__ = ["compile_kernels", "main"]


def compile_kernels(device: str) -> None:
    """Two worlds on ``device`` through a reset and an autoreset; device outputs and actions."""
    env = WarpVectorEnv(2, device=device, max_episode_steps=2, layout_bank=2)
    env.reset(seed=0)
    for _ in range(3):
        env.step(np.zeros((2, 2), dtype=np.float32))
    env.close()
    flat = WarpVectorEnv(2, device=device, layout_bank=2, outputs="warp", obs_mode="flat")
    flat.reset(seed=0)
    flat.step(wp.zeros((2, 2), dtype=float, device=flat.device))
    flat.close()


def main(argv: Sequence[str] | None = None) -> None:
    """Compile the kernels of each device in ``argv`` (default: the process arguments, or cpu)."""
    devices = list(sys.argv[1:] if argv is None else argv) or ["cpu"]
    for device in devices:
        started = time.perf_counter()
        compile_kernels(device)
        print(f"MuJoCo Warp kernels ready on {device} ({time.perf_counter() - started:.0f} s)")
