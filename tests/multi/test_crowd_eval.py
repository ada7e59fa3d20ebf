"""Circle crossings whose seeds mean something; the crowd metrics of ``evaluate --robots``."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("pettingzoo")
import bubblerob_env  # noqa: E402
from bubblerob_cli.main import main as bubblerob  # noqa: E402
from policies.crowd_metrics import crowd_metrics  # noqa: E402
from policies.multi_evaluation import run_world_episode, world_env  # noqa: E402

RADIUS, CLEARANCE, GOAL_RADIUS, V_MAX, DT = 0.11, 0.25, 0.2, 0.4, 0.05  # BubbleRob's defaults
FAST: dict[str, Any] = {"laser_num_rays": 36}


def _starts(env: Any, seed: int) -> tuple[np.ndarray, np.ndarray]:
    _, infos = env.reset(seed=seed)
    starts = np.array([[info["x"], info["y"]] for info in infos.values()])
    return starts, np.array([info["goal"] for info in infos.values()])


def test_a_jittered_circle_is_each_seeds_own_and_keeps_room_between_neighbours() -> None:
    env = bubblerob_env.parallel_env(
        num_robots=20, scenario="circle", task="nav", circle_jitter=0.1, **FAST
    )
    circle = env.config.arena_size / 2 - RADIUS - CLEARANCE
    assert circle == pytest.approx(2.24)  # README's rule: R = 2.24 m at 20 robots
    seen = []
    for seed in (0, 1):
        starts, goals = _starts(env, seed)
        np.testing.assert_allclose(np.hypot(*starts.T), circle, atol=2e-3)  # on the circle
        np.testing.assert_allclose(goals, -starts, atol=2e-3)  # goals: the antipodes
        angles = np.sort(np.arctan2(starts[:, 1], starts[:, 0]))
        gaps = np.diff(np.append(angles, angles[0] + 2 * math.pi))
        assert abs(gaps.mean() - 2 * math.pi / 20) < 1e-9
        assert gaps.std() > 0  # moved along the circle, not evenly spaced
        chords = 2 * circle * np.sin(gaps / 2)
        assert chords.min() >= 2 * RADIUS + CLEARANCE - 2e-3  # starts stay free
        seen.append(starts)
    assert not np.allclose(seen[0], seen[1])  # two seeds, two circles
    np.testing.assert_array_equal(_starts(env, 0)[0], seen[0])  # one seed, one circle
    plain = bubblerob_env.parallel_env(num_robots=20, scenario="circle", task="nav", **FAST)
    np.testing.assert_array_equal(_starts(plain, 0)[0], _starts(plain, 1)[0])  # as before
    with pytest.raises(ValueError, match=r"circle_jitter 0.2 m .* at most 0.11"):
        bubblerob_env.parallel_env(num_robots=20, scenario="circle", task="nav", circle_jitter=0.2)


class ToGoal:
    """Turn towards the goal's bearing and drive (a batch of observations in, actions out)."""

    def predict(self, obs: dict[str, Any], **_: Any) -> tuple[np.ndarray, None]:
        turn = np.clip(2.0 * obs["goal"][:, 1], -1, 1)
        return np.stack([1 - turn, 1 + turn], axis=1).clip(-1, 1).astype(np.float32), None


def test_a_lone_crossing_measures_its_extra_time_and_distance_from_the_straight_line() -> None:
    world = world_env(1, "circle", "BubbleRobNav-v0", {"laser_num_rays": 36}, circle_jitter=0.1)
    try:
        (record,) = run_world_episode(world, ToGoal(), seed=100_000, max_speed=V_MAX)
    finally:
        world.close()
    assert record["succeeded"] and record["outcome"] == "success"
    straight = 2 * (4.0 / 2 - RADIUS - CLEARANCE) - GOAL_RADIUS  # to the goal's disc
    assert record["shortest"] == pytest.approx(straight, abs=1e-3)
    assert record["time"] == pytest.approx(record["length"] * DT)
    assert straight - 0.05 <= record["driven"] <= straight + 0.3  # about straight there
    metrics = crowd_metrics([record, {**record, "succeeded": False, "collided_with": "bubble"}])
    assert metrics.counts == {"success": 1, "robot": 1, "obstacle": 0, "timeout": 0}
    assert metrics.extra_time == pytest.approx(record["time"] - record["shortest"] / V_MAX)
    assert metrics.extra_time_ratio == pytest.approx(metrics.extra_time * V_MAX / straight)
    assert metrics.extra_distance == pytest.approx(record["driven"] - record["shortest"])
    assert metrics.mean_speed == pytest.approx(record["driven"] / record["time"])


def test_evaluate_robots_on_a_nav_env_prints_the_crowd_table(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    per_robot = tmp_path / "crowd.json"
    argv = [
        "evaluate", "--env", "BubbleRobNav-v0", "--policy", "navigator", "--policy",
        "crowd_navigator", "--policy", "crowd", "--robots", "3",
        "--scenario", "circle", "--circle-jitter", "0.05", "--episodes", "2", "--split", "test",
        "--env-kwargs", '{"max_episode_steps": 40}',
        "--per-episode", str(per_robot),
    ]  # fmt: skip
    assert bubblerob(argv) == 0
    header, *rows = capsys.readouterr().out.splitlines()[:4]
    assert header.split()[:5] == ["policy", "robots", "scenario", "robot-episodes", "success"]
    assert "extra time s" in header
    assert [row.split()[:4] for row in rows] == [
        [name, "3", "circle", "6"] for name in ("navigator", "crowd_navigator", "crowd")
    ]
    records = json.loads(per_robot.read_text())
    for name in ("navigator", "crowd_navigator", "crowd"):  # 2 s: no robot gets there
        assert [r["outcome"] for r in records[name]] == ["timeout"] * 6
    with pytest.raises(SystemExit) as exit_:
        bubblerob([*argv[:-2], "--circle-jitter", "2"])
    assert exit_.value.code == 2
    assert "circle_jitter 2.0 m" in capsys.readouterr().err


def test_the_crowd_recipe_file_trains_on_the_weighted_mix(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from bubblerob_cli.train import main

    out = tmp_path / "run"
    recipe = Path(__file__).resolve().parents[2] / "train" / "hyperparams" / "crowd.yml"
    argv = [
        "--env", "BubbleRobNav-v0", "--vec-env", "crowd", "--conf-file", str(recipe),
        "--timesteps", "1", "--set", "n_steps=2", "--set", "batch_size=256",
        "--set", "n_epochs=1", "--set", "callback=null", "--set", "env_kwargs={laser_num_rays: 36}",
        "--eval-freq", "1000", "--eval-episodes", "1", "--no-progress", "--out", str(out),
    ]  # fmt: skip
    assert main(argv) == 0
    settings = json.loads((out / "settings.json").read_text())
    assert settings["vec_env"] == "crowd" and (out / "model.zip").is_file()
    # n_envs 1 (the recipe's): circles of 4, 8, 2 x 12 and 3 x 20 robots, 4 random arenas of 8;
    # one rollout of 2 steps of every robot.
    robots = 4 + 8 + 2 * 12 + 3 * 20 + 4 * 8
    timing = json.loads((out / "train_time.json").read_text())
    assert timing["timesteps"] == 2 * robots
    # A wall time comes with when it ran and the machine's load then.
    assert timing["started"] <= timing["ended"] and timing["ended"].endswith("Z")
    assert len(timing["uptime_load_at_start"]) == len(timing["uptime_load_at_end"]) == 3
    missing = tmp_path / "none.yml"
    assert main(["--env", "BubbleRobNav-v0", "--conf-file", str(missing), "--out", str(out)]) == 2
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert error.endswith(f"--conf-file {missing}: No such file or directory")
