"""``bubblerob record``, ``info`` and ``replay``."""

from __future__ import annotations

import json

import numpy as np
import pytest

from bubblerob_cli import main as cli
from bubblerob_cli import record as ros_cli


class Forward:
    """A tiny stand-in policy with SB3's ``predict``."""

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        return np.array([0.7, 0.6], dtype=np.float32), state


@pytest.fixture
def forward_policy(monkeypatch):
    monkeypatch.setattr(ros_cli, "_load_policy", lambda name, env, seed: Forward())


def test_record_info_replay(tmp_path, capsys, forward_policy):
    argv = ["record", "--policy", "forward", "--episodes", "2", "--seed", "7"]
    argv += ["--format", "ros1", "--compression", "bz2", "--max-steps", "6"]
    argv += ["--start-time", "2024-05-01T12:00:00Z"]
    assert cli.main([*argv, "--no-progress", "--out", str(tmp_path)]) == 0
    bag = tmp_path / "bubblerob_forward_seed7.bag"
    assert f"to {bag}" in capsys.readouterr().out

    assert cli.main(["info", str(bag)]) == 0
    out = capsys.readouterr().out
    assert "/scan" in out and "sensor_msgs/msg/LaserScan" in out
    assert "start/end: 2024-05-01 12:00:00.000 UTC (1714564800.000 s) / " in out
    assert "#0: start +0.000 s, seed 7, policy forward" in out
    assert "#1: start +0.350 s, seed 8" in out

    assert cli.main(["info", str(bag), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    counts = {t["name"]: t["count"] for t in summary["topics"]}
    assert counts["/cmd_vel"] == 12 and counts["/scan"] == 14
    assert summary["duration_s"] == pytest.approx(0.65)
    assert summary["start_ns"] == 1714564800 * 10**9

    assert cli.main(["replay", str(bag)]) == 0
    out = capsys.readouterr().out
    assert "replay matches the recording" in out
    # info's count is replay's compared messages plus those it reads but does not re-simulate.
    assert f"({summary['message_count']} in all: 2 /bubblerob/episode, 2 /map, 1 /tf_static" in out
    compared = int(out.split(" messages: replay matches")[0].rsplit(" ", 1)[1])
    assert compared == summary["message_count"] - 5


def test_record_refuses_to_overwrite_and_says_how(tmp_path, capsys, forward_policy):
    argv = ["record", "--policy", "forward", "--max-steps", "2", "--no-progress"]
    argv += ["--out", str(tmp_path)]
    assert cli.main(argv) == 0
    assert cli.main(argv) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert cli.main([*argv, "--overwrite"]) == 0


def test_record_with_a_builtin_policy(tmp_path, capsys):
    pytest.importorskip("policies")
    argv = ["record", "--policy", "reactive", "--max-steps", "5", "--no-progress"]
    assert cli.main([*argv, "--out", str(tmp_path)]) == 0
    assert (tmp_path / "bubblerob_reactive_seed0" / "metadata.yaml").exists()


def test_replay_of_a_missing_bag_fails_cleanly(tmp_path, capsys):
    assert cli.main(["replay", str(tmp_path / "nothing")]) == 2
    assert "no bag at" in capsys.readouterr().err


@pytest.mark.parametrize("command", ["info", "replay"])
@pytest.mark.parametrize(
    ("name", "content", "says"),
    [
        ("notes.txt", b"hello", "is not a bag"),
        ("fake.bag", b"hello", "is not a ROS 1 bag"),
        ("fake/bag.mcap", b"hello", "is not an MCAP file"),
        ("fake/bag.db3", b"hello" * 300, "is not a rosbag2 sqlite3 file"),
        ("empty_dir/", b"", "is not a bag"),
    ],
)
def test_a_file_that_is_no_bag_gets_one_line(tmp_path, capsys, command, name, content, says):
    path = tmp_path / name
    if name.endswith("/"):
        path.mkdir()
    else:
        path.parent.mkdir(exist_ok=True)
        path.write_bytes(content)
    assert cli.main([command, str(path)]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1, captured.err
    assert captured.err.startswith(f"bubblerob {command}: ") and says in captured.err
