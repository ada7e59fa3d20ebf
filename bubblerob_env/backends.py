"""The native batch's backends: ``gym.make_vec(..., vectorization_mode="vector_entry_point")``.

``backend="cpu"`` (the default) is :class:`~bubblerob_env.batch.cpu.BubbleRobVectorEnv`, bit for bit
the single env; ``backend="warp"`` is :class:`~bubblerob_env.mjwarp.WarpVectorEnv`, MuJoCo Warp
on a GPU (or Warp's CPU device), from the ``[warp]`` extra.
"""

from __future__ import annotations

import importlib.util
from typing import Any

from gymnasium.vector import VectorEnv

from bubblerob_env.batch.cpu import BubbleRobVectorEnv
from bubblerob_env.checks import check_choice

__all__ = ["BACKENDS", "make_vector_env"]

BACKENDS = ("cpu", "warp")


def make_vector_env(
    num_envs: int = 1, *, backend: str = "cpu", device: str | None = None, **kwargs: Any
) -> VectorEnv[Any, Any, Any]:
    """``num_envs`` robots on ``backend``; ``device`` only for ``"warp"`` (Warp's device name)."""
    check_choice("backend", backend, BACKENDS)
    if backend == "cpu":
        if device not in (None, "cpu"):
            raise ValueError(
                f"device={device!r} needs backend='warp'; backend='cpu' runs on the CPU"
            )
        return BubbleRobVectorEnv(num_envs, **kwargs)
    if importlib.util.find_spec("mujoco_warp") is None:
        raise ValueError(
            "backend='warp' needs MuJoCo Warp: pip install 'bubblerob[warp]' "
            "(mujoco-warp and warp-lang)"
        )
    from bubblerob_env.mjwarp import WarpVectorEnv

    return WarpVectorEnv(num_envs, device=device, **kwargs)
