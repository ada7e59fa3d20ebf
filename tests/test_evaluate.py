"""``bubblerob evaluate``: the comparison table and the episode video."""

from __future__ import annotations

import subprocess
import sys

import imageio.v3 as iio
import numpy as np
import pytest

from policies.evaluation import EpisodeStats, format_table, summarize


def test_summary_counts_successes_collisions_and_speed():
    episodes = [
        EpisodeStats(10, 5.0, collided=False, succeeded=True, speed_fractions=(0.5,) * 10),
        EpisodeStats(4, -8.0, collided=True, succeeded=False, speed_fractions=(1.0,) * 4),
    ]
    result = summarize("p", episodes)
    assert (result.success_rate, result.collision_rate) == (0.5, 0.5)
    assert result.mean_speed_fraction == pytest.approx((5.0 + 4.0) / 14)
    assert result.mean_length == 7
    table = format_table([result])
    assert table.splitlines()[0].split() == [
        "policy",
        "episodes",
        "success",
        "collision",
        "speed/max",
        "length",
        "return",
    ]
    assert table.splitlines()[1].split()[:5] == ["p", "2", "50%", "50%", "64%"]


def test_evaluate_command_compares_policies_and_writes_a_video(tmp_path):
    video = tmp_path / "episode.gif"
    command = [
        sys.executable,
        "-m",
        "bubblerob_env.cli",
        "evaluate",
        "--policy",
        "laser",
        "--policy",
        "reactive",
        "--episodes",
        "2",
        "--env-kwargs",
        '{"arena_size": 3.0}',
        "--video",
        str(video),
    ]
    result = subprocess.run(command, capture_output=True, text=True, timeout=600, check=False)
    assert result.returncode == 0, result.stderr
    rows = [line.split() for line in result.stdout.splitlines()]
    assert rows[0][0] == "policy"
    assert [rows[1][0], rows[2][0]] == ["laser", "reactive"]
    frames = iio.imread(video, index=None)
    assert frames.shape[0] >= 2 and frames.shape[-1] in (3, 4)


def test_evaluate_rejects_bad_env_kwargs():
    command = [
        sys.executable,
        "-m",
        "bubblerob_env.cli",
        "evaluate",
        "--policy",
        "laser",
        "--env-kwargs",
        "[1]",
    ]
    result = subprocess.run(command, capture_output=True, text=True, timeout=120, check=False)
    assert result.returncode == 2
    assert "--env-kwargs must be a JSON object" in result.stderr


def test_demo_films_the_first_episode_from_above_and_shows_progress(tmp_path):
    import gymnasium as gym

    from bubblerob_env.wrappers import TopDownView

    command = [sys.executable, "-m", "bubblerob_env.cli", "demo", "--episodes", "1"]
    command += ["--policy", "laser", "--out", str(tmp_path)]
    result = subprocess.run(command, capture_output=True, text=True, timeout=600, check=False)
    assert result.returncode == 0, result.stderr
    assert "1000/1000" in result.stderr and "step" in result.stderr  # a bar of steps
    frames = iio.imread(tmp_path / "bubblerob_demo_laser.mp4", index=None)
    assert frames.shape == (1001, 360, 360, 3)  # the reset's frame and one per step
    env = TopDownView(gym.make("BubbleRob-v0"))

    def far_off(seed: int) -> float:  # the share of pixels far from the view after reset(seed)
        env.reset(seed=seed)
        return float((np.abs(frames[0].astype(int) - env.render()).max(axis=2) > 40).mean())

    # H.264 at x264's fastest preset blurs the thin rays; another seed's arena is much farther.
    assert far_off(1000) < 0.15 and far_off(1000) < 0.5 * far_off(1001)
    env.close()
