"""``bubblerob evaluate``, ``demo`` and ``teleop``: a wrong policy, env or --out is one line."""

from __future__ import annotations

import subprocess
import sys

import pytest

pytest.importorskip("policies")


def _bubblerob(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "bubblerob_env.cli", *args],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["evaluate", "--policy", "nosuch", "--episodes", "1"], "unknown policy 'nosuch'"),
        (["demo", "--policy", "nosuch", "--no-video"], "unknown policy 'nosuch'"),
        (["evaluate", "--policy", "missing.zip", "--episodes", "1"], "missing.zip"),
    ],
)
def test_a_wrong_policy_is_one_line(args, says):
    result = _bubblerob(*args)
    assert result.returncode == 1
    assert "Traceback" not in result.stderr and result.stderr.count("\n") == 1, result.stderr
    assert result.stderr.startswith(f"bubblerob {args[0]}: ") and says in result.stderr


def test_an_unusable_demo_out_is_one_line(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a directory")
    result = _bubblerob(
        "demo", "--policy", "reactive", "--episodes", "1", "--no-video", "--out", str(blocker / "x")
    )
    assert result.returncode == 1
    assert "Traceback" not in result.stderr, result.stderr
    assert result.stderr.startswith("bubblerob demo: ") and str(blocker) in result.stderr


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["demo", "--env-kwargs", '{"nosuch": 1}', "--no-video"], "unexpected keyword argument"),
        (["demo", "--env", "NoSuch-v0", "--no-video"], "--env NoSuch-v0"),
        (["teleop", "--env-kwargs", '{"action_type": "wheels"}'], "cannot set action_type"),
        (["teleop", "--env-kwargs", '{"nosuch": 1}'], "unexpected keyword argument"),
        (["teleop", "--ros", "1", "--env-kwargs", '{"arena_size": 3}'], "local simulation"),
    ],
)
def test_a_bad_env_is_one_line_exit_2(args, says):
    result = _bubblerob(*args)
    assert result.returncode == 2, result.stderr
    assert result.stderr.count("\n") == 1 and says in result.stderr, result.stderr
    assert result.stderr.startswith(f"bubblerob {args[0]}: ")


def test_demo_makes_the_env_its_env_kwargs_name(tmp_path):
    kwargs = '{"arena_size": 3.0, "max_episode_steps": 20}'
    result = _bubblerob(
        "demo", "--policy", "laser", "--episodes", "1", "--no-video", "--env-kwargs", kwargs,
        "--out", str(tmp_path),
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    row = result.stdout.splitlines()[1].split()
    assert row[0] == "laser" and row[5] == "20"  # the time limit given, not the default 1000
    info = _bubblerob("info", str(tmp_path / "bubblerob_demo_laser"))
    assert info.returncode == 0 and "arena_size" in info.stdout and "3.0" in info.stdout


def test_teleop_will_not_record_over_a_bag(tmp_path):
    (tmp_path / "drive").mkdir()
    result = _bubblerob("teleop", "--record", str(tmp_path / "drive"))
    assert result.returncode == 2, result.stderr
    assert (
        result.stderr
        == f"bubblerob teleop: bag {tmp_path / 'drive'} already exists; --record another path\n"
    )
