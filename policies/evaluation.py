"""Evaluate policies on held-out seeds and print one comparison table; record episode videos."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from policies.loading import load_policy

__all__ = [
    "DEFAULT_EVAL_SEED",
    "EpisodeStats",
    "EvalResult",
    "evaluate",
    "format_table",
    "record_video",
    "run_episode",
    "summarize",
    "write_video",
]

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


@dataclass(frozen=True)
class EpisodeStats:
    """One episode's outcome."""

    length: int
    total_reward: float
    collided: bool
    succeeded: bool
    speed_fractions: tuple[float, ...]


def run_episode(
    env: gym.Env[Any, Any], policy: Any, seed: int, frames: list[np.ndarray] | None = None
) -> EpisodeStats:
    """Run one episode from ``seed`` with deterministic actions; append rendered frames if asked.

    Success is the env's ``info["is_success"]`` on the last step: the time limit reached
    without a collision.
    """
    obs, _ = env.reset(seed=seed)
    if frames is not None:
        frames.append(env.render())
    episode_start = True
    total, speeds = 0.0, []
    max_speed = env.unwrapped.max_linear_speed
    while True:
        action, _ = policy.predict(obs, episode_start=np.array([episode_start]), deterministic=True)
        episode_start = False
        obs, reward, terminated, truncated, info = env.step(action)
        total += float(reward)
        speeds.append(float(info["body_twist"][0]) / max_speed)
        if frames is not None:
            frames.append(env.render())
        if terminated or truncated:
            break
    return EpisodeStats(
        length=len(speeds),
        total_reward=total,
        collided=bool(info["collision"]),
        succeeded=bool(info["is_success"]),
        speed_fractions=tuple(speeds),
    )


def summarize(policy_name: str, episodes: Sequence[EpisodeStats]) -> EvalResult:
    """Aggregate episodes into one table row."""
    count = len(episodes)
    return EvalResult(
        policy=policy_name,
        episodes=count,
        success_rate=sum(e.succeeded for e in episodes) / count,
        collision_rate=sum(e.collided for e in episodes) / count,
        mean_speed_fraction=float(np.mean([s for e in episodes for s in e.speed_fractions])),
        mean_length=float(np.mean([e.length for e in episodes])),
        mean_return=float(np.mean([e.total_reward for e in episodes])),
    )


def evaluate(
    policy_name: str,
    episodes: int = 100,
    seed: int = DEFAULT_EVAL_SEED,
    env_id: str = "BubbleRob-v0",
    env_kwargs: dict[str, Any] | None = None,
    progress: bool = False,
) -> EvalResult:
    """Run ``episodes`` episodes from seeds ``seed, seed + 1, ...`` with deterministic actions.

    The speed fraction is the mean measured forward speed over all steps divided by the env's
    ``max_linear_speed``.
    """
    env = gym.make(env_id, **(env_kwargs or {}))
    policy = load_policy(policy_name, env)
    seeds: Any = range(seed, seed + episodes)
    if progress:
        from tqdm import tqdm

        seeds = tqdm(seeds, desc=f"evaluate {policy_name}", unit="episode")
    stats = [run_episode(env, policy, episode_seed) for episode_seed in seeds]
    env.close()
    return summarize(str(policy_name), stats)


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
    if path.suffix.lower() not in (".mp4", ".gif"):
        raise ValueError(f"video path must end in .mp4 or .gif, got {path}")
    kwargs = dict(env_kwargs or {}, render_mode="rgb_array", render_width=size, render_height=size)
    env = gym.make(env_id, **kwargs)
    frames: list[np.ndarray] = []
    run_episode(env, load_policy(policy_name, env), seed, frames)
    env.close()
    write_video(path, frames, env.metadata["render_fps"])
    return len(frames)


def write_video(path: Path, frames: Sequence[np.ndarray], fps: int) -> None:
    """Write frames as an MP4 (H.264) or a looping GIF, by the path's suffix."""
    import imageio.v3 as iio

    if path.suffix.lower() not in (".mp4", ".gif"):
        raise ValueError(f"video path must end in .mp4 or .gif, got {path}")
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix.lower() == ".gif":
        iio.imwrite(path, np.stack(frames), duration=1000 / fps, loop=0)
    else:
        _write_mp4(path, frames, fps)


def _write_mp4(path: Path, frames: Sequence[np.ndarray], fps: int) -> None:
    import imageio.v2 as imageio

    with imageio.get_writer(path, fps=fps, codec="libx264", macro_block_size=8) as writer:
        for frame in frames:
            writer.append_data(frame)
