"""The benchmarks run (smoke only: speed is measured by running them, never by tests).

train_speed.py runs once, with ``--vec-env batched``, in tests/test_vector_bench.py.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize(
    ("script", "expected_rows"),
    [
        ("env_speed.py", ["laser 360, no camera", "engine floor:", "naive floor:", "Ant-v5"]),
        ("record_speed.py", ["mcap", "ros1", "sqlite3"]),
        ("soak.py", ["undetected penetration", "memory growth after warm-up", "PASSED"]),
        ("fast_core.py", ["BubbleRob batch N=64, 2 threads", "one thread to two", "machine:"]),
        ("localisation.py", ["| 0-1 | 2 |", "| 7000-7001 | 2 |", "sim s per CPU s"]),
        ("foxglove_train_speed.py", ["slows training by a median factor", "machine:"]),
        pytest.param(
            "live_speed.py",
            ["| off |", "| 64x64 |", "received msg/s"],
            marks=pytest.mark.skipif(
                not Path("/usr/bin/rosmaster").exists(), reason="needs Debian's ROS 1 (README)"
            ),
        ),
    ],
)
def test_benchmark_prints_its_table(script, expected_rows):
    result = subprocess.run(
        [sys.executable, str(ROOT / "bench" / script), "--quick"],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=ROOT,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    for row in expected_rows:
        assert row in result.stdout, f"{row!r} missing from\n{result.stdout}"
