"""README's "Live on a ROS 2 graph" block as written (set-up lines: CI's, already run)."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import time

from ros2_helpers import DOMAIN_ID, ROOT, require_ros2, ros2_env

HEADING = "## Live on a ROS 2 graph\n"
SET_UP = 3  # venv, pip install -e ".[ros2]", ros2_msgs: those of "Run the tests" (CI runs them)


def _blocks(heading: str) -> list[str]:
    section = (ROOT / "README.md").read_text().split(heading, 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```bash\n(.*?)```", section, flags=re.DOTALL)


def test_readme_ros2_set_up_is_the_one_ci_runs():
    set_up = _blocks(HEADING)[0].splitlines()[:SET_UP]
    tests = _blocks("## Run the tests\n")[-1].splitlines()  # the by-hand steps, after make test
    assert set_up == tests[-1 - SET_UP : -1]
    assert "ros2_msgs" in set_up[-1]


def test_readme_ros2_section_runs(tmp_path):
    require_ros2()
    lines = _blocks(HEADING)[0].splitlines(keepends=True)[SET_UP:]
    script = "set -euo pipefail\n" + "".join(lines)
    assert "ROS_DOMAIN_ID=42" in script
    script = script.replace("ROS_DOMAIN_ID=42", f"ROS_DOMAIN_ID={DOMAIN_ID}")  # this session's
    log = tmp_path / "section.log"
    with log.open("w") as out:
        proc = subprocess.Popen(
            ["bash", "-c", script],
            cwd=ROOT,
            env=ros2_env(),
            stdout=out,
            stderr=subprocess.STDOUT,
            start_new_session=True,  # the background node is stopped with its group
        )
        try:
            code = proc.wait(timeout=120)
        finally:
            try:
                os.killpg(proc.pid, signal.SIGTERM)
                time.sleep(1.0)
                os.killpg(proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
    text = log.read_text()
    assert code == 0, text
    echoed = re.search(r"^([\d.]+) (\d+)$", text, flags=re.MULTILINE)
    assert echoed is not None, text
    assert abs(float(echoed.group(1)) - 0.017453292) < 1e-6 and echoed.group(2) == "360", text
