"""``EpisodeSuccess``: the one definition of a successful episode, as ``info["is_success"]``.

Success means the episode reached its time limit without a collision. Only the time limit knows
when that happens, and Gymnasium's ``TimeLimit`` wraps the env from outside, so the flag is set by
this wrapper, which ``gym.make("BubbleRob-v0")`` applies right after ``TimeLimit`` (the env's
registration lists it in ``additional_wrappers``). SB3's ``Monitor`` and ``EvalCallback``, our
evaluation, training, demo and benches all read ``info["is_success"]`` on an episode's last step.
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
