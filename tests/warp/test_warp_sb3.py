"""SB3 on the MuJoCo Warp backend (issue #41, item 3), on Warp's CPU device.

Oracles: the CPU backend's SB3 adapter (``--vec-env batched``) with the same seeds and actions
(SB3's conventions on an episode's last step; the laser within 1e-3 m), and the CPU env itself
(a policy trained on the warp worlds acts on ``gym.make``'s observations).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("mujoco_warp")
pytest.importorskip("stable_baselines3")
from stable_baselines3 import PPO  # noqa: E402

import bubblerob_env  # noqa: E402,F401
from policies.loading import load_policy  # noqa: E402
from train.sb3_vec import BubbleRobSB3VecEnv  # noqa: E402
from train.sb3_warp import WarpSB3VecEnv  # noqa: E402

LASER_TOLERANCE = 1e-3  # metres


def _close(ours: Any, cpu: Any) -> bool:
    """Two dict observations: the laser (and the rest) within the laser's tolerance."""
    return all(np.abs(ours[key] - cpu[key]).max() <= LASER_TOLERANCE for key in cpu)


def test_episodes_end_as_the_cpu_adapters_do() -> None:
    """Through the time limit: dones, info keys, terminal observations, Monitor's episode."""
    warp = WarpSB3VecEnv(3, device="cpu", max_episode_steps=5, layout_bank=8)
    cpu = BubbleRobSB3VecEnv(3, max_episode_steps=5)
    warp.seed(7)
    cpu.seed(7)
    assert _close(warp.reset(), cpu.reset())
    assert [sorted(info) for info in warp.reset_infos] == [sorted(i) for i in cpu.reset_infos]
    actions = np.array([[0.5, 0.5], [0.2, -0.2], [1.0, 0.8]], dtype=np.float32)
    for step in range(5):
        obs, rewards, dones, infos = warp.step(actions)
        cpu_obs, cpu_rewards, cpu_dones, cpu_infos = cpu.step(actions)
        assert dones.tolist() == cpu_dones.tolist() == [step == 4] * 3
        if step < 4:  # then the next episodes, in arenas each backend draws its own way
            assert _close(obs, cpu_obs)
        assert np.abs(rewards - cpu_rewards).max() < 1e-3
        for info, cpu_info in zip(infos, cpu_infos, strict=True):
            assert sorted(info) == sorted(cpu_info)
            assert info["TimeLimit.truncated"] == cpu_info["TimeLimit.truncated"]
            if "episode" in cpu_info:
                assert info["episode"]["l"] == cpu_info["episode"]["l"] == 5
                assert abs(info["episode"]["r"] - cpu_info["episode"]["r"]) < 1e-3
                assert info["is_success"] == cpu_info["is_success"]
                assert _close(info["terminal_observation"], cpu_info["terminal_observation"])
    assert warp.get_attr("max_linear_speed") == cpu.get_attr("max_linear_speed")
    with pytest.raises(AttributeError, match="share one model"):
        warp.set_attr("max_linear_speed", 1.0)
    warp.close()
    cpu.close()


def test_ppo_trains_on_warps_cpu_device() -> None:
    envs = WarpSB3VecEnv(4, device="cpu", max_episode_steps=40, layout_bank=8)
    envs.seed(0)
    model = PPO("MultiInputPolicy", envs, n_steps=64, batch_size=128, n_epochs=2, seed=0)
    before = [p.detach().clone() for p in model.policy.parameters()]
    model.learn(256)
    assert model.num_timesteps == 256
    # Monitor's episodes, as SB3's logger reads them
    assert model.ep_info_buffer is not None and len(model.ep_info_buffer) >= 4
    after = list(model.policy.parameters())
    assert any(not (a == b).all() for a, b in zip(before, after, strict=True))
    envs.close()


def test_train_vec_env_warp_saves_a_policy_that_drives_the_cpu_env(tmp_path: Path) -> None:
    from train import train

    final = train(
        "ppo",
        "BubbleRob-v0",
        tmp_path,
        timesteps=128,
        n_envs=2,
        seed=3,
        eval_freq=64,
        eval_episodes=1,
        progress_bar=False,
        overrides={"n_steps": 64, "batch_size": 64},
        vec_env="warp",
    )
    assert final.is_file() and (tmp_path / "best_model.zip").is_file()
    env = gym.make("BubbleRob-v0", max_episode_steps=20)
    model = load_policy(final, env)  # fed the run's pooled scan, as evaluate feeds it
    obs, _ = env.reset(seed=1000)
    for _ in range(20):
        action, _ = model.predict(obs, deterministic=True)
        obs, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            break
    assert truncated or terminated


def test_vec_env_warp_names_what_to_install_and_the_envs_it_steps(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import importlib.util

    from train.envs import warp_envs

    with pytest.raises(ValueError, match="BubbleRob-v0 or PioneerP3DX-v0, not 'CartPole-v1'"):
        warp_envs("CartPole-v1", 1, 0, {})
    find_spec = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util,
        "find_spec",
        lambda name, *a: None if name == "mujoco_warp" else find_spec(name, *a),
    )
    with pytest.raises(ValueError, match=r"pip install 'bubblerob\[warp\]'"):
        warp_envs("BubbleRob-v0", 1, 0, {})
