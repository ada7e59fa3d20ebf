"""``bubblerob evaluate``: the comparison table and the episode video."""

from __future__ import annotations

import imageio.v3 as iio
import numpy as np
import pytest
from cli_usage import run

from policies.evaluation import EpisodeStats, format_table, summarize
from policies.protocol import wilson_interval


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
        "95%CI",
        "collision",
        "speed/max",
        "length",
        "return",
    ]
    assert table.splitlines()[1].split()[:6] == ["p", "2", "50.0%", "9.5%-90.5%", "50.0%", "64.3%"]


@pytest.mark.parametrize(("successes", "trials"), [(0, 10), (3, 10), (10, 10), (981, 1000)])
def test_the_success_interval_is_wilsons(successes, trials):
    # Wilson's interval is the set of p with |p_hat - p| <= z * sqrt(p (1 - p) / n): its ends are
    # the roots of that quadratic, found here by bisection, not by the closed form under test.
    p_hat, z = successes / trials, 1.96

    def inside(p: float) -> bool:
        return abs(p_hat - p) <= z * np.sqrt(p * (1 - p) / trials)

    def edge(outside: float, inner: float) -> float:
        for _ in range(100):
            middle = (outside + inner) / 2
            outside, inner = (outside, middle) if inside(middle) else (middle, inner)
        return inner

    low = 0.0 if inside(0.0) else edge(0.0, p_hat if inside(p_hat) else 0.5)
    high = 1.0 if inside(1.0) else edge(1.0, p_hat if inside(p_hat) else 0.5)
    assert wilson_interval(successes, trials) == pytest.approx((low, high), abs=1e-9)


def test_evaluate_command_compares_policies_and_writes_a_video(tmp_path, capsys):
    video = tmp_path / "episode.gif"
    command = ["evaluate", "--policy", "laser", "--policy", "reactive", "--episodes", "2",
               "--env-kwargs", '{"arena_size": 3.0}', "--video", str(video)]  # fmt: skip
    result = run(command, capsys)  # in process (cli_usage): an exception fails the test
    assert result.code == 0, result.err
    rows = [line.split() for line in result.out.splitlines()]
    assert rows[0][0] == "policy"
    assert [rows[1][0], rows[2][0]] == ["laser", "reactive"]
    frames = iio.imread(video, index=None)
    assert frames.shape[0] >= 2 and frames.shape[-1] in (3, 4)


def test_evaluate_rejects_bad_env_kwargs(capsys):
    result = run(["evaluate", "--policy", "laser", "--env-kwargs", "[1]"], capsys)
    assert result.code == 2
    assert "--env-kwargs must be a JSON object" in result.err


def test_demo_films_the_first_episode_from_above_and_shows_progress(tmp_path, capsys):
    import gymnasium as gym

    from bubblerob_env.wrappers import TopDownView

    command = ["demo", "--episodes", "1", "--policy", "laser", "--out", str(tmp_path)]
    result = run(command, capsys)
    assert result.code == 0, result.err
    assert "1000/1000" in result.err and "step" in result.err  # a bar of steps
    frames = iio.imread(tmp_path / "bubblerob_demo_laser.mp4", index=None)
    assert frames.shape == (1001, 360, 360, 3)  # the reset's frame and one per step
    env = TopDownView(gym.make("BubbleRob-v0"))

    def far_off(seed: int) -> float:  # the share of pixels far from the view after reset(seed)
        env.reset(seed=seed)
        return float((np.abs(frames[0].astype(int) - env.render()).max(axis=2) > 40).mean())

    # H.264 at x264's fastest preset blurs the thin rays; another seed's arena is much farther.
    assert far_off(1000) < 0.15 and far_off(1000) < 0.5 * far_off(1001)
    env.close()
