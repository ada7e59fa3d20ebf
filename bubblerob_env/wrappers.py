"""``EpisodeSuccess``: ``info["is_success"]`` on the last step of an episode, after a time limit.

The env itself now sets ``info["is_success"]`` on every step ("no collision so far"), which on an
episode's last step is its success: ``gym.make_vec``'s vector entry point refuses a spec with
``additional_wrappers``, so ``BubbleRob-v0`` no longer registers this wrapper. It is kept for code
that applies it to other envs or wants the flag on the last step only: after ``TimeLimit`` it sets
the same value there. SB3's ``Monitor`` and ``EvalCallback``, our evaluation, training, demo and
benches all read ``info["is_success"]`` on an episode's last step.
"""

from __future__ import annotations

from typing import Any, SupportsFloat

import gymnasium as gym
from gymnasium.utils import RecordConstructorArgs

__all__ = ["EpisodeSuccess"]


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
