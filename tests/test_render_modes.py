"""Render modes an env lists: ``human`` only where a window can be opened (issue #22, item 2)."""

from __future__ import annotations

import os
import subprocess
import sys

from bubblerob_env.rendering import render_modes_here


def test_human_is_listed_only_with_a_display(monkeypatch) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    if sys.platform.startswith("linux"):
        assert render_modes_here(["human", "rgb_array"]) == ["rgb_array"]
    monkeypatch.setenv("DISPLAY", ":99")
    assert render_modes_here(["human", "rgb_array"]) == ["human", "rgb_array"]


CHECK_ENV = """
import gymnasium as gym
import bubblerob_env
from gymnasium.utils.env_checker import check_env
check_env(gym.make("BubbleRob-v0"))
print("checked")
"""


def test_gymnasium_check_env_passes_headless_with_default_arguments() -> None:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    result = subprocess.run(
        [sys.executable, "-c", CHECK_ENV], env=env, capture_output=True, text=True, timeout=300
    )
    assert result.returncode == 0, result.stderr[-2000:]
    assert "checked" in result.stdout
