"""Driving ``bubblerob teleop --ros N`` in a real terminal (tmux), for tests/live and tests/live2.

Imported as a plain module (``tests/`` is on ``sys.path``). The oracle is the node's own ``/odom``,
read by a separate client of the test's: ``w w w`` (0.3 of the top speed forward) must move the
robot, started at the centre facing +y, along +y (its heading) and not sideways; space must stop
it.
"""

from __future__ import annotations

import math
import re
import subprocess
import time
from typing import Any


def tmux(*args: str) -> str:
    return subprocess.run(
        ["tmux", *args], check=True, capture_output=True, text=True, timeout=30
    ).stdout


def screen_until(session: str, pattern: str, timeout: float, at_least: float = -math.inf) -> Any:
    """The pane's text once ``pattern`` matches it (or at the timeout), and the match.

    With ``at_least``, the match's first group must also be a number at least that large.
    """
    end = time.monotonic() + timeout
    while True:
        text = tmux("capture-pane", "-p", "-t", session)
        match = re.search(pattern, text)
        if match and match.groups() and float(match.group(1)) < at_least:
            match = None
        if match or time.monotonic() > end:
            return text, match
        time.sleep(0.1)


def drive_in_tmux(command: str, session: str, odom: Any) -> dict[str, Any]:
    """Run ``command`` (a teleop) in tmux: w w w, until the odom y >= 0.4, space, q."""
    tmux("new-session", "-d", "-s", session, "-x", "200", "-y", "20", command + "; sleep 30")
    try:
        text, _ = screen_until(session, r"pose x=", 60)
        assert "BubbleRob teleop over ROS" in text and "collisions 0" in text, text
        before = odom()
        tmux("send-keys", "-t", session, "w", "w", "w")  # forward 0.3 of 0.4 m/s
        text, _ = screen_until(session, r"pose x=\S+ y=(\S+)", 60, at_least=0.4)  # about 3 s
        assert "cmd lin +0.3 ang +0.0" in text, text
        status = text
        moving = odom()
        tmux("send-keys", "-t", session, "Space")
        time.sleep(1.0)
        stopped = odom()
        time.sleep(1.0)
        still = odom()
        tmux("send-keys", "-t", session, "q")
        text, final = screen_until(session, r"final pose: x=(\S+) y=(\S+) yaw=(\S+)", 30)
    finally:
        subprocess.run(["tmux", "kill-session", "-t", session], check=False, timeout=30)
    assert final, text
    return {
        "before": before, "moving": moving, "stopped": stopped, "still": still, "text": text,
        "status": status,
    }  # fmt: skip


def check_drive(result: dict[str, Any]) -> None:
    before, moving, stopped, still = (result[k] for k in ("before", "moving", "stopped", "still"))
    assert abs(before["x"]) < 1e-3 and abs(before["y"]) < 1e-3, before
    assert moving["y"] - before["y"] > 0.3, result  # forward = the heading, +y
    assert abs(moving["x"] - before["x"]) < 0.1 * (moving["y"] - before["y"]), result
    assert moving["vx"] > 0.05, moving
    assert abs(still["vx"]) < 0.01 and abs(still["wz"]) < 0.01, still
    assert math.hypot(still["x"] - stopped["x"], still["y"] - stopped["y"]) < 0.005, result
    assert abs(still["yaw"] - math.pi / 2) < 0.1, still
    # The status line while driving: the node's measured speed and nearest laser reading (the
    # north wall, less than 2 m ahead, is the nearest thing in an arena without obstacles).
    speed = float(re.search(r"speed ([+-][\d.]+) m/s", result["status"]).group(1))
    nearest = float(re.search(r"nearest ([\d.]+) m", result["status"]).group(1))
    assert speed > 0.05 and 1.0 < nearest < 2.0, result["status"]
