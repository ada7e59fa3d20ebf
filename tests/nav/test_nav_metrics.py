"""SPL and the other navigation metrics, the Nav controllers, and ``evaluate`` on a Nav env."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from cli_usage import run

import bubblerob_env  # noqa: F401  (registers the ids)
from policies import PolicyEnvMismatchError, load_policy
from policies.evaluation import summarize_records
from policies.navigation_metrics import format_nav_table, nav_metrics, spl
from policies.protocol import wilson_interval


def _record(outcome, shortest, driven, time=10.0, v_max=0.4):
    return {"outcome": outcome, "shortest": shortest, "driven": driven, "time": time,
            "v_max": v_max, "spl": spl(outcome == "success", shortest, driven)}  # fmt: skip


def _polyline_length(points):
    return sum(math.dist(a, b) for a, b in zip(points[:-1], points[1:], strict=True))


def test_spl_is_one_along_the_shortest_path_and_less_on_a_detour():
    env = gym.make("BubbleRobNav-v0")
    _, info = env.reset(seed=3)
    path = [tuple(p) for p in env.unwrapped.problem.path]
    shortest = info["shortest_path_length"]
    assert _polyline_length(path) == pytest.approx(shortest)
    assert spl(True, shortest, _polyline_length(path)) == 1.0
    # A detour: the same start and goal by a point 1 m off the straight line's middle.
    (sx, sy), (gx, gy) = path[0], path[-1]
    span = math.dist(path[0], path[-1])
    mid = ((sx + gx) / 2 - (gy - sy) / span, (sy + gy) / 2 + (gx - sx) / span)
    detour = _polyline_length([path[0], mid, path[-1]])
    assert detour > shortest
    assert spl(True, shortest, detour) == pytest.approx(shortest / detour)
    assert spl(True, shortest, detour) < 1.0
    assert spl(False, shortest, shortest) == 0.0


def test_metrics_of_records():
    records = [
        _record("success", 2.0, 2.0, time=5.0),  # the ideal: 2 m at 0.4 m/s is 5 s
        _record("success", 2.0, 3.0, time=10.0),
        _record("collision", 2.0, 1.0),
        _record("timeout", 2.0, 4.0, time=50.0),
    ]
    m = nav_metrics(records)
    assert m.counts == {"success": 2, "collision": 1, "timeout": 1}
    assert m.spl == pytest.approx((1.0 + 2.0 / 3.0) / 4)
    assert m.extra_time == pytest.approx((0.0 + 1.0) / 2)
    assert m.extra_distance == pytest.approx((0.0 + 0.5) / 2)
    assert m.mean_speed == pytest.approx((0.4 + 0.3) / 2)
    assert m.interval("collision") == wilson_interval(1, 4)
    assert nav_metrics([{"seed": 1}]) is None  # not a Nav episode: the plain table
    failed = nav_metrics([_record("timeout", 2.0, 1.0)])
    assert failed.spl == 0.0 and math.isnan(failed.extra_time)


@pytest.mark.parametrize("name", ["navigator", "pursuit"])
@pytest.mark.parametrize("obs_mode", ["dict", "flat"])
def test_nav_controllers_reach_goals(name, obs_mode):
    env = gym.make("BubbleRobNav-v0", obs_mode=obs_mode)
    policy = load_policy(name, env)
    for seed in (1000, 1001):
        obs, _ = env.reset(seed=seed)
        policy.reset()
        for _ in range(1000):
            obs, _, terminated, truncated, info = env.step(policy.predict(obs)[0])
            if terminated or truncated:
                break
        assert info["is_success"], (name, seed)


def test_nav_controllers_refuse_the_wandering_env():
    with pytest.raises(PolicyEnvMismatchError, match="needs a Nav env"):
        load_policy("navigator", gym.make("BubbleRob-v0"))


def test_navigator_takes_batches():
    env = gym.make("BubbleRobNav-v0")
    policy = load_policy("navigator", env)
    obs, _ = env.reset(seed=0)
    batch = {key: np.stack([value, value]) for key, value in obs.items()}
    actions, _ = policy.predict(batch, episode_start=np.array([True, True]))
    single, _ = policy.predict(obs, episode_start=np.array([True]))
    assert actions.shape == (2, 2) and np.allclose(actions, single[None])


def test_evaluate_on_a_nav_env_prints_the_navigation_metrics(tmp_path, capsys):
    per_episode = tmp_path / "episodes.json"
    command = ["evaluate", "--env", "BubbleRobNav-v0", "--policy", "navigator", "--policy",
               "pursuit", "--episodes", "2", "--split", "test", "--per-episode",
               str(per_episode)]  # fmt: skip
    result = run(command, capsys)
    assert result.code == 0, result.err
    lines = result.out.splitlines()
    for column in ("success (95% CI)", "collision (95% CI)", "timeout (95% CI)", "SPL",
                   "extra time", "extra distance", "speed m/s"):  # fmt: skip
        assert column in lines[0]
    assert lines[1].startswith("navigator") and lines[2].startswith("pursuit")
    episodes = json.loads(per_episode.read_text())
    first = episodes["navigator"][0]
    assert first["seed"] == 100_000  # the test split's first seed
    assert {"outcome", "goal", "shortest", "driven", "time", "spl"} <= set(first)
    # README's measured episodes are these: the same seeds give the same records.
    root = Path(__file__).resolve().parents[2]
    measured = json.loads((root / "docs" / "results" / "nav_bubblerob_test.json").read_text())
    for name in ("navigator", "pursuit"):
        assert episodes[name] == measured[name][:2]


RESULTS = {
    "BubbleRobNav-v0": "nav_bubblerob_test.json",
    "PioneerP3DXNav-v0": "nav_pioneer_test.json",
    "20-30 obstacles": "nav_crowded_test.json",
    "BubbleRobNav-v0, 1000 episodes": "nav_policy_test.json",
}


def test_readme_navigation_table_is_its_per_episode_files():
    root = Path(__file__).resolve().parents[2]
    readme = (root / "README.md").read_text()
    section = readme.split("## Go somewhere: navigation\n", 1)[1].split("\n## ", 1)[0]
    shown = [
        [cell.strip() for cell in line.strip("|").split("|")]
        for line in section.splitlines()
        if line.startswith("| ") and not line.startswith("| env ")
    ]
    expected = []
    for label, name in RESULTS.items():
        episodes = json.loads((root / "docs" / "results" / name).read_text())
        rows = [(policy, summarize_records(policy, records).navigation)
                for policy, records in episodes.items()]  # fmt: skip
        for line in format_nav_table(rows, markdown=True).splitlines()[2:]:
            cells = [cell.strip() for cell in line.strip("|").split("|")]
            expected.append([label, cells[0], *cells[2:]])  # README leaves out "episodes"
    assert shown == expected


def test_nav_figure_script_draws_the_picture(tmp_path):
    out = tmp_path / "nav.png"
    script = Path(__file__).resolve().parents[2] / "docs" / "make_nav_figure.py"
    subprocess.run([sys.executable, str(script), str(out)], check=True, timeout=300)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and out.stat().st_size > 20_000
