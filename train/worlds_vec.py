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

from collections.abc import Sequence
from typing import Any

import numpy as np
from stable_baselines3.common.vec_env.base_vec_env import VecEnvIndices, VecEnvObs

from bubblerob_env.multi.vector import WorldsVectorEnv
from train.sb3_vec import BatchStep, FinalStep, SameStepSB3VecEnv

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


class WorldsSB3VecEnv(SameStepSB3VecEnv):
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

    def reset_batch(
        self, seeds: list[int | None], options: list[dict[str, Any]]
    ) -> tuple[VecEnvObs, list[dict[str, Any]]]:
        """Reset every world; world ``w`` seeded ``s + w`` after :meth:`seed` ``(s)``."""
        obs, info = self.venv.reset(seed=seeds[0] if seeds else None)
        return obs, split_infos(info, self.num_envs)

    def step_batch(self, actions: np.ndarray) -> BatchStep:
        """Step every world; an ended slot's robot already replaced by a new one."""
        obs, rewards, terminated, truncated, info = self.venv.step(
            actions.reshape(self.num_envs, 2)
        )
        ended = np.flatnonzero(terminated | truncated).tolist()
        finals: list[FinalStep | None] = [None] * self.num_envs
        if ended:
            final_infos = split_infos(info["final_info"], self.num_envs)
            for i in ended:
                finals[i] = (info["final_obs"][i], final_infos[i])
        return obs, rewards, terminated, truncated, split_infos(info, self.num_envs), finals

    def close(self) -> None:
        """Stop the worlds' threads."""
        self.venv.close()

    def get_images(self) -> Sequence[np.ndarray | None]:
        """No rendering: the worlds have no camera (``parallel_env`` renders)."""
        return [None] * self.num_envs

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """The worlds' attribute (one object steps every slot), once per slot asked."""
        return [getattr(self.venv, attr_name) for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Set an attribute of the worlds (shared by every slot)."""
        setattr(self.venv, attr_name, value)

    def env_method(
        self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **kwargs: Any
    ) -> list[Any]:
        """Call a method of the worlds once; its result for each slot asked."""
        result = getattr(self.venv, method_name)(*method_args, **kwargs)
        return [result for _ in self._get_indices(indices)]
