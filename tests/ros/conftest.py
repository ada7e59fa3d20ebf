"""Fixtures for the ROS layer tests."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import pytest
from ros_helpers import drive

from bubblerob_env.ros import RosBagRecorder


@pytest.fixture
def record(tmp_path: Path) -> Callable[..., Path]:
    """Record ``episodes`` short episodes of ``BubbleRob-v0`` (kwargs: env and recorder)."""

    def make(
        fmt: str = "mcap",
        compression: str | None = None,
        episodes: int = 2,
        steps: int = 15,
        env_kwargs: dict[str, Any] | None = None,
        name: str = "bag",
        **recorder_kwargs: Any,
    ) -> Path:
        env = gym.make("BubbleRob-v0", **(env_kwargs or {}))
        with RosBagRecorder(
            env, tmp_path / name, format=fmt, compression=compression, **recorder_kwargs
        ) as recorder:
            drive(recorder, episodes, steps)
        return recorder.bag_paths[0]

    return make
