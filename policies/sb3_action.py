"""An SB3 model's deterministic action as one torch module, in float64.

The zip loader (:mod:`policies.sb3_policy`) runs it and the ONNX export traces it; it needs the
[train] extra (torch).

``predict(obs, deterministic=True)`` of a PPO model is the Gaussian's mean, clipped to the action
space (tanh-squashed and rescaled where the policy squashes); of a SAC model the squashed mean,
rescaled. :class:`DeterministicActor` computes that from already normalised observations.

Why float64: the zip (torch) and its ONNX export (onnxruntime) run the same weights, but in float32
their matrix products sum in different orders, and actions differ by ~1e-6. A policy driving a
robot in closed loop amplifies that: in 7 of 1000 test episodes the ``nav`` zip and ONNX export
of 2026-11-28 ended differently (docs/LEARNING.md, the eleventh round). In float64 the two differ
by ~1e-15, and their float32 actions are the same. The weights stay the float32 ones training
wrote; only the arithmetic is wider.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch
from gymnasium import spaces

__all__ = ["DeterministicActor"]


class DeterministicActor(torch.nn.Module):
    """The deterministic action of ``model`` (SB3 PPO or SAC) in float64, clipped or rescaled.

    ``forward`` takes a dict of observation tensors keyed as the model's ``Dict`` space, already
    normalised (VecNormalize) and pooled as in training, of any float or uint8 dtype; it returns
    float64 actions ``(batch, action_dim)``. Converts ``model``'s policy to float64 in place.
    """

    low: torch.Tensor
    high: torch.Tensor

    def __init__(self, model: Any) -> None:
        super().__init__()
        from stable_baselines3.common.distributions import (
            DiagGaussianDistribution,
            StateDependentNoiseDistribution,
        )
        from stable_baselines3.common.policies import ActorCriticPolicy

        self.policy = model.policy.double()
        self.policy.set_training_mode(False)
        space = model.observation_space
        if not isinstance(space, spaces.Dict):
            raise ValueError("only Dict observation spaces are supported (BubbleRob's)")
        self.images = [
            key
            for key, sub in space.spaces.items()
            if self.policy.normalize_images and _is_image(sub)
        ]
        self.is_actor_critic = isinstance(self.policy, ActorCriticPolicy)
        if self.is_actor_critic and not isinstance(
            self.policy.action_dist, (DiagGaussianDistribution, StateDependentNoiseDistribution)
        ):
            raise ValueError(
                f"a Box action's Gaussian policy is exported, not {type(self.policy.action_dist)}"
            )
        actions = model.action_space
        self.register_buffer("low", torch.as_tensor(actions.low, dtype=torch.float64))
        self.register_buffer("high", torch.as_tensor(actions.high, dtype=torch.float64))

    def forward(self, observations: dict[str, Any]) -> Any:
        """Float64 actions for a batch of observations (see the class)."""
        obs = {key: self._preprocessed(key, value) for key, value in observations.items()}
        if self.is_actor_critic:
            features = self.policy.pi_features_extractor(obs)
            latent = self.policy.mlp_extractor.forward_actor(features)
            mean = self.policy.action_net(latent)
            if not self.policy.squash_output:  # predict clips the Gaussian's mean
                return torch.maximum(torch.minimum(mean, self.high), self.low)
            return self._rescaled(torch.tanh(mean))
        actor = self.policy.actor  # SAC: the squashed mean, with or without gSDE
        mean = actor.mu(actor.latent_pi(actor.features_extractor(obs)))
        return self._rescaled(torch.tanh(mean))

    def _preprocessed(self, key: str, value: Any) -> Any:
        """SB3's ``preprocess_obs`` (images to [0, 1]), in float64."""
        value = value.double()
        return value / 255.0 if key in self.images else value

    def _rescaled(self, squashed: Any) -> Any:
        """A squashed action in [-1, 1] mapped onto the action space."""
        return self.low + 0.5 * (squashed + 1.0) * (self.high - self.low)

    def act(self, observations: dict[str, Any]) -> np.ndarray[Any, np.dtype[np.float32]]:
        """Float32 actions for a batch of NumPy observations (what ``predict`` returns)."""
        tensors = {key: torch.as_tensor(np.asarray(value)) for key, value in observations.items()}
        with torch.no_grad():
            actions = self(tensors)
        return np.asarray(actions.numpy(), dtype=np.float32)


def _is_image(space: spaces.Space[Any]) -> bool:
    from stable_baselines3.common.preprocessing import is_image_space

    return isinstance(space, spaces.Box) and is_image_space(space)
