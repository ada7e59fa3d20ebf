"""Wrappers: ``EpisodeSuccess``, ``LaserPooling`` and ``TopDownView``.

``LaserPooling`` min-pools the laser scan into sectors (360 rays -> 36 by default): the nearest
reading in each group of ``pool`` consecutive rays, so that a small obstacle between the rays of
a coarse scan is still seen. Training applies it through rl-zoo's ``env_wrapper`` key, and the
trained policies apply the same pooling to the env's full scan (:func:`min_pool`).

``TopDownView`` makes ``render()`` return the view from above drawn with NumPy
(:class:`~bubblerob_env.topdown.TopDownRenderer`, about a millisecond a 360x360 frame against some
50 ms for MuJoCo's renderer on a CPU); ``bubblerob demo`` and ``evaluate --video`` record it.

``EpisodeSuccess``: ``info["is_success"]`` on the last step of an episode, after a time limit.

The env itself now sets ``info["is_success"]`` on every step ("no collision so far"), which on an
episode's last step is its success: ``gym.make_vec``'s vector entry point refuses a spec with
``additional_wrappers``, so ``BubbleRob-v0`` no longer registers this wrapper. It is kept for code
that applies it to other envs or wants the flag on the last step only: after ``TimeLimit`` it sets
the same value there. SB3's ``Monitor`` and ``EvalCallback``, our evaluation, training, demo and
benches all read ``info["is_success"]`` on an episode's last step.
"""

from __future__ import annotations

import math
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.utils import RecordConstructorArgs
from numpy.typing import NDArray

__all__ = [
    "ActionNoise",
    "EpisodeSuccess",
    "LaserPooling",
    "TopDownView",
    "min_pool",
]


def min_pool(scan: NDArray[Any], pool: int) -> NDArray[Any]:
    """The minimum over each group of ``pool`` consecutive rays of the last axis of ``scan``.

    Ray ``i`` goes to sector ``i // pool``; the number of rays must be a multiple of ``pool``.
    Works on one scan ``(rays,)`` or a batch ``(..., rays)`` and keeps the dtype.
    """
    rays = scan.shape[-1]
    if pool < 1 or rays % pool:
        raise ValueError(f"pool must be a positive divisor of the {rays} rays, got {pool}")
    pooled: NDArray[Any] = scan.reshape(*scan.shape[:-1], rays // pool, pool).min(axis=-1)
    return pooled


class ActionNoise(gym.ActionWrapper[Any, Any, Any], RecordConstructorArgs):
    """Adds Gaussian noise of standard deviation ``std`` to each action, then clips to [-1, 1].

    A training lever (``env_wrapper``): a policy that must stay clear of obstacles while its
    actions are perturbed learns a margin. The noise comes from the env's own generator, so a
    seeded episode stays reproducible. Trained policies do not replay it.
    """

    def __init__(self, env: gym.Env[Any, Any], std: float = 0.1) -> None:
        RecordConstructorArgs.__init__(self, std=std)
        gym.ActionWrapper.__init__(self, env)
        if not (isinstance(std, (int, float)) and std >= 0.0 and math.isfinite(std)):
            raise ValueError(f"ActionNoise std must be a finite number >= 0, got {std!r}")
        self.std = float(std)

    def action(self, action: Any) -> NDArray[np.float32]:
        """The action with noise, clipped to the action space's [-1, 1]."""
        generator: np.random.Generator = self.env.unwrapped.np_random
        noisy = np.asarray(action, dtype=np.float64) + generator.normal(
            0.0, self.std, size=np.shape(action)
        )
        clipped: NDArray[np.float32] = np.clip(noisy, -1.0, 1.0).astype(np.float32)
        return clipped


class LaserPooling(gym.ObservationWrapper[Any, Any, Any], RecordConstructorArgs):
    """Replaces the dict observation's ``key`` scan by its min over groups of ``pool`` rays.

    With the default env (360 rays) and ``pool=10`` the policy sees 36 sectors of 10 degrees,
    each the nearest reading in it. The observation space's ``key`` Box is updated (same bounds,
    ``rays // pool`` entries); the other entries pass through unchanged. Rewards and ``info``
    are the env's, computed from the full scan.
    """

    def __init__(self, env: gym.Env[Any, Any], pool: int = 10, key: str = "laser") -> None:
        RecordConstructorArgs.__init__(self, pool=pool, key=key)
        gym.ObservationWrapper.__init__(self, env)
        space = env.observation_space
        if not isinstance(space, spaces.Dict) or key not in space.spaces:
            raise ValueError(f"LaserPooling needs a Dict observation space with {key!r}")
        scan = space.spaces[key]
        if not isinstance(scan, spaces.Box) or len(scan.shape) != 1:
            raise ValueError(f"observation {key!r} must be a 1-D Box, got {scan}")
        rays = scan.shape[0]
        if pool < 1 or rays % pool:
            raise ValueError(f"pool must be a positive divisor of the {rays} rays, got {pool}")
        self.pool = pool
        self.key = key
        pooled = spaces.Box(
            min_pool(np.asarray(scan.low), pool),
            min_pool(np.asarray(scan.high), pool),
            (rays // pool,),
            scan.dtype,
        )
        self.observation_space = spaces.Dict({**space.spaces, key: pooled})

    def observation(self, observation: Any) -> Any:
        """The observation with its scan min-pooled."""
        return {**observation, self.key: min_pool(observation[self.key], self.pool)}


class EpisodeSuccess(gym.Wrapper[Any, Any, Any, Any], RecordConstructorArgs):
    """Sets ``info["is_success"]`` on the last step of every episode, and only there.

    ``True`` when the episode was truncated by the time limit and no step of it had a collision,
    also with ``terminate_on_collision=False``; ``False`` when it ended any other way, including
    the env's own truncation when MuJoCo diverged (``info["physics_diverged"]``).
    """

    def __init__(self, env: gym.Env[Any, Any]) -> None:
        RecordConstructorArgs.__init__(self)
        gym.Wrapper.__init__(self, env)
        self._collided = False

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Reset the env and forget the last episode's collisions."""
        self._collided = False
        return self.env.reset(seed=seed, options=options)

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        """Step the env; on the episode's last step, say whether it succeeded."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._collided = self._collided or bool(info.get("collision", False))
        if terminated or truncated:
            by_time_limit = truncated and not terminated and "physics_diverged" not in info
            info["is_success"] = bool(by_time_limit and not self._collided)
        return obs, reward, terminated, truncated, info


class TopDownView(gym.Wrapper[Any, Any, Any, Any], RecordConstructorArgs):
    """``render()`` returns the arena from above, drawn with NumPy: no OpenGL context, ~1 ms.

    Whatever the env's own ``render_mode``, this wrapper's is ``"rgb_array"``, so Gymnasium's
    ``RecordVideo`` and our video writers take its frames. The laser drawn is the scan of the last
    observation (its ``"laser"`` entry, or its slice with ``obs_mode="flat"``): wrap the env before
    anything that changes the scan, such as :class:`LaserPooling`; without a laser or a scan of
    every ray, no rays are drawn.

    Args:
        env: A BubbleRob env or a wrapper of one.
        width: Frame width in pixels.
        height: Frame height in pixels.
    """

    def __init__(self, env: gym.Env[Any, Any], width: int = 360, height: int = 360) -> None:
        from bubblerob_env.topdown import TopDownRenderer  # numpy only, but not needed elsewhere

        RecordConstructorArgs.__init__(self, width=width, height=height)
        gym.Wrapper.__init__(self, env)
        self._renderer = TopDownRenderer.for_env(env, width, height)
        spec = self._renderer.laser_spec
        self._rays = 0 if spec is None else spec.num_rays
        self._scan: NDArray[Any] | None = None
        layout = getattr(env.unwrapped, "observation_layout", None) or {}
        flat = env.observation_space == env.unwrapped.observation_space
        self._flat_laser: slice | None = layout.get("laser") if flat else None
        self.metadata = {**env.metadata, "render_modes": ["rgb_array"]}

    @property
    def render_mode(self) -> str:  # type: ignore[override]
        """Always ``"rgb_array"``."""
        return "rgb_array"

    def _keep_scan(self, observation: Any) -> None:
        if isinstance(observation, dict):
            scan = observation.get("laser")
        else:  # obs_mode="flat": the env names the laser's slice
            part = self._flat_laser
            scan = None if part is None else np.asarray(observation)[part]
        fits = scan is not None and np.shape(scan) == (self._rays,)
        self._scan = np.array(scan) if fits else None

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Reset the env and keep the first scan for ``render()``."""
        observation, info = self.env.reset(seed=seed, options=options)
        self._keep_scan(observation)
        return observation, info

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        """Step the env and keep the scan for ``render()``."""
        observation, reward, terminated, truncated, info = self.env.step(action)
        self._keep_scan(observation)
        return observation, reward, terminated, truncated, info

    def render(self) -> NDArray[np.uint8]:
        """The current frame, ``(height, width, 3)`` ``uint8``."""
        return self._renderer.render(self._scan)
