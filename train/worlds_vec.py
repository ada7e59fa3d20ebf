"""Stable-Baselines3 ``VecEnv`` over worlds of several robots: one slot per robot.

``WorldsSB3VecEnv(num_worlds, num_robots, **kwargs)`` steps
:class:`~bubblerob_env.multi.vector.WorldsVectorEnv` (``M`` worlds of ``N`` robots, one numba
call) for a policy shared by every robot (Long et al., ICRA 2018). Slot ``w * N + k`` is robot
``k`` of world ``w``. A slot whose robot touched something, reached its time limit or whose world
diverged ends its episode there: its ``info`` carries SB3's ``terminal_observation``,
``TimeLimit.truncated``, the env's ``is_success`` and ``collided_with``, and ``episode`` as SB3's
``Monitor`` writes it; the observation returned in its row is already the next episode's first,
a new robot at a free pose of the same world, while the world's other robots drive on. So each
slot is a sequence of independent robot-episodes, as SB3 expects of a ``VecEnv`` slot.

``seed(s)`` seeds world ``w`` with ``s + w`` at the next ``reset``. Used by
``python -m train --vec-env worlds --robots N`` (``n_envs`` worlds). Needs the ``train`` and
``multi`` extras.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env.base_vec_env import (
    VecEnv,
    VecEnvIndices,
    VecEnvObs,
    VecEnvStepReturn,
)

from bubblerob_env.multi.vector import WorldsVectorEnv

__all__ = ["WorldsSB3VecEnv", "split_infos"]

_FINALS = ("final_obs", "final_info")


def split_infos(info: dict[str, Any], count: int) -> list[dict[str, Any]]:
    """Gymnasium's dict of arrays (``_key`` masks) as one ``info`` dict per slot."""
    infos: list[dict[str, Any]] = [{} for _ in range(count)]
    for key, values in info.items():
        if key.startswith("_") or key in _FINALS:
            continue
        present = info.get(f"_{key}", np.ones(count, dtype=bool))
        for i in np.flatnonzero(present).tolist():
            value = values[i]
            infos[i][key] = value.item() if isinstance(value, np.generic) else value
    return infos


class WorldsSB3VecEnv(VecEnv):
    """``num_worlds`` worlds of ``num_robots`` robots as ``num_worlds * num_robots`` SB3 slots.

    Args:
        num_worlds: Worlds.
        num_robots: Robots in each world.
        **kwargs: :class:`~bubblerob_env.multi.vector.WorldsVectorEnv`'s (``robot``,
            ``scenario``, ``num_threads``, ``max_episode_steps``, the single env's arguments).
    """

    def __init__(self, num_worlds: int, num_robots: int, **kwargs: Any) -> None:
        self.venv = WorldsVectorEnv(num_worlds, num_robots, **kwargs)
        self.render_mode = None
        super().__init__(
            self.venv.num_envs, self.venv.single_observation_space, self.venv.single_action_space
        )
        self.num_worlds, self.num_robots = num_worlds, num_robots
        self._actions: np.ndarray | None = None
        self._returns = np.zeros(self.num_envs)
        self._lengths = np.zeros(self.num_envs, dtype=np.int64)
        self._start = time.time()

    def reset(self) -> VecEnvObs:
        """Reset every world; world ``w`` seeded ``s + w`` after :meth:`seed` ``(s)``."""
        first = self._seeds[0] if self._seeds else None
        obs, info = self.venv.reset(seed=first)
        self._returns[:] = 0.0
        self._lengths[:] = 0
        self.reset_infos = split_infos(info, self.num_envs)
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        """Store the actions for :meth:`step_wait`."""
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        """Step every world; ended slots restart in the same step, as SB3 expects."""
        assert self._actions is not None, "step_async first"
        actions = np.asarray(self._actions, dtype=np.float32).reshape(self.num_envs, 2)
        obs, rewards, terminated, truncated, info = self.venv.step(actions)
        self._returns += rewards
        self._lengths += 1
        dones = terminated | truncated
        infos = split_infos(info, self.num_envs)
        ended = np.flatnonzero(dones).tolist()
        finals = split_infos(info["final_info"], self.num_envs) if ended else []
        for i in range(self.num_envs):
            infos[i]["TimeLimit.truncated"] = False  # as SB3's DummyVecEnv
        for i in ended:
            infos[i] = {
                **finals[i],
                "episode": {  # as SB3's Monitor writes it
                    "r": round(float(self._returns[i]), 6),
                    "l": int(self._lengths[i]),
                    "t": round(time.time() - self._start, 6),
                },
                "terminal_observation": info["final_obs"][i],
                "TimeLimit.truncated": bool(truncated[i] and not terminated[i]),
            }
            self._returns[i], self._lengths[i] = 0.0, 0
            self.reset_infos[i] = {}
        return obs, rewards.astype(np.float32), dones, infos

    def close(self) -> None:
        """Stop the worlds' threads."""
        self.venv.close()

    def get_images(self) -> Sequence[np.ndarray | None]:
        """No rendering: the worlds have no camera (``parallel_env`` renders)."""
        return [None] * self.num_envs

    def _slots(self, indices: VecEnvIndices) -> Iterable[int]:
        if indices is None:
            return range(self.num_envs)
        if isinstance(indices, int):
            return [indices]
        return indices

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """The worlds' attribute (one object steps every slot), once per slot asked."""
        return [getattr(self.venv, attr_name) for _ in self._slots(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Set an attribute of the worlds (shared by every slot)."""
        setattr(self.venv, attr_name, value)

    def env_method(
        self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **kwargs: Any
    ) -> list[Any]:
        """Call a method of the worlds once; its result for each slot asked."""
        result = getattr(self.venv, method_name)(*method_args, **kwargs)
        return [result for _ in self._slots(indices)]

    def env_is_wrapped(
        self, wrapper_class: type[gym.Wrapper[Any, Any, Any, Any]], indices: VecEnvIndices = None
    ) -> list[bool]:
        """Only as by ``Monitor``: ``info["episode"]`` is reported as Monitor does."""
        return [wrapper_class is Monitor for _ in self._slots(indices)]
