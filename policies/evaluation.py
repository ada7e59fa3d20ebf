"""Evaluate policies on held-out seeds and print one comparison table; record episode videos."""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import gymnasium as gym
import numpy as np

from bubblerob_env import BubbleRobEnv
from bubblerob_env.wrappers import TopDownView
from policies.loading import load_policy
from policies.navigation_metrics import NavMetrics, episode_record, format_nav_table, nav_metrics
from policies.protocol import wilson_interval

__all__ = [
    "DEFAULT_EVAL_SEED",
    "EpisodeStats",
    "EvalResult",
    "FfmpegNotFoundError",
    "VideoWriter",
    "evaluate",
    "format_table",
    "record_video",
    "run_episode",
    "step_bar",
    "summarize",
    "summarize_records",
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
    per_episode: tuple[dict[str, Any], ...] = ()
    """One record per episode, in seed order: ``seed``, ``succeeded``, ``collided``, ``length``,
    ``return`` and ``speed`` (its mean speed fraction), for ``evaluate --per-episode``; a Nav
    env's also its navigation fields (:func:`~policies.navigation_metrics.episode_record`)."""
    navigation: NavMetrics | None = None
    """A Nav env's success, SPL, extra time and distance (:mod:`policies.navigation_metrics`)."""

    @property
    def success_interval(self) -> tuple[float, float]:
        """The Wilson 95% interval of the success rate."""
        return wilson_interval(round(self.success_rate * self.episodes), self.episodes)


@dataclass(frozen=True)
class EpisodeStats:
    """One episode's outcome."""

    length: int
    total_reward: float
    collided: bool
    succeeded: bool
    speed_fractions: tuple[float, ...]
    seed: int = -1
    navigation: dict[str, Any] | None = None
    """A Nav env's episode: its navigation fields (outcome, shortest and driven path, time)."""


class FrameSink(Protocol):
    """Where rendered frames go: a list, or a :class:`VideoWriter` that encodes as they come."""

    def append(self, frame: np.ndarray, /) -> None:
        """Take one frame."""


def _frame(env: gym.Env[Any, Any]) -> np.ndarray:
    frame = env.render()
    if not isinstance(frame, np.ndarray):
        raise ValueError(f"recording frames needs render_mode='rgb_array', got {env.render_mode!r}")
    return frame


def run_episode(
    env: gym.Env[Any, Any],
    policy: Any,
    seed: int,
    frames: FrameSink | None = None,
    on_step: Callable[[], object] | None = None,
) -> EpisodeStats:
    """Run one episode from ``seed`` with deterministic actions; append rendered frames if asked.

    Success is the env's ``info["is_success"]`` on the last step: the time limit reached
    without a collision. ``on_step`` is called after every step (a progress bar's update).
    """
    obs, _ = env.reset(seed=seed)
    if frames is not None:
        frames.append(_frame(env))
    episode_start = True
    total, speeds = 0.0, []
    base = env.unwrapped
    if not isinstance(base, BubbleRobEnv):
        raise TypeError(f"expected a BubbleRob env, got {type(base).__name__}")
    max_speed = base.max_linear_speed
    while True:
        action, _ = policy.predict(obs, episode_start=np.array([episode_start]), deterministic=True)
        episode_start = False
        obs, reward, terminated, truncated, info = env.step(action)
        total += float(reward)
        speeds.append(float(info["body_twist"][0]) / max_speed)
        if frames is not None:
            frames.append(_frame(env))
        if on_step is not None:
            on_step()
        if terminated or truncated:
            break
    navigation = None
    if "shortest_path_length" in info:  # a Nav env (bubblerob_env.tasks.nav)
        radius = float(getattr(base, "goal_radius", 0.0))
        navigation = episode_record(info, len(speeds), base.dt, max_speed, radius)
    return EpisodeStats(
        length=len(speeds),
        total_reward=total,
        collided=bool(info["collision"]),
        succeeded=bool(info["is_success"]),
        speed_fractions=tuple(speeds),
        seed=seed,
        navigation=navigation,
    )


def summarize(policy_name: str, episodes: Sequence[EpisodeStats]) -> EvalResult:
    """Aggregate episodes into one table row (through their per-episode records)."""
    records = [
        {
            "seed": e.seed,
            "succeeded": e.succeeded,
            "collided": e.collided,
            "length": e.length,
            "return": e.total_reward,
            "speed": float(np.mean(e.speed_fractions)),
            **(e.navigation or {}),
        }
        for e in episodes
    ]
    return summarize_records(policy_name, records)


def summarize_records(policy_name: str, records: Sequence[dict[str, Any]]) -> EvalResult:
    """The table row of per-episode records (``evaluate --per-episode``'s).

    The mean speed is over all steps: each episode's mean weighted by its length.
    """
    lengths = np.array([r["length"] for r in records], dtype=float)
    return EvalResult(
        policy=policy_name,
        episodes=len(records),
        success_rate=float(np.mean([r["succeeded"] for r in records])),
        collision_rate=float(np.mean([r["collided"] for r in records])),
        mean_speed_fraction=float(np.dot([r["speed"] for r in records], lengths) / lengths.sum()),
        mean_length=float(lengths.mean()),
        mean_return=float(np.mean([r["return"] for r in records])),
        per_episode=tuple(records),
        navigation=nav_metrics(records),
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
    """One table, a row per policy; success with its Wilson 95% interval.

    Results of a Nav env get the navigation table
    (:func:`~policies.navigation_metrics.format_nav_table`).
    """
    navigation = [(r.policy, r.navigation) for r in results if r.navigation is not None]
    if results and len(navigation) == len(results):
        return format_nav_table(navigation, markdown)
    header = [
        "policy", "episodes", "success", "95%CI", "collision", "speed/max", "length",
        "return",
    ]  # fmt: skip
    rows = [
        [
            r.policy,
            str(r.episodes),
            f"{r.success_rate:.1%}",
            "{:.1%}-{:.1%}".format(*r.success_interval),
            f"{r.collision_rate:.1%}",
            f"{r.mean_speed_fraction:.1%}",
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
    progress: bool = False,
) -> int:
    """Write one episode from above (laser drawn) as MP4 or GIF; returns its frames.

    The frames are :class:`~bubblerob_env.wrappers.TopDownView`'s, drawn without OpenGL, and go
    to the encoder as they are drawn: memory stays flat however long the episode. ``progress``
    shows a bar of the episode's steps.
    """
    _check_video_path(path)
    kwargs = dict(env_kwargs or {})
    if max_steps is not None:
        kwargs["max_episode_steps"] = max_steps
    env = TopDownView(gym.make(env_id, **kwargs), size, size)
    policy = load_policy(policy_name, env)
    with (
        VideoWriter(path, env.metadata["render_fps"]) as writer,
        step_bar(env, 1, f"video {policy_name} -> {path.name}", progress) as bar,
    ):
        run_episode(env, policy, seed, writer, on_step=bar.update)
    env.close()
    return writer.frames


def step_bar(env: gym.Env[Any, Any], episodes: int, description: str, shown: bool) -> Any:
    """A tqdm bar over the steps of ``episodes`` episodes of up to the env's time limit."""
    from tqdm import tqdm

    limit = env.spec.max_episode_steps if env.spec is not None else None
    total = episodes * limit if limit else None
    return tqdm(total=total, desc=description, unit="step", disable=not shown)


def _check_video_path(path: Path) -> None:
    if path.suffix.lower() not in (".mp4", ".gif"):
        raise ValueError(f"video path must end in .mp4 or .gif, got {path}")


# GIF in one pass with one 256-colour palette, made from the first frame: the top-down view's few
# flat colours are all in it, ffmpeg never holds the clip, and a 1000-frame episode takes ~3 s and
# ~9 MB (a palette per frame took ~30 s and 24 MB).
_GIF_FILTER = (
    "split[a][b];[a]trim=end_frame=1,palettegen=reserve_transparent=0[p];"
    "[b][p]paletteuse=dither=none"
)
# H.264 tuned for flat colours, at x264's cheapest preset: it keeps up with the simulation. For a
# 1000-frame top-down episode here: 2.3 s of CPU and 5 MB; x264's default (medium, CRF 23) took
# 19 s, and veryfast 6 s for 3 MB. The encoder runs beside the simulation, on another core.
_H264_OPTIONS = ("-c:v", "libx264", "-preset", "ultrafast", "-tune", "animation", "-crf", "30")


class FfmpegNotFoundError(RuntimeError):
    """No ffmpeg to write a video with: imageio-ffmpeg is not installed, none is on the PATH.

    Its message is one line that says what to install (the commands print it and exit 1).
    """


def ffmpeg_executable() -> str:
    """imageio-ffmpeg's ffmpeg if that package is installed, else ``ffmpeg`` on the PATH.

    Raises :class:`FfmpegNotFoundError` when there is neither.
    """
    try:
        import imageio_ffmpeg
    except ModuleNotFoundError:
        found = shutil.which("ffmpeg")
        if found is None:
            raise FfmpegNotFoundError(
                "writing a video needs ffmpeg: apt-get install ffmpeg (or pip install "
                "imageio-ffmpeg); --no-video skips the video"
            ) from None
        return found
    return str(imageio_ffmpeg.get_ffmpeg_exe())


class VideoWriter:
    """Streams RGB frames to ffmpeg as an MP4 (H.264) or a looping GIF, by the path's suffix.

    ``append`` pipes each frame to an ffmpeg process at once; nothing is kept in memory. The
    size is taken from the first frame. ffmpeg is imageio-ffmpeg's (the [dev] extra) or the
    system's (Debian's ``ffmpeg``).
    """

    def __init__(self, path: Path, fps: float) -> None:
        _check_video_path(path)
        self.path = Path(path)
        self.fps = fps
        self.frames = 0
        self._encoder: Any = None

    def append(self, frame: np.ndarray, /) -> None:
        """Encode one frame (H x W x 3 uint8)."""
        frame = np.ascontiguousarray(frame[..., :3], dtype=np.uint8)
        if self._encoder is None:
            self._encoder = self._open(frame.shape[1], frame.shape[0])
        self._send(frame)
        self.frames += 1

    def _open(self, width: int, height: int) -> Any:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        if self.path.suffix.lower() == ".gif":
            options = ["-filter_complex", _GIF_FILTER, "-loop", "0"]
        else:  # H.264 needs even sizes
            even = "scale=trunc(iw/2)*2:trunc(ih/2)*2"
            options = ["-vf", even, *_H264_OPTIONS, "-pix_fmt", "yuv420p"]
        command = [
            ffmpeg_executable(), "-y", "-loglevel", "error", "-f", "rawvideo",
            "-pix_fmt", "rgb24", "-s", f"{width}x{height}", "-r", f"{self.fps}", "-i", "-",
            "-an", *options, str(self.path),
        ]  # fmt: skip
        return subprocess.Popen(command, stdin=subprocess.PIPE, stderr=subprocess.PIPE)

    def _send(self, frame: np.ndarray) -> None:
        try:
            self._encoder.stdin.write(frame.tobytes())
        except BrokenPipeError:
            self.close()

    def close(self) -> None:
        """Finish the file."""
        encoder, self._encoder = self._encoder, None
        if encoder is None:
            return
        encoder.stdin.close()
        error = encoder.stderr.read().decode(errors="replace").strip()
        if encoder.wait() != 0:
            raise RuntimeError(f"ffmpeg could not write {self.path}: {error}")

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def write_video(path: Path, frames: Iterable[np.ndarray], fps: float) -> None:
    """Write frames as an MP4 (H.264) or a looping GIF, by the path's suffix."""
    with VideoWriter(path, fps) as writer:
        for frame in frames:
            writer.append(frame)
