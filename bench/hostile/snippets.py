"""Run the campaign's Python snippets in one process (``run.py`` feeds them on standard input).

Each snippet runs as ``run.py``'s ``SNIPPET`` would run it alone: a one-line ``ValueError`` or
``TypeError`` is a refusal (status 2; 3 when it spans lines), a failed ``assert`` is status 4,
any other exception is a traceback (status 1, its traceback on standard error). Importing
gymnasium and the env once for all snippets saves ~2 s a case; a snippet that kills the process
leaves the cases after it unanswered (``run.py`` calls them crashes).
"""

from __future__ import annotations

import contextlib
import io
import json
import sys
import traceback
import warnings
from typing import Any

import gymnasium as gym
import numpy as np

import bubblerob_env  # noqa: F401 - registers the env ids


def run_snippet(code: str) -> tuple[int, str, str]:
    """Run ``code``; its status, standard output and error (see the module docstring)."""
    out, err = io.StringIO(), io.StringIO()
    scope: dict[str, Any] = {
        "gym": gym,
        "np": np,
        "warnings": warnings,
        "sys": sys,
        "bubblerob_env": bubblerob_env,
    }
    status = 0
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            exec(compile(code, "<case>", "exec"), scope)  # noqa: S102 - the campaign's own cases
        except (ValueError, TypeError) as error:
            text = str(error)
            print(f"refused: {type(error).__name__}: {text}", file=sys.stderr)
            status = 2 if "\n" not in text.strip() else 3
        except AssertionError as error:
            print(f"WRONG: {error}")
            status = 4
        except Exception:  # noqa: BLE001 - what a user would see as a traceback
            traceback.print_exc()
            status = 1
    for env in [v for v in scope.values() if isinstance(v, gym.Env)]:
        env.close()
    return status, out.getvalue(), err.getvalue()


def main() -> None:
    """One JSON line per snippet read: ``{"id", "rc", "stdout", "stderr"}``."""
    for line in sys.stdin:
        case = json.loads(line)
        rc, out, err = run_snippet(case["code"])
        print(json.dumps({"id": case["id"], "rc": rc, "stdout": out, "stderr": err}), flush=True)


if __name__ == "__main__":
    main()
