"""train/rllib_ppo.py: RLlib's PPO (new API stack), 2 env runners on the native batch.

Runs where ``ray[rllib]`` and torch are installed: their own venv, as RLlib 2.60 pins
gymnasium 1.2.2 (``make test-clients``, README: Past one machine); skipped elsewhere.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from ray_helpers import need_netns, run_scenarios


def test_ppo_trains_on_two_env_runners_stepping_the_native_batch(tmp_path: Path) -> None:
    pytest.importorskip(
        "ray.rllib",
        reason="ray[rllib] is not installed with the project: `make test-clients` runs this "
        "test in its own venv (.venv-clients)",
    )
    pytest.importorskip("torch", reason="RLlib's PPO here needs torch")
    need_netns()
    params = {"envs": 2, "rollout": 50, "iterations": 2, "env_kwargs": {"max_episode_steps": 40}}
    result = run_scenarios({"rllib_ppo": params}, tmp_path, timeout_s=400)["rllib_ppo"]
    assert result["env_classes"] == ["BubbleRobVectorEnv", "BubbleRobVectorEnv"]
    assert result["steps"] == [200, 400]  # 2 runners x 2 robots x 50 steps per iteration
    assert all(r is not None and math.isfinite(r) for r in result["returns"])
