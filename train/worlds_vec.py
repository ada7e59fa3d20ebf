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
``python -m train --vec-env worlds --robots N`` (``n_envs`` worlds). :meth:`WorldsSB3VecEnv.mixed`
puts groups of worlds of different sizes and scenarios side by side, their slots one after the
other (``--vec-env crowd``). Needs the ``train`` and ``multi`` extras.
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


def _joined(parts: list[Any]) -> Any:
    """The groups' batched observations as one batch."""
    if len(parts) == 1:
        return parts[0]
    if isinstance(parts[0], dict):
        return {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
    return np.concatenate(parts)


def _finals(info: dict[str, Any], done: np.ndarray, count: int) -> list[FinalStep | None]:
    """Each slot's last observation and ``info`` where its episode ended, else None."""
    finals: list[FinalStep | None] = [None] * count
    ended = np.flatnonzero(done).tolist()
    if ended:
        final_infos = split_infos(info["final_info"], count)
        for i in ended:
            finals[i] = (info["final_obs"][i], final_infos[i])
    return finals


class WorldsSB3VecEnv(SameStepSB3VecEnv):
    """``num_worlds`` worlds of ``num_robots`` robots as ``num_worlds * num_robots`` SB3 slots.

    Args:
        num_worlds: Worlds.
        num_robots: Robots in each world.
        groups: Groups of worlds made already (:meth:`mixed`), instead of the above.
        **kwargs: :class:`~bubblerob_env.multi.vector.WorldsVectorEnv`'s (``robot``,
            ``scenario``, ``task``, ``num_threads``, ``max_episode_steps``, the single env's
            arguments).
    """

    def __init__(
        self,
        num_worlds: int,
        num_robots: int,
        *,
        groups: Sequence[WorldsVectorEnv] = (),
        **kwargs: Any,
    ) -> None:
        venvs = list(groups) or [WorldsVectorEnv(num_worlds, num_robots, **kwargs)]
        self.venvs = venvs
        self.venv = venvs[0]
        """The (first) group of worlds: its attributes are the adapter's."""
        self.render_mode = None
        # Groups of another arena differ only in the goal distance's bound: the first's space.
        super().__init__(
            sum(v.num_envs for v in venvs),
            self.venv.single_observation_space,
            self.venv.single_action_space,
        )
        self.num_worlds = sum(v.num_worlds for v in venvs)
        self.num_robots = num_robots

    @classmethod
    def mixed(cls, groups: Sequence[tuple[int, int, dict[str, Any]]], **kwargs: Any) -> Any:
        """Groups of ``(num_worlds, num_robots, their own kwargs)`` worlds, slots in that order.

        ``kwargs``: every group's. A policy shared by all robots learns from all of them.
        """
        venvs = [WorldsVectorEnv(m, n, **{**kwargs, **own}) for m, n, own in groups]
        return cls(0, 0, groups=venvs)

    def reset_batch(
        self, seeds: list[int | None], options: list[dict[str, Any]]
    ) -> tuple[VecEnvObs, list[dict[str, Any]]]:
        """Reset every world; world ``w`` (counted over the groups) seeded ``s + w``."""
        first = seeds[0] if seeds else None
        parts, infos, offset = [], [], 0
        for venv in self.venvs:
            obs, info = venv.reset(seed=None if first is None else first + offset)
            offset += venv.num_worlds
            parts.append(obs)
            infos += split_infos(info, venv.num_envs)
        return _joined(parts), infos

    def step_batch(self, actions: np.ndarray) -> BatchStep:
        """Step every world; an ended slot's robot already replaced by a new one."""
        actions = actions.reshape(self.num_envs, 2)
        parts, infos, finals, start = [], [], [], 0
        rewards, terminated, truncated = [], [], []
        for venv in self.venvs:
            obs, reward, ends, cuts, info = venv.step(actions[start : start + venv.num_envs])
            start += venv.num_envs
            parts.append(obs)
            rewards.append(reward)
            terminated.append(ends)
            truncated.append(cuts)
            infos += split_infos(info, venv.num_envs)
            finals += _finals(info, ends | cuts, venv.num_envs)
        return (
            _joined(parts),
            np.concatenate(rewards),
            np.concatenate(terminated),
            np.concatenate(truncated),
            infos,
            finals,
        )

    def close(self) -> None:
        """Stop the worlds' threads."""
        for venv in self.venvs:
            venv.close()

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
