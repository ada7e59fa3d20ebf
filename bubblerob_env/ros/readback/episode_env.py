"""The env an episode's metadata names, made again: for replay, ``detect`` and ``map``."""

from __future__ import annotations

from typing import Any

import gymnasium as gym

import bubblerob_env  # noqa: F401  (registers the env ids)

__all__ = ["make_episode_env"]


def make_episode_env(
    meta: dict[str, Any],
    error: type[Exception],
    env_id: str | None = None,
    env_kwargs: dict[str, Any] | None = None,
) -> gym.Env[Any, Any]:
    """``gym.make`` of the episode's env id and kwargs, its time limit, no rendering.

    ``env_id`` and ``env_kwargs`` replace the metadata's where given (a bag of an env that is
    registered under another name here). An env that cannot be made raises ``error`` with one
    line naming the episode and the env.
    """
    name = env_id or meta.get("env_id")
    kwargs = dict((meta.get("env_kwargs") if env_kwargs is None else env_kwargs) or {})
    kwargs["render_mode"] = None
    try:
        if not name:
            raise ValueError("the metadata has no env id: record with an env made by gym.make")
        return gym.make(name, max_episode_steps=meta.get("max_episode_steps"), **kwargs)
    except (gym.error.Error, TypeError, ValueError) as problem:
        source = "the bag's metadata" if env_id is None and env_kwargs is None else "the options"
        raise error(
            f"episode {meta.get('episode')}'s env {name!r} cannot be made again from {source}: "
            f"{problem}"
        ) from None
