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

import time
from collections.abc import Iterable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env.base_vec_env import (
    VecEnv,
    VecEnvIndices,
    VecEnvObs,
    VecEnvStepReturn,
)

from bubblerob_env.mjwarp import WarpVectorEnv

__all__ = ["WarpSB3VecEnv"]

_BATCH_ONLY = ("final_obs", "final_info")


class WarpSB3VecEnv(VecEnv):
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
        self._actions: np.ndarray | None = None
        self._returns = np.zeros(num_envs)
        self._lengths = np.zeros(num_envs, dtype=np.int64)
        self._start = time.time()

    def reset(self) -> VecEnvObs:
        """Reset every robot with the seeds given to :meth:`seed` (then unseeded)."""
        seeds = list(self._seeds)
        obs: VecEnvObs
        obs, info = self.venv.reset(seed=None if all(s is None for s in seeds) else seeds)
        self._returns[:] = 0.0
        self._lengths[:] = 0
        self.reset_infos = [_robot(info, i) for i in range(self.num_envs)]
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        """Store the actions for :meth:`step_wait`."""
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        """Step every robot; ended episodes restart at once, as SB3 expects."""
        assert self._actions is not None, "step_async first"
        obs, rewards, terminated, truncated, info = self.venv.step(
            np.asarray(self._actions, dtype=np.float32)
        )
        self._returns += rewards
        self._lengths += 1
        done = terminated | truncated
        infos = []
        for i in range(self.num_envs):
            if not done[i]:
                infos.append({**_robot(info, i), "TimeLimit.truncated": False})  # as DummyVecEnv
                continue
            infos.append(
                {
                    **_robot(info["final_info"], i),
                    # As SB3's Monitor writes it.
                    "episode": {
                        "r": round(float(self._returns[i]), 6),
                        "l": int(self._lengths[i]),
                        "t": round(time.time() - self._start, 6),
                    },
                    "terminal_observation": info["final_obs"][i],
                    "TimeLimit.truncated": bool(truncated[i] and not terminated[i]),
                }
            )
            self._returns[i], self._lengths[i] = 0.0, 0
            self.reset_infos[i] = {}
        return obs, rewards.astype(np.float32), done, infos

    def close(self) -> None:
        """Free the device arrays."""
        self.venv.close()

    def get_images(self) -> Sequence[np.ndarray | None]:
        """No frames: the warp backend renders nothing (render with ``--vec-env batched``)."""
        return [None] * self.num_envs

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """The attribute of the CPU env that describes every world (one per index)."""
        return [self.venv.get_attr(attr_name)[0] for _ in _indices(indices, self.num_envs)]

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
        return [method(*method_args, **kwargs) for _ in _indices(indices, self.num_envs)]

    def env_is_wrapped(
        self, wrapper_class: type[gym.Wrapper[Any, Any, Any, Any]], indices: VecEnvIndices = None
    ) -> list[bool]:
        """Only as by ``Monitor``: the adapter reports ``info["episode"]`` as Monitor does."""
        return [wrapper_class is Monitor for _ in _indices(indices, self.num_envs)]


def _indices(indices: VecEnvIndices, n: int) -> Iterable[int]:
    if indices is None:
        return range(n)
    return [indices] if isinstance(indices, int) else indices


def _robot(info: dict[str, Any], i: int) -> dict[str, Any]:
    """Robot ``i``'s own ``info`` dict from Gymnasium's dict of arrays."""
    return {
        key: value[i]
        for key, value in info.items()
        if not key.startswith("_") and key not in _BATCH_ONLY and info[f"_{key}"][i]
    }
