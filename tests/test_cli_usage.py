"""Every subcommand's bad arguments (issue #23): one line naming the value, exit 2, nothing done.

Run in this process (:mod:`cli_usage`), so each case costs milliseconds: the checks come before
any env, bag, ROS graph or training starts, which these tests also hold (no file is written).
"""

from __future__ import annotations

import subprocess
import sys

import pytest
from cli_usage import run

pytest.importorskip("policies")

REFUSED = [
    # (argv, what the line must say)
    (["record", "--policy", "reactive", "--seed", "-1"], "--seed must be from 0 to"),
    (["record", "--policy", "reactive", "--max-steps", "0"], "--max-steps must be at least 1"),
    (["record", "--policy", "reactive", "--episodes", "0"], "--episodes must be at least 1"),
    (["record", "--policy", "reactive", "--namespace", "bad name!"], "is not a valid ROS name"),
    (["record", "--policy", "reactive", "--namespace", "a//b"], "is not a valid ROS name"),
    (["record", "--policy", "reactive", "--namespace", "robot__2"], "is not a valid ROS name"),
    (["record", "--policy", "reactive", "--namespace", "2robot"], "is not a valid ROS name"),
    (["replay", "BAG", "--episodes", "0"], "--episodes must be at least 1, got 0"),
    (["replay", "BAG", "--episodes", "-1"], "--episodes must be at least 1, got -1"),
    (["map", "BAG", "--episode", "-1"], "--episode must be an episode index >= 0, got -1"),
    (["map", "BAG", "--resolution", "0"], "resolution"),
    (["demo", "--episodes", "0", "--no-video"], "--episodes must be >= 1, got 0"),
    (["demo", "--seed", "-1", "--no-video"], "--seed must be from 0 to"),
    (["evaluate", "--policy", "reactive", "--seed", "-1"], "--seed must be from 0 to"),
    (["evaluate", "--policy", "reactive", "--episodes", "0"], "--episodes must be >= 1"),
    (["evaluate", "--policy", "reactive", "--env", "Bogus-v9"], "Bogus"),
    (["evaluate", "--policy", "reactive", "--env-kwargs", '{"camera": "no"}'], "camera must be"),
    (["evaluate", "--policy", "reactive", "--env-kwargs", '{"arena_size": 1e12}'], "arena_size"),
    (["evaluate", "--policy", "reactive", "--env-kwargs", '{"nope": 1}'], "'nope'"),
    (["evaluate", "--policy", "reactive", "--env-kwargs", "[1]"], "must be a JSON object"),
    (["evaluate", "--policy", "reactive", "--video", "/proc/no/v.mp4"], "cannot create its folder"),
    (["node", "--seed", "-1"], "--seed must be an int from 0"),
    (["node", "--steps", "0"], "--steps must be at least 1"),
    (["node", "--namespace", "bad name!"], "is not a valid ROS name"),
    (["train", "--n-envs", "0"], "--n-envs must be an int >= 1, got 0"),
    (["train", "--timesteps", "0"], "--timesteps must be an int >= 1, got 0"),
    (["train", "--timesteps", "-1"], "--timesteps must be an int >= 1, got -1"),
    (["train", "--timesteps", "256", "--eval-freq", "0"], "--eval-freq must be an int >= 1"),
    (["train", "--torch-threads", "0"], "--torch-threads must be an int >= 1"),
    (["train", "--seed", "-1"], "--seed must be an int from 0 to 4294967295"),
    (["train", "--seed", "993"], "training seeds are 0-999 (policies/protocol.py): use --seed"),
    (
        ["evaluate", "--policy", "laser", "--split", "test", "--seed", "5"],
        "--split test: test seeds are 100000-199999; seeds 5-104 are not all in it",
    ),
    (
        ["evaluate", "--policy", "laser", "--split", "validation", "--seed", "99999"],
        "validation seeds are 1000-99999; seeds 99999-100098 are not all in it",
    ),
    (["train", "--set", "n_steps=-1"], "hyperparameter n_steps must be an int >= 1, got -1"),
    (["train", "--set", "gamma=1.5"], "hyperparameter gamma must be a number in (0, 1]"),
    (["train", "--set", "n_steps=["], "--set n_steps=[: the value is"),
    (["train", "--set", "vec_env=dummy"], "use the command-line option --vec-env"),
    (["train", "--env", "Bogus-v9"], "no ppo hyperparameters for 'Bogus-v9'"),
    (["train", "--out", "/proc/no/run"], "--out /proc/no/run:"),
    (["info", "--json"], "error: the following arguments are required: bag"),
    (["replay", "BAG", "--episodes", "x"], "invalid int value: 'x'"),
]


@pytest.mark.parametrize(("argv", "says"), REFUSED, ids=[" ".join(a) for a, _ in REFUSED])
def test_a_bad_argument_is_one_line_and_exit_2(argv, says, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)  # whatever a refused command might write would land here
    (tmp_path / "BAG").mkdir()
    argv = [*argv, *(["--out", str(tmp_path / "out")] if argv[0] == "record" else [])]
    done = run(argv, capsys)
    line = done.one_line()
    assert done.code == 2, (done.code, done.err)
    assert line.startswith(f"bubblerob {argv[0]}: ") and says in line, line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["BAG"]  # nothing written
    assert not any((tmp_path / "BAG").iterdir())


def test_a_damaged_policy_file_is_one_line_naming_it(tmp_path, capsys):
    for name, junk in (("policy.zip", b"not a zip"), ("policy.onnx", b"not a protobuf\x00")):
        path = tmp_path / name
        path.write_bytes(junk)
        for argv in (
            ["evaluate", "--policy", str(path), "--episodes", "1"],
            ["demo", "--policy", str(path), "--no-video", "--out", str(tmp_path / "demo")],
        ):
            done = run(argv, capsys)
            line = done.one_line()
            assert done.code == 2 and f"cannot load the policy file {path}" in line, line
        record = ["record", "--policy", str(path), "--out", str(tmp_path / "bags")]
        done = run(record, capsys)  # record's refusals are all exit 2
        assert done.code == 2 and f"cannot load the policy file {path}" in done.one_line()
    assert not (tmp_path / "demo").exists() and not (tmp_path / "bags").exists()


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["teleop", "--seed", "-1"], "--seed must be from 0"),
        (["teleop"], "needs a terminal"),
        (["teleop", "--start-pose", "99", "0", "0"], "start_pose"),
    ],
)
def test_teleop_mistakes_are_one_line_without_a_terminal(argv, says):
    result = subprocess.run(
        [sys.executable, "-m", "bubblerob_cli", *argv],
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and says in lines[0] and lines[0].startswith("bubblerob teleop: ")
