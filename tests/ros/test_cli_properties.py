"""Property-based tests of the bag subcommands' arguments (Hypothesis), valid ones included.

``record``, ``replay``, ``map`` and ``info`` are cheap on a small bag, so here every drawn value is
run, valid or not: a valid set does what it says (exit 0, and the result checked against an
independent reading of the bag), an invalid one is exit 2 and one line naming the option. CI runs
a fixed derandomised budget; ``BUBBLEROB_FUZZ_SCALE`` multiplies it (``bench/fuzz.py``).
"""

from __future__ import annotations

import os
import re
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rosbags.highlevel import AnyReader

from bubblerob_env.ros.readback.summary import read_summary

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # tests/: cli_usage
from cli_usage import run  # noqa: E402

pytest.importorskip("policies")

SCALE = int(os.environ.get("BUBBLEROB_FUZZ_SCALE", "1"))
BUDGET = settings(
    max_examples=12 * SCALE,
    derandomize=SCALE == 1,
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
EPISODES = 3


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    import gymnasium as gym
    from ros_helpers import drive

    from bubblerob_env.ros import RosBagRecorder

    env = gym.make("BubbleRob-v0", max_episode_steps=6, laser_num_rays=16)
    with RosBagRecorder(env, tmp_path_factory.mktemp("bag") / "bag") as recorder:
        drive(recorder, EPISODES, 6)
    return recorder.bag_paths[0]


@BUDGET
@given(episodes=st.one_of(st.none(), st.integers(-(2**64), 6)))
def test_replay_episodes(bag, capsys, episodes):
    done = run(
        ["replay", str(bag), *([] if episodes is None else ["--episodes", str(episodes)])], capsys
    )
    if episodes is not None and episodes < 1:
        assert done.code == 2 and "--episodes must be at least 1" in done.one_line()
        return
    assert done.code == 0, done.err
    replayed = EPISODES if episodes is None else min(episodes, EPISODES)
    assert f": {replayed} episode(s), " in done.out and "replay matches the recording" in done.out


@BUDGET
@given(
    episode=st.integers(-(2**64), 5),
    resolution=st.one_of(
        st.sampled_from(["0.05", "0", "-1", "nan", "inf", "x", "2"]), st.floats(0.001, 1.5).map(str)
    ),  # fmt: skip
)
def test_map_episode_and_resolution(bag, capsys, tmp_path_factory, episode, resolution):
    png = tmp_path_factory.mktemp("map") / "map.png"
    argv = ["map", str(bag), "--episode", str(episode), "--resolution", resolution]
    done = run([*argv, "--out", str(png)], capsys)
    try:
        valid_resolution = 0.005 <= float(resolution) <= 1
    except ValueError:
        valid_resolution = False
    if not valid_resolution or not 0 <= episode < EPISODES:
        assert done.code == 2 and done.one_line().startswith("bubblerob map: ")
        assert ("--episode" in done.err) or ("resolution" in done.err), done.err
        assert not png.exists()
        return
    assert done.code == 0, done.err
    assert png.stat().st_size > 0 and "IoU of occupied cells" in done.out


@BUDGET
@given(
    episodes=st.integers(-3, 2),
    max_steps=st.integers(-3, 3),
    seed=st.one_of(st.integers(-(2**64), -1), st.integers(0, 2**63 - 3), st.just(2**63)),
    namespace=st.sampled_from(["", "robot2", "/r/sub/", "bad name!", "a//b", "x__y", "9lives"]),
)
def test_record_arguments(capsys, tmp_path_factory, episodes, max_steps, seed, namespace):
    out = tmp_path_factory.mktemp("record")
    argv = ["record", "--policy", "reactive", "--episodes", str(episodes), "--no-progress"]
    argv += ["--max-steps", str(max_steps), "--seed", str(seed), "--out", str(out)]
    done = run([*argv, *(["--namespace", namespace] if namespace else [])], capsys)
    ros_name = namespace.strip("/")
    # ROS 1 graph names and ROS 2 topic names both: letter-led word tokens, no "__" (ROS 2).
    token = r"[A-Za-z][A-Za-z0-9_]*"
    valid_namespace = not ros_name or (
        re.fullmatch(f"{token}(/{token})*", ros_name) is not None and "__" not in ros_name
    )
    valid = episodes >= 1 and max_steps >= 1 and 0 <= seed <= 2**63 - episodes
    if not (valid and valid_namespace):
        assert done.code == 2 and done.one_line().startswith("bubblerob record: "), done.err
        assert not any(out.iterdir())
        return
    assert done.code == 0, done.err
    (path,) = [p for p in out.iterdir() if not p.name.endswith(".lock")]
    summary = read_summary(path)
    assert [e["seed"] for e in summary.episodes] == [seed + k for k in range(episodes)]
    with AnyReader([path]) as reader:  # rosbags' own reader, an independent reading
        topics = {c.topic for c in reader.connections}
    prefix = f"/{ros_name}" if ros_name else ""
    assert f"{prefix}/scan" in topics and f"{prefix}/cmd_vel" in topics
