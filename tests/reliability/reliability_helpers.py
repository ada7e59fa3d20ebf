"""What the reliability tests share: running ``bubblerob`` in this process, a refusal's shape."""

from __future__ import annotations

import contextlib
import io

from bubblerob_cli.main import main

__all__ = ["one_line", "run"]


def run(*argv: str) -> tuple[int, str, str]:
    """``bubblerob ARGV`` in this process: its exit status, standard output and error."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status = main(list(argv))
        except SystemExit as exit_:
            code = exit_.code
            status = code if isinstance(code, int) else 1
            if isinstance(code, str):
                print(code, file=err)
    return status, out.getvalue(), err.getvalue()


def one_line(text: str) -> bool:
    """A refusal is one line of standard error (warnings of other libraries aside)."""
    lines = [line for line in text.splitlines() if line.startswith("bubblerob ")]
    return len(lines) == 1
