"""``--vec-env batched`` with a residual policy: the gap follower's actions for the whole batch.

:class:`~policies.residual.ResidualOnLaser` is a per-env action wrapper; the native batch takes
observation wrappers only (``VecObservationWrapper``). :class:`VecResidualOnLaser` does the same
on the batch, below those: it keeps the batch's raw observations and adds ``scale`` x the agent's
actions to the gap follower's, clipped, as each env's wrapper would.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper
from stable_baselines3.common.vec_env.base_vec_env import VecEnvObs, VecEnvStepReturn

from policies.base import Policy
from policies.residual import combine

__all__ = ["VecResidualOnLaser"]


class VecResidualOnLaser(VecEnvWrapper):
    """The batch's actions are corrections to ``base``'s (the gap follower for its env)."""

    def __init__(self, venv: VecEnv, base: Policy, scale: float) -> None:
        super().__init__(venv)
        self.base = base
        self.scale = scale
        self._observations: Any = None

    def reset(self) -> VecEnvObs:
        """Reset every env; keep the observations the gap follower acts on next."""
        observations: VecEnvObs = self.venv.reset()
        self._observations = observations
        return observations

    def step_async(self, actions: np.ndarray) -> None:
        """Send the corrected actions."""
        base, _ = self.base.predict(self._observations)
        self.venv.step_async(combine(base, actions, self.scale))

    def step_wait(self) -> VecEnvStepReturn:
        """Step every env (an env that ended is already reset: its new first observation)."""
        observations, rewards, dones, infos = self.venv.step_wait()
        self._observations = observations
        return observations, rewards, dones, infos
