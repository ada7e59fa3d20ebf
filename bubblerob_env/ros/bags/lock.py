"""One writer per bag: an advisory lock on ``<bag>.lock`` beside the bag, held while it is open.

Two recorders writing one path (two ``bubblerob record --overwrite`` runs) would both delete,
write and claim success, and one run's data would be lost; the second now fails at once, naming
the process that holds the bag. The lock is ``flock``: the kernel drops it when its process dies,
so a killed recorder leaves a stale ``.lock`` file that blocks nobody (the next writer takes it).
A recorder whose bag a writer process writes (:mod:`~bubblerob_env.ros.bags.process`) takes the
lock before starting it, and the writer inherits it: killed, the recorder's lock is held until its
writer has written what it was sent and ended (milliseconds), which the next writer waits for.
"""

from __future__ import annotations

import fcntl
import os
import time
from pathlib import Path

__all__ = ["BagLock", "BagLockedError"]

_ORPHAN_WAIT_S = 10.0  # at most, for the writer process of a recorder that is gone


class BagLockedError(OSError):
    """Another process is writing the bag."""


class BagLock:
    """The lock of the bag at ``path``, taken by the constructor; :meth:`release` gives it back.

    Raises:
        BagLockedError: Another process holds it.
        OSError: The lock file cannot be created (the directory is not writable).
    """

    def __init__(self, path: Path) -> None:
        self.path = path.with_name(path.name + ".lock")
        deadline = time.monotonic() + _ORPHAN_WAIT_S
        while True:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.read(fd, 64).decode(errors="replace").strip() or "another process"
                os.close(fd)
                if not _alive(holder) and time.monotonic() < deadline:
                    time.sleep(0.01)  # a dead recorder's writer process, finishing: soon free
                    continue
                raise BagLockedError(
                    f"bag {path} is being written by process {holder}; "
                    "wait for it to finish or choose another --out"
                ) from None
            try:
                same = os.stat(self.path).st_ino == os.fstat(fd).st_ino
            except FileNotFoundError:
                same = False
            if same:  # not unlinked by a writer that finished meanwhile: ours
                break
            os.close(fd)
        os.ftruncate(fd, 0)
        os.write(fd, str(os.getpid()).encode())
        self._fd: int | None = fd

    def release(self) -> None:
        """Remove the lock file and drop the lock (once; later calls do nothing)."""
        fd, self._fd = self._fd, None
        if fd is None:
            return
        try:
            self.path.unlink(missing_ok=True)
        finally:
            os.close(fd)


def _alive(holder: str) -> bool:
    """Whether the process named in a lock file runs (if it cannot be told: it counts as alive)."""
    try:
        os.kill(int(holder), 0)
    except ProcessLookupError:
        return False
    except (ValueError, OSError):  # no pid written yet, or another user's process
        return True
    return True
