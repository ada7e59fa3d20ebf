"""Shared fixtures. Importing bubblerob_env first selects headless EGL rendering when no display."""

from __future__ import annotations

import signal
from pathlib import Path

import gymnasium as gym
import pytest

import bubblerob_env  # noqa: F401  (registers BubbleRob-v0, picks MUJOCO_GL before mujoco renders)
from bubblerob_env.arena import ASSETS_DIR

WALL_TEST_SCENE = ASSETS_DIR / "scenes" / "wall_test.xml"


def pytest_configure(config: pytest.Config) -> None:
    """Run as from a terminal however the suite was started.

    A background job of a non-interactive shell (``make test &``, ``nohup``, many CI runners)
    starts with SIGINT ignored, and an ignored signal stays ignored across ``exec``: every command
    a test starts would then ignore the Ctrl-C the test sends it. The commands themselves keep that
    convention (a background job is not for the terminal's Ctrl-C); the suite restores Python's
    default here, so that a caught signal is reset to the default action in each child it starts.
    """
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


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
