"""Evaluation, recording and pickling on a local Ray cluster (2 CPUs), compared with serial runs.

All Ray work happens in one child process in a loopback-only network namespace
(ray_helpers.run_scenarios: one cluster start-up for the module); everything it is compared with
is computed here, without Ray.
"""

from __future__ import annotations

import dataclasses
import re
from collections import Counter
from pathlib import Path
from typing import Any

import gymnasium as gym
import pytest
from ray_helpers import as_json, need_netns, run_scenarios

from bubblerob_cli.main import main as bubblerob
from bubblerob_env.ros.readback.replay import replay_bag
from bubblerob_env.ros.readback.summary import read_summary
from policies.evaluation import evaluate, run_episode
from policies.loading import load_policy

SHORT = {"max_episode_steps": 150}
KILL_KWARGS = {"max_episode_steps": 400}
RECORD_ARGS = ["--policy", "laser", "--episodes", "5", "--seed", "40", "--max-steps", "250"]
RECORD_START = ["--start-time", "1700000000"]
EVALUATE = [
    "evaluate", "--policy", "reactive", "--policy", "laser", "--policy", "reactive",
    "--episodes", "4", "--seed", "7",
    "--env-kwargs", '{"max_episode_steps": 100}',
]  # fmt: skip


@pytest.fixture(scope="module")
def ray_runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Any]]:
    need_netns()
    out = tmp_path_factory.mktemp("ray_local")
    wanted = {
        "evaluate": {"episodes": 6, "seed": 1000, "env_kwargs": SHORT},
        "pickling": {"steps": 120, "env_kwargs": {}},
        "evaluate_with_kill": {
            "episodes": 12, "seed": 1000, "env_kwargs": KILL_KWARGS, "chunk_size": 6,
        },
        "record": {"argv": [*RECORD_ARGS, *RECORD_START, "--out", str(out / "bags")], "kill": True},
        "cli": {"argv": [*EVALUATE, "--ray", "local"]},
    }  # fmt: skip
    return out, run_scenarios(wanted, out)


def _serial_episodes(policy: str, seeds: range, env_kwargs: dict[str, Any]) -> list[dict[str, Any]]:
    """Each seed's episode run here, one env and policy for all as serial evaluate does."""
    env = gym.make("BubbleRob-v0", **env_kwargs)
    loaded = load_policy(policy, env)
    episodes = []
    for seed in seeds:
        stats = dataclasses.asdict(run_episode(env, loaded, seed))
        episodes.append({"policy": policy, "seed": seed, **stats})
    env.close()
    return episodes


def _json_like(value: Any) -> Any:
    """Tuples as lists, as the scenario's JSON holds them."""
    if isinstance(value, dict):
        return {k: _json_like(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_json_like(v) for v in value]
    return value


def test_evaluate_rows_and_episodes_equal_serial(ray_runs: tuple[Path, dict[str, Any]]) -> None:
    result = ray_runs[1]["evaluate"]
    policies = ["reactive", "laser", "ppo", "random"]
    serial_rows = [as_json(evaluate(p, 6, 1000, env_kwargs=SHORT)) for p in policies]
    assert result["rows"] == serial_rows
    serial = [e for p in policies for e in _serial_episodes(p, range(1000, 1006), SHORT)]
    assert result["episodes"] == _json_like(serial)
    assert result["tasks"] == 10  # 3 policies x 3 chunks of 2 seeds; random's one stream in 1


def test_evaluate_command_on_the_cluster_prints_the_serial_table(
    ray_runs: tuple[Path, dict[str, Any]], capsys: pytest.CaptureFixture[str]
) -> None:
    # `bubblerob evaluate --ray local` on this module's cluster (test_ray_cli's Ctrl-C test runs
    # it in a process of its own, which starts one); the table is the serial command's.
    done = ray_runs[1]["cli"]
    assert done["code"] == 0, done["stderr"]
    assert bubblerob(EVALUATE) == 0
    assert done["stdout"] == capsys.readouterr().out
    assert "12/12" in done["stderr"]  # the bar counted the 3 x 4 episodes (a policy named twice)
    assert "Ray tasks on 1 node(s)" in done["stderr"]


def test_killed_worker_is_retried_without_losing_or_repeating(
    ray_runs: tuple[Path, dict[str, Any]],
) -> None:
    result = ray_runs[1]["evaluate_with_kill"]
    assert len(result["killed"]) == 1, "no evaluation worker was seen running to kill"
    assert [e["seed"] for e in result["episodes"]] == list(range(1000, 1012))
    assert result["rows"] == [as_json(evaluate("laser", 12, 1000, env_kwargs=KILL_KWARGS))]


def test_env_survives_ray_put_and_a_task(ray_runs: tuple[Path, dict[str, Any]]) -> None:
    assert ray_runs[1]["pickling"] == {"same_after_get": True, "same_in_task": True}


def test_record_bags_hold_the_serial_episodes(
    ray_runs: tuple[Path, dict[str, Any]], tmp_path: Path
) -> None:
    out, results = ray_runs
    result = results["record"]
    assert result["code"] == 0, result["stderr"]
    assert len(result["killed"]) == 1, "no recording worker was seen running to kill"
    bags = sorted((out / "bags").iterdir())
    # One bag per task, named by its seeds: together they tile the seeds, each once, in order.
    named = [re.fullmatch(r"bubblerob_laser_seed(\d+)-(\d+)", b.name) for b in bags]
    spans = sorted((int(m[1]), int(m[2])) for m in named if m)
    assert len(spans) == len(bags) >= 2, [b.name for b in bags]
    assert [s for first, last in spans for s in range(first, last + 1)] == list(range(40, 45))
    seeds, topics = [], Counter[str]()
    for bag in bags:
        summary = read_summary(bag)
        assert not summary.unfinished, bag
        seeds += [episode["seed"] for episode in summary.episodes]
        counts = {t.name: t.count for t in summary.topics}
        assert counts.pop("/tf_static") == 1  # once per bag; every other topic per episode
        topics.update(counts)
        report = replay_bag(bag)
        assert report.ok, str(report)
    serial_args = ["record", *RECORD_ARGS, *RECORD_START, "--no-progress", "--out", str(tmp_path)]
    assert bubblerob(serial_args) == 0
    (serial_bag,) = tmp_path.iterdir()
    serial = read_summary(serial_bag)
    assert seeds == [episode["seed"] for episode in serial.episodes] == list(range(40, 45))
    assert topics == Counter({t.name: t.count for t in serial.topics if t.name != "/tf_static"})
