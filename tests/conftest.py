"""Shared fixtures. Importing bubblerob_env first selects headless EGL rendering when no display."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import pytest

import bubblerob_env  # noqa: F401  (registers BubbleRob-v0, picks MUJOCO_GL before mujoco renders)
from bubblerob_env.arena import ASSETS_DIR

WALL_TEST_SCENE = ASSETS_DIR / "scenes" / "wall_test.xml"


@pytest.fixture
def wall_env_factory():
    """Make envs in the fixed wall scene: robot at the origin facing +x, no random obstacles."""
    made = []

    def make(**kwargs):
        kwargs.setdefault("start_pose", (0.0, 0.0, 0.0))
        env = gym.make(
            "BubbleRob-v0", xml_file=str(WALL_TEST_SCENE), num_obstacles=(0, 0), **kwargs
        )
        made.append(env)
        return env

    yield make
    for env in made:
        env.close()


@pytest.fixture
def scene_path() -> Path:
    return WALL_TEST_SCENE
