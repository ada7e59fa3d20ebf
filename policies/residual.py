"""Residual learning on the gap follower: a trained correction added to the ``laser`` policy.

The network does not drive on its own: each step the hand-written gap follower
(:class:`~policies.handwritten.LaserPolicy`) proposes an action from the full scan, and the
network's output, scaled by ``scale``, is added to it; the sum is clipped to the action box
(residual policy learning: Silver et al., 2018; Johannink et al., 2019). The network starts near
zero, so training starts from the gap follower's behaviour and learns what to change: here, to
drive faster where the scan allows it.

Training wraps the env in :class:`ResidualOnLaser` through rl-zoo's ``env_wrapper`` (listed
*before* any :class:`~bubblerob_env.wrappers.LaserPooling`: the gap follower reads the full scan,
the network the pooled one). A trained model replays it with :class:`ResidualPolicy`:
``load_policy`` does so for an SB3 ``.zip`` whose run's ``config.yml`` lists the wrapper
(:func:`policies.runs.residual_scale`), and for an ONNX export whose metadata records
``residual`` (the export writes it).
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.utils import RecordConstructorArgs
from numpy.typing import NDArray

from policies.base import Observation, Policy
from policies.builtin import builtin_policy, controller
from policies.observations import bubblerob_base

__all__ = [
    "RESIDUAL_ON_LASER",
    "ResidualOnLaser",
    "ResidualPolicy",
    "check_scale",
    "combine",
    "on_gap_follower",
]

RESIDUAL_ON_LASER = "policies.residual.ResidualOnLaser"
"""How rl-zoo's ``env_wrapper`` names :class:`ResidualOnLaser` (``policies.runs.residual_scale``
reads its ``scale``)."""


def check_scale(scale: Any) -> float:
    """``scale`` as a float; ``ValueError`` unless it is a number in (0, 2] (or its text)."""
    try:
        value = float(scale) if not isinstance(scale, bool) else math.nan
    except (TypeError, ValueError):
        value = math.nan  # not a number: the message below says what is allowed
    if not 0.0 < value <= 2.0:
        raise ValueError(f"residual scale must be in (0, 2], got {scale!r}")
    return value


def combine(base: NDArray[Any], residual: NDArray[Any], scale: float) -> NDArray[np.float32]:
    """The executed action: the base action plus ``scale`` x the residual (clipped to [-1, 1])."""
    correction = scale * np.clip(np.asarray(residual, dtype=np.float32), -1.0, 1.0)
    summed = np.asarray(base, dtype=np.float32) + correction
    return np.clip(summed, -1.0, 1.0).astype(np.float32)


class ResidualOnLaser(gym.ActionWrapper[Any, Any, Any], RecordConstructorArgs):
    """The agent's action is a correction to the gap follower's (see the module docstring).

    Wrap the env before any observation wrapper: the gap follower reads this env's observation.
    """

    def __init__(self, env: gym.Env[Any, Any], scale: float = 0.5) -> None:
        RecordConstructorArgs.__init__(self, scale=scale)
        gym.ActionWrapper.__init__(self, env)
        self.scale = check_scale(scale)
        self.base = builtin_policy("laser", env)
        self._observation: Any = None

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        """Reset the env and remember the observation the gap follower acts on next."""
        self._observation, info = self.env.reset(**kwargs)
        return self._observation, info

    def step(self, action: Any) -> tuple[Any, Any, bool, bool, dict[str, Any]]:
        """Step with the corrected action; remember the new observation."""
        observation, reward, terminated, truncated, info = self.env.step(self.action(action))
        self._observation = observation
        return observation, reward, terminated, truncated, info

    def action(self, action: Any) -> NDArray[np.float32]:
        """The gap follower's action for the last observation, corrected by ``action``."""
        if self._observation is None:
            raise RuntimeError("step() before reset(): reset the env first")
        base, _ = self.base.predict(self._observation)
        return combine(base, action, self.scale)


class ResidualPolicy:
    """A trained residual on the gap follower, as a policy: ``base + scale * learnt``, clipped.

    ``learnt`` is the network (an SB3 model or an ONNX export, with its own observation pooling
    and normalisation); ``base`` the gap follower for the same env. One observation or a batch.
    """

    def __init__(self, learnt: Policy, base: Policy, scale: float) -> None:
        self.learnt = learnt
        self.base = base
        self.scale = check_scale(scale)

    def predict(
        self,
        observation: Observation,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[NDArray[np.float32], None]:
        """The corrected action(s); the policy is stateless."""
        residual, _ = self.learnt.predict(observation, None, episode_start, deterministic)
        base, _ = self.base.predict(observation)
        return combine(base, residual, self.scale), None

    def reset(self) -> None:
        """Nothing to forget: both parts are stateless."""
        self.learnt.reset()
        self.base.reset()


def on_gap_follower(
    learnt: Policy, env: gym.Env[Any, Any] | None, space: gym.spaces.Dict | None, scale: float
) -> ResidualPolicy:
    """``learnt``, a residual trained on the gap follower, with the gap follower for ``env``.

    Takes ``Dict`` observations (``space``: the env's, None: unchecked).
    """
    return ResidualPolicy(learnt, controller("laser", bubblerob_base(env), space, 0), scale)
