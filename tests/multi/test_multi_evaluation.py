"""evaluate --robots (#36 item 5): one policy on every robot, per robot-episode outcomes."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("pettingzoo", reason="the [multi] extra is not installed")

from bubblerob_cli.main import main as bubblerob  # noqa: E402
from policies.multi_evaluation import (  # noqa: E402
    MultiEvalResult,
    run_world_episode,
    world_env,
)
from policies.protocol import wilson_interval  # noqa: E402


class Ahead:
    """Full speed ahead on every robot (a batch of observations in, a batch of actions out)."""

    def predict(self, obs: dict[str, Any], **_: Any) -> tuple[np.ndarray, None]:
        return np.ones((len(obs["proximity"]), 2), dtype=np.float32), None


def test_two_robots_driven_at_each_other_both_end_on_the_other() -> None:
    # On a circle facing its centre, no obstacles: driving ahead, they meet in the middle.
    world = world_env(
        2, "circle", "BubbleRob-v0", {"num_obstacles": (0, 0), "max_episode_steps": 400}
    )
    try:
        records = run_world_episode(world, Ahead(), seed=100_000, max_speed=1.0)
    finally:
        world.close()
    assert [r["robot"] for r in records] == ["bubblerob_0", "bubblerob_1"]
    assert [r["collided_with"] for r in records] == ["bubblerob_1", "bubblerob_0"]
    assert not any(r["succeeded"] for r in records)
    assert records[0]["length"] == records[1]["length"] < 400  # both end in the same step
    result = MultiEvalResult("ahead", 2, "circle", 1, tuple(records))
    assert result.count("robot") == 2 and result.count("obstacle") == 0
    assert result.rate("success") == (0.0, *wilson_interval(0, 2))


def test_evaluate_robots_prints_the_table_and_writes_each_robot_episode(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    per_robot = tmp_path / "robots.json"
    argv = [
        "evaluate", "--policy", "laser", "--policy", "ppo", "--robots", "3", "--episodes", "2",
        "--split", "test", "--scenario", "circle", "--env-kwargs", '{"max_episode_steps": 15}',
        "--per-episode", str(per_robot),
    ]  # fmt: skip
    assert bubblerob(argv) == 0
    table = capsys.readouterr().out.splitlines()
    assert table[0].split()[:4] == ["policy", "robots", "scenario", "robot-episodes"]
    assert [line.split()[:4] for line in table[1:3]] == [
        ["laser", "3", "circle", "6"],
        ["ppo", "3", "circle", "6"],  # the shipped policy drives every robot of the world
    ]
    records = json.loads(per_robot.read_text())
    for policy in ("laser", "ppo"):
        seeds = [(r["seed"], r["robot"]) for r in records[policy]]
        assert seeds == [(s, f"bubblerob_{k}") for s in (100_000, 100_001) for k in range(3)]
        assert all(r["length"] <= 15 and 0.0 <= r["speed"] <= 1.5 for r in records[policy])


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (["--robots", "0"], "--robots must be >= 1, got 0"),
        (["--robots", "80"], "--robots 80: num_robots=80 do not fit"),
        (["--robots", "2", "--circle-jitter", "0.1"], "circle_jitter moves the robots of"),
        (["--robots", "2", "--video", "x.gif"], "not with --video"),
    ],
)
def test_bad_robots_options_are_one_line(
    options: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["evaluate", "--episodes", "1", *options]
    if "--policy" not in options:
        argv += ["--policy", "laser"]
    with pytest.raises(SystemExit) as exit_:
        bubblerob(argv)
    assert exit_.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
