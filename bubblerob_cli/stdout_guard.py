"""Standard output closed, full or left by its reader: one line, never a traceback.

Every entry point runs its command through :func:`guarded` (``bubblerob``, ``python -m train``,
``python -m policies.export_onnx``): started with standard output closed (``>&-``) it says so and
exits 1; a write to a full one (``> /dev/full``) is one line and exit 1; a reader that left
(``| head``) is exit 141, as a shell reports SIGPIPE, with nothing printed.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from typing import Any

__all__ = ["guarded"]


def guarded(program: str, call: Callable[[], int | None]) -> int:
    """``call()``'s exit status; standard output's failures as the module docstring says.

    ``program`` prefixes the one line (``bubblerob info``, ``python -m train``).
    """
    if sys.stdout is None:  # started with standard output closed
        print(f"{program}: standard output is closed: nothing could be printed", file=sys.stderr)
        return 1
    watched = _WatchedStream(sys.stdout)
    sys.stdout = watched
    try:
        result = call()
        sys.stdout.flush()
    except BrokenPipeError:  # `bubblerob info BAG | head`: the reader left, nothing is wrong
        os.dup2(os.open(os.devnull, os.O_WRONLY), watched.fileno())  # the flush at exit
        return 141  # 128 + SIGPIPE, as a shell reports it
    except OSError as error:  # standard output full (`> /dev/full`): one line, not a traceback
        if not watched.failed:
            raise
        os.dup2(os.open(os.devnull, os.O_WRONLY), watched.fileno())
        print(f"{program}: cannot write to standard output: {error.strerror or error}",
              file=sys.stderr)  # fmt: skip
        return 1
    finally:
        sys.stdout = watched.stream
    return int(result or 0)


class _WatchedStream:
    """Standard output, noting whether a write to it failed (so that error is told apart)."""

    def __init__(self, stream: Any) -> None:
        self.stream = stream
        self.failed = False

    def write(self, text: str) -> int:
        try:
            return int(self.stream.write(text))
        except OSError:
            self.failed = True
            raise

    def flush(self) -> None:
        try:
            self.stream.flush()
        except OSError:
            self.failed = True
            raise

    def __getattr__(self, name: str) -> Any:
        return getattr(self.stream, name)
