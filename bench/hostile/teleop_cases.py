"""The campaign's ``teleop`` cases: refused in one line before a terminal or a bag is needed.

The runner's standard output is a pipe, so ``teleop`` never finds a terminal there: every case
is a refusal, and the one that is valid but for the terminal says so.
"""

from __future__ import annotations

from typing import Any

__all__ = ["teleop_cases"]

REFUSED: list[tuple[list[str], str]] = [
    ([], "terminal"),
    (["--start-pose", "100", "0", "0"], "start_pose"),
    (["--start-pose", "nan", "0", "0"], "start_pose"),
    (["--start-pose", "0", "0"], "--start-pose"),
    (["--num-obstacles", "5", "2"], "num_obstacles"),
    (["--seed", "-1"], "--seed"),
    (["--env", "Bogus-v9"], "Bogus-v9"),
    (["--env-kwargs", '{"action_type": "wheels"}'], "action_type"),
    (["--ros", "1", "--record", "drive"], "--record"),
    (["--ros", "1", "--start-pose", "0", "0", "0"], "--start-pose"),
    (["--ros", "1", "--overwrite"], "--overwrite"),
    (["--robots", "2", "--record", "drive"], "--record"),
    (["--record", "{bag}"], "already exists"),
]


def teleop_cases() -> list[dict[str, Any]]:
    """Kinds 0 and 5: teleop's hostile options, and teleop without a terminal."""
    return [
        {
            "id": f"teleop-{k}",
            "kind": 5 if says == "terminal" else 0,
            "argv": ["teleop", *extra],
            "expect": "refuse",
            "exit": 2,
            "stderr_has": [says],
            "absent": ["drive"],
            "timeout": 60,
        }
        for k, (extra, says) in enumerate(REFUSED)
    ]
