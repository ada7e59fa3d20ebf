"""The MuJoCo Warp backend of the native batch (``backend="warp"``; the ``[warp]`` extra).

:class:`WarpVectorEnv` steps N BubbleRobs as N worlds of one MuJoCo Warp model, on a GPU or on
Warp's CPU device; :mod:`~bubblerob_env.mjwarp.kernels` holds the device code besides MuJoCo
Warp's physics, :mod:`~bubblerob_env.mjwarp.layouts` the arenas as device tables.
"""

from __future__ import annotations

from bubblerob_env.mjwarp.vector import OUTPUTS, WarpVectorEnv

__all__ = ["OUTPUTS", "WarpVectorEnv"]
