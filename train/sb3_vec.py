"""Stable-Baselines3 ``VecEnv`` over the native batch: ``BubbleRobSB3VecEnv(num_envs, **kwargs)``.

A drop-in for ``make_vec_env("BubbleRob-v0", n_envs=N, seed=s)``: robot ``i`` seeded ``s + i``
(``venv.seed(s)``), the same time limit (1000 steps unless ``max_episode_steps``), and SB3's
conventions on an episode's last step: ``info["terminal_observation"]``,
``info["TimeLimit.truncated"]`` and the env's ``info["is_success"]``; the returned observation is
already the next episode's first (SB3 resets in the same step); and, as SB3's ``Monitor`` adds,
``info["episode"]`` with the episode's return ``r``, length ``l`` and time ``t``, so that SB3's
logs and ``EvalCallback``'s normalisation sync work without another wrapper. Used by
``python -m train --vec-env batched``. Needs ``stable-baselines3`` (the ``train`` extra). Was
``bubblerob_env.sb3``: the env package imports no SB3.

:class:`SameStepSB3VecEnv` holds those conventions for every batch that autoresets in the same
step: this one, :class:`train.worlds_vec.WorldsSB3VecEnv` and
:class:`train.sb3_warp.WarpSB3VecEnv` say only how their batch resets and steps.
"""

from __future__ import annotations

import time
from abc import abstractmethod
from collections.abc import Sequence
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
    VecEnvWrapper,
)

from bubblerob_env.vector import BubbleRobVectorEnv

__all__ = [
    "BatchStep",
    "BubbleRobSB3VecEnv",
    "FinalStep",
    "SameStepSB3VecEnv",
    "VecObservationWrapper",
]

FinalStep = tuple[Any, dict[str, Any]]
"""An ended episode's last observation and ``info``, as the batch's ``SameStep`` autoreset
keeps them (its ``final_obs`` and ``final_info``)."""

BatchStep = tuple[
    VecEnvObs, np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]], Sequence[FinalStep | None]
]
"""A batch's step: observations (an ended slot's already its next episode's first), rewards,
terminated, truncated, each slot's ``info``, and each slot's :data:`FinalStep` (None where its
episode goes on)."""


class SameStepSB3VecEnv(VecEnv):
    """SB3's conventions over a batch that autoresets in the step an episode ends.

    What the adapters share: the seeds (slot ``i`` gets ``s + i`` after :meth:`seed` ``(s)``, as
    SB3 counts them; the batch decides what a slot's seed means) and, on an episode's last step,
    ``info["terminal_observation"]``, ``info["TimeLimit.truncated"]`` and ``info["episode"]``
    as SB3's ``Monitor`` writes it. A batch says how it resets (:meth:`reset_batch`) and steps
    (:meth:`step_batch`); the rest (attributes, methods, frames, closing) is its own.
    """

    def __init__(
        self,
        num_envs: int,
        observation_space: gym.spaces.Space[Any],
        action_space: gym.spaces.Space[Any],
    ) -> None:
        super().__init__(num_envs, observation_space, action_space)
        self._actions: np.ndarray | None = None
        self._returns = np.zeros(num_envs)
        self._lengths = np.zeros(num_envs, dtype=np.int64)
        self._start = time.time()

    @abstractmethod
    def reset_batch(
        self, seeds: list[int | None], options: list[dict[str, Any]]
    ) -> tuple[VecEnvObs, list[dict[str, Any]]]:
        """Reset the batch with SB3's per-slot seeds and options: observations, slot ``info``s."""

    @abstractmethod
    def step_batch(self, actions: np.ndarray) -> BatchStep:
        """Step the batch with ``actions`` (float32): a :data:`BatchStep`."""

    def reset(self) -> VecEnvObs:
        """Reset every slot with the seeds given to :meth:`seed` (then unseeded)."""
        obs, self.reset_infos = self.reset_batch(list(self._seeds), self._options)
        self._returns[:] = 0.0
        self._lengths[:] = 0
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        """Store the actions for :meth:`step_wait`."""
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        """Step every slot; ended episodes restart at once, as SB3 expects."""
        assert self._actions is not None, "step_async first"
        obs, rewards, terminated, truncated, infos, finals = self.step_batch(
            np.asarray(self._actions, dtype=np.float32)
        )
        self._returns += rewards
        self._lengths += 1
        for i, final in enumerate(finals):
            if final is None:
                infos[i]["TimeLimit.truncated"] = False  # as SB3's DummyVecEnv
                continue
            final_obs, final_info = final
            infos[i] = {
                **final_info,
                "episode": {  # as SB3's Monitor writes it
                    "r": round(float(self._returns[i]), 6),
                    "l": int(self._lengths[i]),
                    "t": round(time.time() - self._start, 6),
                },
                "terminal_observation": final_obs,
                "TimeLimit.truncated": bool(truncated[i] and not terminated[i]),
            }
            self._returns[i], self._lengths[i] = 0.0, 0
            self.reset_infos[i] = {}
        return obs, rewards.astype(np.float32), terminated | truncated, infos

    def env_is_wrapped(
        self, wrapper_class: type[gym.Wrapper[Any, Any, Any, Any]], indices: VecEnvIndices = None
    ) -> list[bool]:
        """Only as by ``Monitor``: the adapter reports ``info["episode"]`` as Monitor does.

        So SB3's ``evaluate_policy`` takes episode returns and lengths from it, as from a
        ``make_vec_env`` env, instead of warning that nothing reports them.
        """
        return [wrapper_class is Monitor for _ in self._get_indices(indices)]


class BubbleRobSB3VecEnv(SameStepSB3VecEnv):
    """``num_envs`` BubbleRobs for SB3, stepped by a ``BubbleRobVectorEnv``.

    Args:
        num_envs: Number of robots.
        num_threads: Threads stepping them (default: the usable cores).
        max_episode_steps: Time limit in steps, as ``gym.make``'s (default 1000).
        **kwargs: Every argument of ``BubbleRobEnv``.
    """

    def __init__(
        self,
        num_envs: int,
        *,
        num_threads: int | None = None,
        max_episode_steps: int | None = 1000,
        **kwargs: Any,
    ) -> None:
        self.venv = BubbleRobVectorEnv(
            num_envs,
            num_threads=num_threads,
            max_episode_steps=max_episode_steps,
            autoreset_mode=AutoresetMode.SAME_STEP,
            **kwargs,
        )
        first = self.venv.envs[0]
        self.render_mode = first.render_mode
        super().__init__(num_envs, first.observation_space, first.action_space)
        self.metadata = self.venv.metadata

    def reset_batch(
        self, seeds: list[int | None], options: list[dict[str, Any]]
    ) -> tuple[VecEnvObs, list[dict[str, Any]]]:
        """Robot ``i`` seeded ``seeds[i]``; the first slot's options (if any) for every robot."""
        first = options[0] if options and options[0] else None
        obs, info = self.venv.reset(seed=seeds, options=first)
        infos = [
            {k: info[k][i] for k in info if not k.startswith("_") and info[f"_{k}"][i]}
            for i in range(self.num_envs)
        ]
        return obs, infos

    def step_batch(self, actions: np.ndarray) -> BatchStep:
        """One step of every robot, with each robot's own ``info``."""
        obs, rewards, terminated, truncated, infos, finals = self.venv.step_robots(actions)
        ended = [None if final is None else (final[0], final[4]) for final in finals]
        return obs, rewards, terminated, truncated, infos, ended

    def close(self) -> None:
        """Close the robots and the threads."""
        self.venv.close()

    def get_images(self) -> Sequence[np.ndarray | None]:
        """Each robot's ``rgb_array`` frame."""
        frames = self.venv.render()
        return list(frames) if frames is not None else [None] * self.num_envs

    def _targets(self, indices: VecEnvIndices) -> list[gym.Env[Any, Any]]:
        return [self.venv.envs[i] for i in self._get_indices(indices)]

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """An attribute of each robot's env."""
        return [getattr(env, attr_name) for env in self._targets(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Set an attribute of each robot's env."""
        for env in self._targets(indices):
            setattr(env, attr_name, value)

    def env_method(
        self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **kwargs: Any
    ) -> list[Any]:
        """Call a method of each robot's env."""
        return [getattr(env, method_name)(*method_args, **kwargs) for env in self._targets(indices)]


class VecObservationWrapper(VecEnvWrapper):
    """Gymnasium observation wrappers applied to a ``VecEnv``'s whole batch at once.

    For wrappers whose ``observation()`` also takes a batch (``LaserPooling`` does: its min-pool
    works on the last axis), so that ``--vec-env batched`` trains on what ``make_vec_env(...,
    wrapper_class=...)`` gives per env. ``from_env_wrapper`` finds the wrappers and the wrapped
    observation space on one probe env; ``terminal_observation`` is wrapped as well.
    """

    def __init__(
        self,
        venv: VecEnv,
        wrappers: Sequence[gym.ObservationWrapper[Any, Any, Any]],
        observation_space: gym.spaces.Space[Any],
    ) -> None:
        super().__init__(venv, observation_space=observation_space)
        self.wrappers = list(wrappers)  # innermost first, the order the per-env chain applies

    @classmethod
    def from_env_wrapper(
        cls, venv: VecEnv, wrap: Any, probe: gym.Env[Any, Any]
    ) -> VecObservationWrapper:
        """``venv`` wrapped in what ``wrap(probe)`` adds; only observation wrappers allowed."""
        wrapped = wrap(probe)
        chain: list[gym.ObservationWrapper[Any, Any, Any]] = []
        env = wrapped
        while env is not probe:
            if not isinstance(env, gym.ObservationWrapper):
                raise ValueError(
                    f"--vec-env batched applies observation wrappers only, not {type(env).__name__}"
                )
            chain.append(env)
            env = env.env
        return cls(venv, chain[::-1], wrapped.observation_space)

    def _observation(self, observation: Any) -> VecEnvObs:
        for wrapper in self.wrappers:
            observation = wrapper.observation(observation)
        wrapped: VecEnvObs = observation
        return wrapped

    def reset(self) -> VecEnvObs:
        """Reset every env; the batch of first observations, wrapped."""
        return self._observation(self.venv.reset())

    def step_wait(self) -> VecEnvStepReturn:
        """Step every env; observations (and terminal observations) wrapped."""
        obs, rewards, dones, infos = self.venv.step_wait()
        for info in infos:
            if "terminal_observation" in info:
                info["terminal_observation"] = self._observation(info["terminal_observation"])
        return self._observation(obs), rewards, dones, infos
