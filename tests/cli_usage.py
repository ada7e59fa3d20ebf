"""Run ``bubblerob`` in this process and read its exit as a user sees it (for the usage tests).

Imported as a plain module (tests/ is on sys.path). A handler that raises ``SystemExit("text")``
prints the text and exits 1, as Python does at the top level; any other exception is a traceback
the user would have seen, so it propagates and fails the test.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import pytest

from bubblerob_cli import main as cli


@dataclass(frozen=True)
class Exit:
    """A finished ``bubblerob`` run."""

    code: int
    out: str
    err: str

    @property
    def lines(self) -> list[str]:
        """The non-empty lines on stderr."""
        return [line for line in self.err.splitlines() if line.strip()]

    def one_line(self) -> str:
        """The one line a refusal prints (argparse's own: its last, after the usage lines)."""
        assert "Traceback" not in self.err, self.err
        lines = self.lines
        if len(lines) > 1 and lines[-1].split(": ")[1:2] == ["error"]:
            return lines[-1]  # argparse: "usage: ...", then "bubblerob X: error: ..."
        assert len(lines) == 1, self.err
        return lines[0]


def run(argv: Sequence[str], capsys: pytest.CaptureFixture[str]) -> Exit:
    """``bubblerob ARGV`` in this process; its exit code and what it printed."""
    capsys.readouterr()
    try:
        code: int | str | None = cli.main(list(argv))
    except SystemExit as stop:
        code = stop.code
    out, err = capsys.readouterr()
    if isinstance(code, str):  # SystemExit("text"): Python prints it and exits 1
        err, code = err + code + "\n", 1
    return Exit(int(code or 0), out, err)
