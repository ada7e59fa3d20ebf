"""The suite passes however it is started: here as a background job of a script would start it.

Such a job starts with SIGINT ignored (and ``nohup``, cron and CI runners add: no terminal, no
input). The test runs one test that stops a command with Ctrl-C in a pytest started that way.
"""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CTRL_C_TEST = "tests/ros/test_cli_errors.py::test_ctrl_c_says_what_was_saved_and_exits_130"


def _ignore_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # what `make test &` gets from its shell


def test_a_ctrl_c_test_passes_with_sigint_ignored_and_no_terminal() -> None:
    pytest.importorskip("policies")
    result = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", CTRL_C_TEST],
        cwd=ROOT,
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=180,
        preexec_fn=_ignore_sigint,
        start_new_session=True,  # no controlling terminal, as under nohup or cron
    )
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-2000:]
    assert "1 passed" in result.stdout
