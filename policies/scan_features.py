"""A 1-D convolution over the laser scan: SB3 features for a Dict observation with a ``laser``.

SB3's default for Dict observations (``CombinedExtractor``) flattens every key and hands the
scan to fully connected layers, which must learn the same obstacle at every bearing separately.
:class:`ScanConvExtractor` slides two small filters round the scan (circular padding when the
scan is a full circle, as the BubbleRob's 360-ray laser is), so a gap or an edge looks the same
at any bearing; the other keys are flattened beside it. Every key is first divided by its
space's bound, a fixed scaling from the observation space, not running statistics (the nav
recipe feeds raw observations: docs/LEARNING.md, the ninth round).

Named in a recipe as rl-zoo names callbacks and wrappers, by module path::

    policy_kwargs:
      features_extractor_class: policies.scan_features.ScanConvExtractor

(train/zoo.py resolves the name). Loading a zip trained with it imports this module; its ONNX
export (policies/export_onnx) does not need it.
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
import torch
from gymnasium import spaces
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor

__all__ = ["ScanConvExtractor"]


class ScanConvExtractor(BaseFeaturesExtractor):
    """``laser`` through two circular 1-D convolutions, the other keys flattened, all scaled.

    ``channels`` filters of ``kernels[0]`` rays at a stride of ``strides[0]``, then as many of
    ``kernels[1]`` at ``strides[1]``, each followed by a ReLU; the features are the flattened
    maps and the other keys (sorted by name, as SB3's ``CombinedExtractor`` orders them).
    """

    def __init__(
        self,
        observation_space: spaces.Dict,
        channels: int = 16,
        kernels: tuple[int, int] = (9, 5),
        strides: tuple[int, int] = (4, 2),
        circular: bool = True,
    ) -> None:
        if "laser" not in observation_space.spaces:
            raise ValueError(
                f"ScanConvExtractor convolves the 'laser' observation; this env gives "
                f"{sorted(observation_space.spaces)} (make it with laser_num_rays > 0)"
            )
        laser = observation_space.spaces["laser"]
        others = sorted(k for k in observation_space.spaces if k != "laser")
        rays = _size(laser)
        padding: Literal["circular", "zeros"] = "circular" if circular else "zeros"
        first = torch.nn.Conv1d(
            1, channels, kernels[0], strides[0], kernels[0] // 2, padding_mode=padding
        )
        second = torch.nn.Conv1d(
            channels, channels, kernels[1], strides[1], kernels[1] // 2, padding_mode=padding
        )
        length = _conv_length(_conv_length(rays, kernels[0], strides[0]), kernels[1], strides[1])
        flat = sum(_size(observation_space.spaces[k]) for k in others)
        super().__init__(observation_space, features_dim=channels * length + flat)
        self.scan = torch.nn.Sequential(first, torch.nn.ReLU(), second, torch.nn.ReLU())
        self.others = others
        for key in ("laser", *others):
            self.register_buffer(f"scale_{key}", _inverse_bound(observation_space.spaces[key]))

    def forward(self, observations: dict[str, Any]) -> Any:
        """The features of a batch of Dict observations (tensors), one row each."""
        laser = observations["laser"].flatten(1) * self.scale_laser
        maps = laser[:, None, :]
        if maps.dtype == torch.float64:
            # The float64 path the zip loader and the ONNX export share (policies/sb3_action.py):
            # onnxruntime has no float64 Conv, so each convolution is a gather and a matmul.
            for layer in self.scan:
                if isinstance(layer, torch.nn.Conv1d):
                    maps = _conv_as_matmul(maps, layer)
                else:
                    maps = layer(maps)
        else:
            maps = self.scan(maps)
        parts = [maps.flatten(1)]
        for key in self.others:
            parts.append(observations[key].flatten(1) * getattr(self, f"scale_{key}"))
        return torch.cat(parts, dim=1)


def _conv_as_matmul(maps: Any, conv: torch.nn.Conv1d) -> Any:
    """``conv(maps)`` as a gather of its windows and one matrix product, in any dtype.

    The same products as the convolution's, summed in another order.
    """
    # Conv1d's padding is a tuple of ints here (never "same"/"valid": see __init__).
    pad, kernel, stride = int(conv.padding[0]), conv.kernel_size[0], conv.stride[0]
    if pad and conv.padding_mode == "circular":
        maps = torch.cat([maps[..., -pad:], maps, maps[..., :pad]], dim=-1)
    elif pad:
        maps = torch.nn.functional.pad(maps, (pad, pad))
    length = (maps.shape[-1] - kernel) // stride + 1
    index = torch.arange(length)[:, None] * stride + torch.arange(kernel)[None, :]
    windows = maps[:, :, index].permute(0, 2, 1, 3).flatten(2)  # (batch, length, in * kernel)
    out = windows @ conv.weight.flatten(1).T
    if conv.bias is not None:
        out = out + conv.bias
    return out.transpose(1, 2)


def _conv_length(length: int, kernel: int, stride: int) -> int:
    """Output length of a convolution padded by ``kernel // 2`` on each side."""
    return (length + 2 * (kernel // 2) - kernel) // stride + 1


def _inverse_bound(space: spaces.Space[Any]) -> Any:
    """1 / the largest magnitude each element of a Box may take (1 where unbounded or 0)."""
    assert isinstance(space, spaces.Box), space
    bound = np.maximum(np.abs(space.low), np.abs(space.high)).reshape(-1).astype(np.float64)
    usable = np.isfinite(bound) & (bound > 0)
    inverse = np.where(usable, 1.0 / np.where(usable, bound, 1.0), 1.0)
    return torch.as_tensor(inverse.astype(np.float32))


def _size(space: spaces.Space[Any]) -> int:
    """The number of elements of a Box's observation."""
    assert space.shape is not None, space
    return math.prod(space.shape)
