"""Stable-Baselines3 ``VecEnv`` over ``backend="warp"``: ``WarpSB3VecEnv(num_envs, **kwargs)``.

The MuJoCo Warp backend (:class:`~bubblerob_env.mjwarp.WarpVectorEnv`, numpy outputs) with the
conventions of :class:`train.sb3_vec.BubbleRobSB3VecEnv` (``--vec-env batched``): robot ``i``
seeded ``s + i`` (``venv.seed(s)``), world ``i`` gets the CPU env's arena for that seed; the
same time limit (1000 steps unless ``max_episode_steps``); on an episode's last step
``info["terminal_observation"]``, ``info["TimeLimit.truncated"]``, the env's
``info["is_success"]`` and ``info["episode"]`` as SB3's ``Monitor`` writes it; the returned
observation is already the next episode's first. Autoresets take arenas from the backend's bank
(``layout_bank`` of them, drawn by the seeded generator), as ``gym.make_vec(...,
backend="warp")`` does. Used by ``python -m train --vec-env warp``; needs ``mujoco-warp`` (the
``warp`` extra) and ``stable-baselines3`` (the ``train`` extra).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env.base_vec_env import VecEnvIndices, VecEnvObs

from bubblerob_env.mjwarp import WarpVectorEnv
from train.sb3_vec import BatchStep, FinalStep, SameStepSB3VecEnv

__all__ = ["WarpSB3VecEnv"]

_BATCH_ONLY = ("final_obs", "final_info")


class WarpSB3VecEnv(SameStepSB3VecEnv):
    """``num_envs`` BubbleRobs for SB3, stepped as MuJoCo Warp worlds on ``device``.

    Args:
        num_envs: Number of robots (worlds).
        device: Warp device (``"cuda:0"``, ``"cpu"``); default Warp's (a GPU where there is one).
        max_episode_steps: Time limit in steps, as ``gym.make``'s (default 1000).
        layout_bank: Arenas the autoresets draw from (see ``WarpVectorEnv``).
        **kwargs: The arguments of ``BubbleRobEnv`` that the warp backend takes.
    """

    def __init__(
        self,
        num_envs: int,
        *,
        device: str | None = None,
        max_episode_steps: int | None = 1000,
        layout_bank: int = 1024,
        **kwargs: Any,
    ) -> None:
        self.venv = WarpVectorEnv(
            num_envs,
            device=device,
            max_episode_steps=max_episode_steps,
            autoreset_mode=AutoresetMode.SAME_STEP,
            layout_bank=layout_bank,
            **kwargs,
        )
        super().__init__(
            num_envs, self.venv.single_observation_space, self.venv.single_action_space
        )
        self.render_mode = None
        self.metadata = self.venv.metadata

    def reset_batch(
        self, seeds: list[int | None], options: list[dict[str, Any]]
    ) -> tuple[VecEnvObs, list[dict[str, Any]]]:
        """Reset every robot with ``seeds`` (unseeded where all are None); no options."""
        obs: VecEnvObs
        obs, info = self.venv.reset(seed=None if all(s is None for s in seeds) else seeds)
        return obs, [_robot(info, i) for i in range(self.num_envs)]

    def step_batch(self, actions: np.ndarray) -> BatchStep:
        """Step every world; an ended world already holds its next episode."""
        obs, rewards, terminated, truncated, info = self.venv.step(actions)
        done = terminated | truncated
        finals: list[FinalStep | None] = [
            (info["final_obs"][i], _robot(info["final_info"], i)) if done[i] else None
            for i in range(self.num_envs)
        ]
        infos = [{} if done[i] else _robot(info, i) for i in range(self.num_envs)]
        return obs, rewards, terminated, truncated, infos, finals

    def close(self) -> None:
        """Free the device arrays."""
        self.venv.close()

    def get_images(self) -> Sequence[np.ndarray | None]:
        """No frames: the warp backend renders nothing (render with ``--vec-env batched``)."""
        return [None] * self.num_envs

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """The attribute of the CPU env that describes every world (one per index)."""
        return [self.venv.get_attr(attr_name)[0] for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Not available: the worlds share one model and its settings."""
        raise AttributeError(
            f"cannot set {attr_name!r} on MuJoCo Warp worlds: they share one model; make the "
            "vec env with the value instead"
        )

    def env_method(
        self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **kwargs: Any
    ) -> list[Any]:
        """The CPU env's method, called once for every index (the worlds have no env objects)."""
        method = self.venv.get_attr(method_name)[0]
        return [method(*method_args, **kwargs) for _ in self._get_indices(indices)]


def _robot(info: dict[str, Any], i: int) -> dict[str, Any]:
    """Robot ``i``'s own ``info`` dict from Gymnasium's dict of arrays."""
    return {
        key: value[i]
        for key, value in info.items()
        if not key.startswith("_") and key not in _BATCH_ONLY and info[f"_{key}"][i]
    }
