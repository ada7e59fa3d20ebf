"""Crash safety for open bags: finish them on exceptions, Ctrl-C, SIGTERM and interpreter exit.

While at least one bag is open (:func:`register`):

- ``SIGTERM`` raises :class:`Terminated` (status 143) instead of killing the process outright, so
  that ``finally`` blocks and ``atexit`` hooks run (only where ``SIGTERM`` had its default action);
- ``SIGINT`` (Ctrl-C) raises ``KeyboardInterrupt`` as usual;
- both are *deferred* while a :func:`critical` block runs (writing one frame, finishing a file),
  and raised when it ends, so that a bag never holds half a step or half an index; a second
  signal during the same block raises at once;
- an ``atexit`` hook closes every bag still open, e.g. after an uncaught exception.

Handlers are installed from the main thread only, and the previous ones come back when the last
bag closes. A hard kill (``SIGKILL``, power loss) cannot be caught: sinks flush after each episode
so that the reindex tools of each format can recover everything but the current episode.
"""

from __future__ import annotations

import atexit
import contextlib
import itertools
import signal
import threading
from collections.abc import Callable
from types import FrameType, TracebackType
from typing import Any

__all__ = ["Terminated", "critical", "register", "unregister"]


class Terminated(SystemExit):
    """A signal (``SIGTERM``) ended the process while a bag was open; ``code`` is 128 + signum.

    Raised in place of the signal's default action, which would end the process without running
    ``finally`` blocks or ``atexit`` hooks. It is a ``SystemExit``, so that a script that records
    and is terminated still ends quietly with the status a shell reports for the signal (143), as
    it would without a bag open; a command may catch it to say more.
    """

    def __init__(self, signum: int) -> None:
        super().__init__(128 + signum)
        self.signum = signum


_closers: dict[int, Callable[[], None]] = {}
_previous: dict[int, Any] = {}
_pending: list[int] = []
_depth = 0
_tokens = itertools.count(1)
_atexit_registered = False


def _raise_for(signum: int) -> None:
    if signum == signal.SIGINT:
        raise KeyboardInterrupt
    raise Terminated(signum)


def _handler(signum: int, frame: FrameType | None) -> None:
    if _depth > 0 and not _pending:
        _pending.append(signum)  # raised when the critical block ends
        return
    _pending.clear()
    _raise_for(signum)


def _install() -> None:
    if threading.current_thread() is not threading.main_thread():
        return
    for signum, default in ((signal.SIGINT, signal.default_int_handler), (signal.SIGTERM, None)):
        current = signal.getsignal(signum)
        if current in (default, signal.SIG_DFL):
            _previous[signum] = current
            signal.signal(signum, _handler)


def _restore() -> None:
    if threading.current_thread() is not threading.main_thread():
        return
    for signum, previous in list(_previous.items()):
        if signal.getsignal(signum) is _handler:
            signal.signal(signum, previous)
        del _previous[signum]


def _close_all() -> None:
    for closer in list(_closers.values()):
        with contextlib.suppress(Exception):  # keep closing the others at exit
            closer()


def register(closer: Callable[[], None]) -> int:
    """Track an open bag; ``closer`` finishes it. Returns a token for :func:`unregister`."""
    global _atexit_registered
    if not _atexit_registered:
        atexit.register(_close_all)
        _atexit_registered = True
    if not _closers:
        _install()
    token = next(_tokens)
    _closers[token] = closer
    return token


def unregister(token: int) -> None:
    """Stop tracking a bag (after it was closed); the last one restores the signal handlers."""
    _closers.pop(token, None)
    if not _closers:
        _restore()


class _Critical:
    """Context manager: defer SIGINT/SIGTERM until the block ends (re-entrant)."""

    def __enter__(self) -> None:
        global _depth
        _depth += 1

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        global _depth
        _depth -= 1
        if _depth == 0 and _pending:
            signum = _pending.pop()
            _pending.clear()
            _raise_for(signum)  # chained to any exception already leaving the block


critical = _Critical()
"""``with critical: ...`` runs the block with SIGINT/SIGTERM deferred to its end."""
