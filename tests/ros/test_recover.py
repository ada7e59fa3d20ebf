"""``bubblerob recover``: a SIGKILLed recording becomes a finished bag that other tools accept."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap

import pytest
from mcap.reader import make_reader
from ros_helpers import missing_debian_ros, read_all, run_debian

from bubblerob_cli import main as cli
from bubblerob_env.ros.readback.replay import replay_bag
from bubblerob_env.ros.readback.summary import read_summary

CHILD = textwrap.dedent(
    """
    import os, signal, sys
    import gymnasium as gym
    import numpy as np
    import bubblerob_env
    from bubblerob_env.ros import RosBagRecorder

    env = RosBagRecorder(
        gym.make("BubbleRob-v0", max_episode_steps=20), sys.argv[1], format=sys.argv[2],
        distro=sys.argv[3], start_time=1.7e9,
    )
    env.reset(seed=0)
    for step in range(1, 71):
        _, _, terminated, truncated, _ = env.step(np.array([0.6, 0.5], dtype=np.float32))
        if terminated or truncated:
            env.reset()
    os.kill(os.getpid(), signal.SIGKILL)  # mid-episode: three ended, the fourth did not
    """
)


def _killed(tmp_path, fmt, distro):
    script = tmp_path / "child.py"
    script.write_text(CHILD)
    bag = tmp_path / ("bag.bag" if fmt == "ros1" else "bag")
    child = subprocess.run([sys.executable, str(script), str(bag), fmt, distro], check=False)
    assert child.returncode == -signal.SIGKILL
    return bag


@pytest.mark.parametrize(
    ("fmt", "distro"),
    [("mcap", "jazzy"), ("mcap", "humble"), ("sqlite3", "jazzy"), ("ros1", "noetic")],
)
def test_recover_finishes_a_killed_recording(tmp_path, capsys, fmt, distro):
    bag = _killed(tmp_path, fmt, distro)
    before = read_summary(bag)
    assert before.unfinished and len(before.episodes) == 3
    assert cli.main(["recover", str(bag)]) == 0
    out = capsys.readouterr().out
    assert f"recovered 3 complete episode(s), {before.message_count} messages into {bag}" in out
    after = read_summary(bag)  # now through rosbags' own readers
    assert not after.unfinished and after.episodes == before.episodes
    assert after.topics == before.topics and after.start_ns == 1.7e18
    assert replay_bag(bag).ok
    assert (tmp_path / f"{bag.name}.orig").exists()  # the original, untouched
    names = sorted(p.name for p in tmp_path.iterdir())  # the killed writer's lock is gone too
    assert names == sorted(["child.py", bag.name, f"{bag.name}.orig"])
    if fmt == "mcap":
        with next(bag.glob("*.mcap")).open("rb") as stream:
            summary = make_reader(stream, validate_crcs=True).get_summary()
        assert summary is not None and summary.statistics.message_count == after.message_count
    if fmt == "ros1" and missing_debian_ros() is None:
        result = run_debian("/usr/bin/rosbag", "check", str(bag))
        assert result.returncode == 0 and "does not need any migrations" in result.stdout
    assert cli.main(["recover", str(bag)]) == 2  # finished now
    assert "is a finished bag and reads whole: nothing to recover" in capsys.readouterr().err
    assert len(read_all(bag)["/cmd_vel"]) == 60
