"""bench/ray_evaluate.py runs (a smoke run: speed is measured by running it, never by tests)."""

from __future__ import annotations

import subprocess
import sys

from ray_helpers import ROOT, need_netns


def test_ray_benchmark_prints_its_table() -> None:
    need_netns()
    done = subprocess.run(
        [sys.executable, str(ROOT / "bench" / "ray_evaluate.py"), "--quick"],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-4000:]
    for row in (
        "| serial |",
        "| --ray local, cluster up |",
        "cluster start-up:",
        "episodes equal: yes",
    ):
        assert row in done.stdout, f"{row!r} missing from\n{done.stdout}"
