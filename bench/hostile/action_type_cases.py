"""The campaign's ``--action-type`` cases (issue #38, kind 6): a bare SB3 zip said and checked.

``{zip_twist}`` is a bare zip (no ``config.yml``) trained on twist actions and 36 rays: it runs
only where ``--action-type twist`` is said and the env takes twist actions.
"""

from __future__ import annotations

from typing import Any

__all__ = ["action_type_cases"]

TWIST = '{"action_type": "twist", "laser_num_rays": 36, "max_episode_steps": 5}'
WHEELS = '{"laser_num_rays": 36, "max_episode_steps": 5}'
HEADS = {
    "evaluate": ["evaluate", "--episodes", "1"],
    "demo": ["demo", "--episodes", "1", "--no-video", "--out", "d"],
    "record": ["record", "--no-progress", "--out", "out"],
    "node": ["node", "--steps", "3", "--master-timeout", "2"],
}


def _case(name: str, command: str, extra: list[str], expect: str, says: str) -> dict[str, Any]:
    case: dict[str, Any] = {
        "id": f"action-type-{name}",
        "kind": 6,
        "argv": [*HEADS[command], *extra],
        "expect": expect,
        "timeout": 120,
    }
    if expect == "ok":
        return {**case, "stdout_has": [says]}
    return {**case, "exit": 2, "stderr_has": [says], "absent": ["d", "out"]}


def action_type_cases() -> list[dict[str, Any]]:
    """Each command: a bare zip unsaid, said wrong, said right; the option beside no bare zip."""
    bare = ["--policy", "{zip_twist}"]
    cases = []
    for command in ("evaluate", "demo", "record"):
        cases += [
            _case(f"{command}-unsaid", command, [*bare, "--env-kwargs", TWIST], "refuse",
                  "--action-type twist"),
            _case(f"{command}-wrong", command,
                  [*bare, "--env-kwargs", TWIST, "--action-type", "wheels"], "refuse",
                  "the env takes twist"),
            _case(f"{command}-env-other", command,
                  [*bare, "--env-kwargs", WHEELS, "--action-type", "twist"], "refuse",
                  "the env takes wheels"),
            _case(f"{command}-unused", command,
                  ["--policy", "laser", "--env-kwargs", WHEELS, "--action-type", "wheels"],
                  "refuse", "no --policy is one"),
        ]  # fmt: skip
    cases += [
        _case("evaluate-said", "evaluate", [*bare, "--env-kwargs", TWIST, "--action-type", "twist"],
              "ok", "zip_twist"),
        _case("record-said", "record", [*bare, "--env-kwargs", TWIST, "--action-type", "twist"],
              "ok", "recorded 1 episode"),
        _case("node-unsaid", "node", [*bare, "--env-kwargs", WHEELS], "refuse",
              "--action-type wheels"),
        _case("node-twist", "node", [*bare, "--env-kwargs", WHEELS, "--action-type", "twist"],
              "refuse", "the env takes wheels"),
        _case("node-no-policy", "node", ["--action-type", "wheels"], "refuse",
              "no --policy is one"),
        _case("bogus", "evaluate", [*bare, "--action-type", "diff"], "refuse", "--action-type"),
    ]  # fmt: skip
    return cases
