"""Fixtures of the reliability tests (issue #38): short bags recorded as hostile users record."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import pytest

import bubblerob_env  # noqa: F401 - registers the env ids

START = 1_700_000_000.0


@pytest.fixture(scope="session")
def short_bag(tmp_path_factory: pytest.TempPathFactory) -> Callable[..., Path]:
    """A 12-step MCAP bag of one episode (seed 0, random actions seeded), cached by its args."""
    from bubblerob_env.ros import RosBagRecorder
    from bubblerob_env.ros.messages.topics import Topics

    made: dict[str, Path] = {}

    def record(env_id: str = "BubbleRob-v0", topics: Topics | None = None, **kwargs: Any) -> Path:
        key = repr((env_id, topics, sorted(kwargs.items())))
        if key not in made:
            path = tmp_path_factory.mktemp("bag") / "bag"
            env = RosBagRecorder(gym.make(env_id, **kwargs), path, topics=topics, start_time=START)
            env.reset(seed=0)
            env.action_space.seed(0)
            for _ in range(12):
                env.step(env.action_space.sample())
            env.close()
            made[key] = path
        return made[key]

    return record
