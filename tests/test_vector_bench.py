"""The batch benchmarks run (smoke only: speed is measured by running them, never by tests)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _run(*args: str) -> str:
    result = subprocess.run(
        [sys.executable, *args],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=ROOT,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    return result.stdout


def test_vector_speed_prints_its_table():
    out = _run(str(ROOT / "bench" / "vector_speed.py"), "--quick")
    for row in ("gym.make, 1 env", "vector_entry_point N=1 (1 threads)", "N=8", "load average"):
        assert row in out


def test_train_speed_prints_its_table_with_the_native_batch_row():
    # The one run of train_speed.py (its default, --vec-env dummy, differs only in part 1's envs).
    out = _run(str(ROOT / "bench" / "train_speed.py"), "--quick", "--vec-env", "batched")
    assert "8 envs, native batch" in out and "batched envs" in out
    for row in ("HalfCheetah-v5, 1 env (anchor)", "2 envs, SubprocVecEnv", "8 envs, DummyVecEnv"):
        assert row in out, f"{row!r} missing from\n{out}"
