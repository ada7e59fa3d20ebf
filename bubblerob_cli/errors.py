"""The one way a command reports a user's mistake: one line, ``bubblerob CMD: what``, exit 2.

docs/RELIABILITY.md's rule: a usage error names the bad value and what is allowed, on standard
error, prefixed with the command, and exits 2 (1 for a failure that is not the user's input).
"""

from __future__ import annotations

import sys
from typing import NoReturn

__all__ = ["USAGE", "fail", "report"]

USAGE = 2  # the exit status of a usage error, as argparse's own


def report(command: str, message: str) -> None:
    """Print ``bubblerob COMMAND: MESSAGE`` on standard error (one line)."""
    print(f"bubblerob {command}: {message}", file=sys.stderr)


def fail(command: str, message: str, status: int = USAGE) -> NoReturn:
    """Report ``message`` for ``command`` and exit with ``status`` (2: a usage error)."""
    report(command, message)
    raise SystemExit(status)
