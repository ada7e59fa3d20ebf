"""``bubblerob evaluate`` and ``demo``: a wrong policy or an unusable --out is one line, exit 1."""

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
