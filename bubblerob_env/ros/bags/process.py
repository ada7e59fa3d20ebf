"""A bag written by a process of its own, as ``rosbag record`` does: :func:`open_bag_in_process`.

The recording process only gathers each step's numbers (:class:`~bubblerob_env.ros.fastpath.batch.
FrameBatch`) and hands each batch over through memory shared with a writer process (forked, so it
starts in milliseconds); the writer converts and packs the frames, appends them to the bag's
chunks, compresses and writes them (:mod:`~bubblerob_env.ros.bags.process_writer`). On a machine
with two or more cores that work leaves the stepping loop. The bytes are the same: the writer
packs with the same packer and runs the same :class:`~bubblerob_env.ros.bags.sinks.BagSink` on
the same calls in the same order.

What holds as with a bag written in the recording process:

- A signal (Ctrl-C, SIGTERM) or an exception leaves a bag with every completed step: the
  recorder's handlers close the bag through the writer, which ignores SIGINT, SIGTERM and SIGHUP
  (a Ctrl-C reaches the whole process group) and finishes when told.
- A hard kill of the recording process loses at most the current episode: the writer reads every
  request sent before the pipe's end (each episode's end sends a flush), then stops without
  finishing the bag, as the recording process would have. :meth:`ProcessBagSink.flush` is not
  waited on, so a kill of *both* processes at once (a process group's SIGKILL) can lose, besides,
  what the writer had not yet written: at most :data:`~.process_writer.SLOTS` batches.
- An error in the writer (a full disk) is raised in the recording process, as the same exception,
  at the next batch, flush or close after it happened; a writer that died is reported
  (:class:`WriterDiedError`), never waited on forever. :attr:`ProcessBagSink.flushed` counts the
  flushes the writer did before any error (each ended an episode, which is then on disk): once
  the bag is closed, the episodes that read back.
- The bag's lock (:mod:`~bubblerob_env.ros.bags.lock`) is the recording process's, taken before
  the writer starts: a second writer of the bag is told this process's id, as inline.

:func:`can_write_apart` says where a writer process helps and is safe: Linux (on macOS, fork is
unsafe: CPython starts processes by spawn there), two or more usable cores (on one, the writer only
adds the hand-over), no other thread running (a fork copies only the forking thread: locks other
threads hold stay held in the child), and not a daemonic process (an ``AsyncVectorEnv`` worker may
not start processes).
"""

from __future__ import annotations

import mmap
import multiprocessing
import multiprocessing.connection
import os
import sys
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bubblerob_env.ros.bags.lock import BagLock
from bubblerob_env.ros.bags.process_writer import HEADER_BYTES, SLOT_BYTES, SLOTS, serve
from bubblerob_env.ros.bags.sinks import bag_path, check_bag_args, lock_bag
from bubblerob_env.ros.fastpath.batch import Gathered
from bubblerob_env.ros.fastpath.framing import (
    FrameLayout,
    Framing,
    PackedBatchWriter,
    PackedWriter,
    Record,
)
from bubblerob_env.ros.messages.topics import Topics
from bubblerob_env.specs import EnvSpecs

__all__ = ["ProcessBagSink", "WriterDiedError", "can_write_apart", "open_bag_in_process"]

_POLL_S = 0.5  # how often a wait looks whether the writer is still alive


class WriterDiedError(OSError):
    """The process writing a bag is gone (killed, or out of memory)."""


class ProcessBagSink:
    """A :class:`~bubblerob_env.ros.bags.sinks.BagSink` whose writing is done by another process.

    Made by :func:`open_bag_in_process`; used like the sink :func:`~.sinks.open_bag` returns.
    """

    def __init__(
        self, path: Path, fmt: str, distro: str, args: tuple[Any, ...], lock: BagLock
    ) -> None:
        self.path = path
        self.format = fmt
        self.distro = distro
        self.closed = False
        self._framing: Framing | None = None
        self._topics: list[str] = []
        self._layouts: dict[FrameLayout, int] = {}
        self._lock = lock  # given back once the writer has ended
        self._shared = mmap.mmap(-1, HEADER_BYTES + SLOTS * SLOT_BYTES)  # shared with the writer
        self._done = np.frombuffer(self._shared, dtype=np.int64, count=1)
        self._flushed = np.frombuffer(self._shared, dtype=np.int64, count=1, offset=8)
        self._flushed_at_close = 0
        self._slots = np.frombuffer(self._shared, dtype=np.uint8, offset=HEADER_BYTES)
        self._sent = 0  # batches sent
        self._queue: list[tuple[Any, ...]] = []  # requests not sent yet
        self._dead: WriterDiedError | None = None  # the writer died: every call says so
        self._packing = False  # whether the writer has its packer
        context = multiprocessing.get_context("fork")
        self._conn, child = context.Pipe()
        self._process = context.Process(
            target=serve, args=(child, self._conn, args, self._shared), daemon=False
        )
        self._process.start()
        child.close()  # ours goes: the writer sees the pipe's end if we die
        try:
            self._wait()
        except BaseException:
            self.closed = True
            self._process.join()
            self._conn.close()
            raise

    # -- talking to the writer ------------------------------------------------------------------

    def _died(self) -> WriterDiedError:
        if self._dead is None:
            self.closed = True
            self._process.join(timeout=5)
            self._flushed_at_close = int(self._flushed[0])  # it does no more
            if not self._process.is_alive():  # its copy of the lock is gone: ours goes too
                self._lock.release()
            code = self._process.exitcode
            how = f"was killed by signal {-code}" if code and code < 0 else f"exited ({code})"
            text = f"the process writing bag {self.path} {how}: the bag is unfinished"
            self._dead = WriterDiedError(text)
        return self._dead

    def _wait(self) -> Any:
        """The writer's answer to the last request that has one (an earlier write's error first)."""
        earlier: BaseException | None = None
        while True:
            try:
                ready = self._conn.poll(_POLL_S)
                message = self._conn.recv() if ready else None
            except (EOFError, ConnectionError):
                raise self._died() from None
            if message is None:
                if not self._process.is_alive():
                    raise self._died()
                continue
            status, value = message
            if status == "async":
                earlier = earlier or value
                continue
            if earlier is not None:
                raise earlier
            if status == "error":
                raise value
            return value

    def _send(self, request: tuple[Any, ...], now: bool = False) -> None:
        """Queue ``request``; with ``now``, send the queue (one message: one wake-up)."""
        if self.closed:
            raise self._dead or ValueError(f"bag {self.path} is closed")
        self._queue.append(request)
        if now:
            self._push()

    def _push(self) -> None:
        queue, self._queue = self._queue, []
        try:
            if self._conn.poll():  # an earlier write failed: say so at once
                raise self._conn.recv()[1]
            self._conn.send(queue)
        except (EOFError, ConnectionError):
            raise self._died() from None

    def _ask(self, request: tuple[Any, ...]) -> Any:
        self._send(request, now=True)
        return self._wait()

    # -- the Sink protocol ----------------------------------------------------------------------

    def add_topic(self, topic: str, msgtype: str, latched: bool = False) -> None:
        """Declare ``topic`` with type ``msgtype`` (the distro's definition goes in the bag)."""
        self._ask(("add_topic", topic, msgtype, latched))
        self._topics.append(topic)
        self._framing = None

    def write_batch(self, records: Sequence[Record]) -> None:
        """Append messages; topics must have been added."""
        self._send(("records", list(records)))

    def framing(self) -> Framing | None:
        """How the bag frames records (asked of the writer once per set of topics)."""
        if self._framing is None:
            self._framing = self._ask(("framing",))
        return self._framing

    def write_packed(self, data: bytes, layout: FrameLayout, stamp_ns: int, action_ns: int) -> None:
        """Append one packed frame."""
        self._send(("one", bytes(data), layout, int(stamp_ns), int(action_ns)))

    def packed_writer(self) -> PackedWriter:
        """:meth:`write_packed`."""
        return self.write_packed

    def write_packed_batch(
        self, data: Any, layout: FrameLayout, stamps: NDArray[Any], action_stamps: NDArray[Any]
    ) -> None:
        """Send ``len(stamps)`` packed frames: their bytes are copied into the pipe now."""
        index = self._layouts.get(layout)
        if index is None:
            index = self._layouts[layout] = len(self._layouts)
            self._send(("layout", layout))
        size = len(stamps) * layout.size
        both = np.concatenate((stamps, action_stamps)).astype(np.int64, copy=False).tobytes()
        if size > SLOT_BYTES:  # a batch of huge frames: through the pipe
            self._send(("many", index, -1, size, both), now=True)
            try:
                self._conn.send_bytes(memoryview(data).cast("B")[:size])
            except (EOFError, ConnectionError):
                raise self._died() from None
        else:
            self._wait_for_slot()
            slot = self._sent % SLOTS
            start = slot * SLOT_BYTES
            self._slots[start : start + size] = np.frombuffer(data, dtype=np.uint8, count=size)
            self._send(("many", index, slot, size, both), now=True)
        self._sent += 1

    def write_gathered(self, gathered: Gathered, specs: EnvSpecs, topics: Topics) -> None:
        """Send frames as gathered: the writer converts and packs them (as the fan-out would)."""
        if not self._packing:
            self._send(("packer", specs, topics))
            self._packing = True
        arrays: tuple[NDArray[Any], ...] = (gathered.rows, gathered.lasers, gathered.images)
        sizes = [array.nbytes for array in arrays]
        if sum(sizes) > SLOT_BYTES:  # pragma: no cover - bigger than any fan-out batch
            raise ValueError(f"a batch of {sum(sizes)} bytes does not fit a writer's slot")
        self._wait_for_slot()
        slot = self._sent % SLOTS
        start = slot * SLOT_BYTES
        for array, size in zip(arrays, sizes, strict=True):
            self._slots[start : start + size] = array.reshape(-1).view(np.uint8)
            start += size
        shapes = [array.shape for array in arrays]
        self._send(("gathered", slot, shapes, gathered.scalars), now=True)
        self._sent += 1

    def _wait_for_slot(self) -> None:
        """Wait until the writer is fewer than ``SLOTS`` batches behind."""
        while self._sent - int(self._done[0]) >= SLOTS:
            if self._conn.poll(0.0005):  # an error of a batch: raised at once
                raise self._conn.recv()[1]
            if not self._process.is_alive():
                raise self._died()

    def packed_batch_writer(self) -> PackedBatchWriter:
        """:meth:`write_packed_batch`."""
        return self.write_packed_batch

    def set_metadata(self, key: str, value: str) -> None:
        """Bag-level metadata (ROS 2 ``custom_data``); ROS 1: ignored."""
        self._send(("metadata", key, value))

    def flush(self) -> None:
        """Have the writer put everything so far on disk (it does so after the batches before).

        Not waited on: if this process dies, the writer still reads every request sent before.
        """
        self._send(("flush",), now=True)

    def close(self) -> None:
        """Finish the bag (index, summary) and wait for the writer to end. Safe twice."""
        if self.closed:
            return
        try:
            try:  # even after an error: the bag is finished
                self._conn.send([*self._queue, ("close",)])
            except (EOFError, ConnectionError):
                raise self._died() from None
            self._wait()
        finally:
            self.closed = True
            self._process.join(timeout=30)
            if self._process.is_alive():  # pragma: no cover - a writer stuck past its close
                self._process.kill()
                self._process.join()
            self._conn.close()
            self._flushed_at_close = int(self._flushed[0])
            del self._done, self._flushed, self._slots
            self._shared.close()
            self._lock.release()

    @property
    def flushed(self) -> int:
        """Flushes the writer has done before any error: exact once :meth:`close` returned."""
        return self._flushed_at_close if self.closed else int(self._flushed[0])

    @property
    def topics(self) -> tuple[str, ...]:
        """Topics added so far."""
        return tuple(self._topics)


def open_bag_in_process(
    path: str | Path,
    fmt: str = "mcap",
    distro: str | None = None,
    compression: str | None = None,
    overwrite: bool = False,
    chunk_size: int | None = None,
) -> ProcessBagSink:
    """:func:`~bubblerob_env.ros.bags.sinks.open_bag`, with the bag written by a process of its own.

    The arguments, the checks and the errors are :func:`~.sinks.open_bag`'s (raised here).
    """
    if "fork" not in multiprocessing.get_all_start_methods():
        raise ValueError("a bag writer process needs the 'fork' start method (Linux, macOS)")
    distro, _ = check_bag_args(fmt, distro, compression)
    target = bag_path(path, fmt)
    lock = lock_bag(target)  # ours, before the fork: the writer inherits it, never takes it
    args = (path, fmt, distro, compression, overwrite, chunk_size, True)
    try:
        return ProcessBagSink(target, fmt, distro, args, lock)
    except BaseException:
        lock.release()
        raise


def can_write_apart() -> bool:
    """Whether a writer process helps and is safe here (see the module's docstring)."""
    if not sys.platform.startswith("linux"):  # macOS: its system libraries make fork unsafe
        return False
    return (
        len(os.sched_getaffinity(0)) >= 2
        and threading.active_count() == 1
        and not multiprocessing.current_process().daemon
    )
