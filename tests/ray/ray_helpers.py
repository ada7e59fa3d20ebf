"""Running Ray in a network namespace of its own, with only loopback up.

Ray binds the machine's own address even when told 127.0.0.1, so every Ray part of the tests runs
in a child process under ``unshare -n`` (a new network namespace: no interface but ``lo``, which
is brought up). Tests that need it skip, with the reason, where ``unshare`` cannot make one.
"""

from __future__ import annotations

import functools
import json
import shlex
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
SCENARIOS = HERE / "scenarios.py"


@functools.cache
def netns_problem() -> str | None:
    """Why a loopback-only network namespace cannot be made here, or ``None``."""
    for tool in ("unshare", "ip"):
        if shutil.which(tool) is None:
            return f"Ray tests need {tool!r} (util-linux, iproute2) for a loopback-only namespace"
    try:
        made = subprocess.run(
            ["unshare", "-n", "ip", "link", "set", "lo", "up"],
            capture_output=True,
            text=True,
            timeout=20,
        )
    except subprocess.TimeoutExpired:
        return "unshare -n did not answer in 20 s"
    if made.returncode != 0:
        return f"unshare -n cannot make a network namespace here: {made.stderr.strip()}"
    return None


def need_netns() -> None:
    """Skip the calling test unless Ray is installed and a namespace can be made."""
    pytest.importorskip("ray", reason="the [ray] extra is not installed")
    problem = netns_problem()
    if problem is not None:
        pytest.skip(problem)


def in_netns(
    argv: list[str], timeout_s: float, cwd: Path = ROOT
) -> subprocess.CompletedProcess[str]:
    """Run ``argv`` in a new network namespace with only loopback up; bounded by ``timeout_s``."""
    script = "ip link set lo up && exec " + shlex.join(argv)
    return subprocess.run(
        ["unshare", "-n", "bash", "-c", script],
        capture_output=True,
        text=True,
        timeout=timeout_s,
        cwd=cwd,
    )


def run_scenarios(
    wanted: dict[str, dict[str, Any]], out: Path, timeout_s: float = 300
) -> dict[str, Any]:
    """Run scenarios.py's ``{name: params}`` in one namespace (one local cluster); their results."""
    result_file = out / "scenarios.json"
    argv = [sys.executable, str(SCENARIOS), str(result_file), json.dumps(wanted)]
    done = in_netns(argv, timeout_s)
    assert done.returncode == 0, (
        f"{list(wanted)} failed:\n{done.stdout[-3000:]}\n{done.stderr[-6000:]}"
    )
    results: dict[str, Any] = json.loads(result_file.read_text())
    return results


def bubblerob_in_netns(args: list[str], timeout_s: float = 180) -> subprocess.CompletedProcess[str]:
    """``bubblerob ARGS`` in a namespace (the CLI of this interpreter's environment)."""
    return in_netns([sys.executable, "-m", "bubblerob_cli", *args], timeout_s)


def as_json(row: Any) -> Any:
    """A serial evaluation row as a scenario's process sends rows back: through JSON (tuples
    become lists)."""
    import dataclasses

    return json.loads(json.dumps(dataclasses.asdict(row)))
