"""``bubblerob evaluate``, ``demo`` and ``teleop``: a wrong policy, env or --out is one line.

Run in this process (:mod:`cli_usage`: an exception other than ``SystemExit`` is the traceback a
user would see and fails the test); tests/test_cli_usage.py runs teleop's refusals as a process.
"""

from __future__ import annotations

import pytest
from cli_usage import run

pytest.importorskip("policies")


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["evaluate", "--policy", "nosuch", "--episodes", "1"], "unknown policy 'nosuch'"),
        (["demo", "--policy", "nosuch", "--no-video"], "unknown policy 'nosuch'"),
        (["evaluate", "--policy", "missing.zip", "--episodes", "1"], "missing.zip"),
    ],
)
def test_a_wrong_policy_is_one_line(args, says, capsys):
    result = run(args, capsys)
    assert result.code == 2  # a usage error (issue #38 kind 7)
    assert "Traceback" not in result.err and result.err.count("\n") == 1, result.err
    assert result.err.startswith(f"bubblerob {args[0]}: ") and says in result.err


def test_an_unusable_demo_out_is_one_line(tmp_path, capsys):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a directory")
    result = run(
        [
            "demo",
            "--policy",
            "reactive",
            "--episodes",
            "1",
            "--no-video",
            "--out",
            str(blocker / "x"),
        ],
        capsys,
    )
    assert result.code == 2  # checked before the work, as every output (bubblerob_cli/outputs.py)
    assert "Traceback" not in result.err and result.err.count("\n") == 1, result.err
    assert result.err.startswith("bubblerob demo: ") and str(blocker) in result.err


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["demo", "--env-kwargs", '{"nosuch": 1}', "--no-video"], "unexpected keyword argument"),
        (["demo", "--env", "NoSuch-v0", "--no-video"], "--env NoSuch-v0"),
        (["teleop", "--env-kwargs", '{"action_type": "wheels"}'], "cannot set action_type"),
        (["teleop", "--env-kwargs", '{"nosuch": 1}'], "unexpected keyword argument"),
        # teleop --ros takes --env/--env-kwargs for the node's limits now: a bad one is refused
        # before any ROS master is looked for.
        (["teleop", "--ros", "1", "--env-kwargs", '{"nosuch": 1}'], "unexpected keyword argument"),
    ],
)
def test_a_bad_env_is_one_line_exit_2(args, says, capsys):
    result = run(args, capsys)
    assert result.code == 2, result.err
    assert result.err.count("\n") == 1 and says in result.err, result.err
    assert result.err.startswith(f"bubblerob {args[0]}: ")


def test_demo_makes_the_env_its_env_kwargs_name(tmp_path, capsys):
    kwargs = '{"arena_size": 3.0, "max_episode_steps": 20}'
    result = run(
        ["demo", "--policy", "laser", "--episodes", "1", "--no-video", "--env-kwargs", kwargs,
         "--out", str(tmp_path)],
        capsys,
    )  # fmt: skip
    assert result.code == 0, result.err
    header, row = (line.split() for line in result.out.splitlines()[:2])
    length = row[header.index("length")]
    assert row[0] == "laser" and length == "20"  # the time limit given, not the default 1000
    info = run(["info", str(tmp_path / "bubblerob_demo_laser")], capsys)
    assert info.code == 0 and "arena_size" in info.out and "3.0" in info.out


def test_teleop_will_not_record_over_a_bag(tmp_path, capsys):
    (tmp_path / "drive").mkdir()
    result = run(["teleop", "--record", str(tmp_path / "drive")], capsys)
    assert result.code == 2, result.err
    drive = tmp_path / "drive"
    says = f"bag {drive} already exists; pass --overwrite to replace it"
    assert result.err == f"bubblerob teleop: {says}\n"
