"""Evaluate policies on held-out seeds and print one comparison table; record episode videos."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from policies.loading import load_policy

__all__ = ["DEFAULT_EVAL_SEED", "EvalResult", "evaluate", "format_table", "record_video"]

DEFAULT_EVAL_SEED = 1000
"""First seed of evaluation episodes: training (seeds 0..n_envs-1, then unseeded resets) and its
periodic evaluation (seeds from 1,000,000) never start an episode from these."""


@dataclass(frozen=True)
class EvalResult:
    """Outcome of ``episodes`` episodes of one policy."""

    policy: str
    episodes: int
    success_rate: float
    collision_rate: float
    mean_speed_fraction: float
    mean_length: float
    mean_return: float


def evaluate(
    policy_name: str,
    episodes: int = 100,
    seed: int = DEFAULT_EVAL_SEED,
    env_id: str = "BubbleRob-v0",
    env_kwargs: dict[str, Any] | None = None,
    progress: bool = False,
) -> EvalResult:
    """Run ``episodes`` episodes from seeds ``seed, seed + 1, ...`` with deterministic actions.

    Success means the episode reached the time limit without a collision. The speed fraction is
    the mean measured forward speed over all steps divided by the env's ``max_linear_speed``.
    """
    env = gym.make(env_id, **(env_kwargs or {}))
    policy = load_policy(policy_name, env)
    successes = collisions = 0
    speeds: list[float] = []
    lengths: list[int] = []
    returns: list[float] = []
    episode_iter: Any = range(episodes)
    if progress:
        from tqdm import tqdm

        episode_iter = tqdm(episode_iter, desc=f"evaluate {policy_name}", unit="episode")
    for episode in episode_iter:
        obs, _ = env.reset(seed=seed + episode)
        episode_start = True
        total, steps = 0.0, 0
        while True:
            action, _ = policy.predict(
                obs, episode_start=np.array([episode_start]), deterministic=True
            )
            episode_start = False
            obs, reward, terminated, truncated, info = env.step(action)
            total += float(reward)
            steps += 1
            speeds.append(float(info["body_twist"][0]) / env.unwrapped.max_linear_speed)
            if terminated or truncated:
                break
        collisions += bool(info["collision"])
        successes += bool(truncated and not terminated)
        lengths.append(steps)
        returns.append(total)
    env.close()
    return EvalResult(
        policy=str(policy_name),
        episodes=episodes,
        success_rate=successes / episodes,
        collision_rate=collisions / episodes,
        mean_speed_fraction=float(np.mean(speeds)),
        mean_length=float(np.mean(lengths)),
        mean_return=float(np.mean(returns)),
    )


def format_table(results: Sequence[EvalResult], markdown: bool = False) -> str:
    """One table, a row per policy."""
    header = ["policy", "episodes", "success", "collision", "speed/max", "length", "return"]
    rows = [
        [
            r.policy,
            str(r.episodes),
            f"{r.success_rate:.0%}",
            f"{r.collision_rate:.0%}",
            f"{r.mean_speed_fraction:.0%}",
            f"{r.mean_length:.0f}",
            f"{r.mean_return:.1f}",
        ]
        for r in results
    ]
    if markdown:
        lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
        lines += ["| " + " | ".join(row) + " |" for row in rows]
        return "\n".join(lines)
    widths = [max(len(row[i]) for row in [header, *rows]) for i in range(len(header))]
    return "\n".join(
        "  ".join(cell.ljust(width) for cell, width in zip(row, widths, strict=True)).rstrip()
        for row in [header, *rows]
    )


def record_video(
    policy_name: str,
    path: Path,
    seed: int = DEFAULT_EVAL_SEED,
    env_id: str = "BubbleRob-v0",
    env_kwargs: dict[str, Any] | None = None,
    max_steps: int | None = None,
    size: int = 360,
) -> int:
    """Write one episode from the overhead view (laser drawn) as MP4 or GIF; returns its frames."""
    import imageio.v3 as iio

    if path.suffix.lower() not in (".mp4", ".gif"):
        raise ValueError(f"video path must end in .mp4 or .gif, got {path}")
    kwargs = dict(env_kwargs or {}, render_mode="rgb_array", render_width=size, render_height=size)
    env = gym.make(env_id, **kwargs)
    policy = load_policy(policy_name, env)
    obs, _ = env.reset(seed=seed)
    frames = [env.render()]
    steps = 0
    while max_steps is None or steps < max_steps:
        action, _ = policy.predict(obs, deterministic=True)
        obs, _, terminated, truncated, _ = env.step(action)
        frames.append(env.render())
        steps += 1
        if terminated or truncated:
            break
    env.close()
    fps = env.metadata["render_fps"]
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix.lower() == ".gif":
        iio.imwrite(path, np.stack(frames), duration=1000 / fps, loop=0)
    else:
        _write_mp4(path, frames, fps)
    return len(frames)


def _write_mp4(path: Path, frames: list[np.ndarray], fps: int) -> None:
    import imageio.v2 as imageio

    with imageio.get_writer(path, fps=fps, codec="libx264", macro_block_size=8) as writer:
        for frame in frames:
            writer.append_data(frame)
