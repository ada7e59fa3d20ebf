"""The writer process of a bag written apart (:mod:`~bubblerob_env.ros.bags.process`): its side.

It opens the bag, then carries out the recorder's requests in order: packed frames, frames as
gathered (converted and packed here, as the fan-out would), records, metadata, flush and close.
Batches come through slots of memory shared with the recorder; the rest through the pipe.
"""

from __future__ import annotations

import mmap
import multiprocessing.connection
import signal
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bubblerob_env.ros.bags.sinks import BagSink, open_bag
from bubblerob_env.ros.fastpath.batch import FrameBatch, Gathered
from bubblerob_env.ros.fastpath.framing import FrameLayout
from bubblerob_env.ros.fastpath.serializer import FramePacker, FrameSerializer
from bubblerob_env.ros.messages.topics import Topics
from bubblerob_env.specs import EnvSpecs

__all__ = ["ANSWERED", "GATHERED_DTYPES", "HEADER_BYTES", "SLOTS", "SLOT_BYTES", "Writer", "serve"]

ANSWERED = ("add_topic", "framing", "close")
"""Requests the recorder waits on; errors of the others come back as ``"async"``, at once."""
SLOTS = 4
"""Batches of packed frames the writer may be behind; each goes through shared memory."""
SLOT_BYTES = 2**21
"""A slot's size: a fan-out batch is about a MiB at most (bigger ones go through the pipe)."""
HEADER_BYTES = 16
"""Before the slots: two int64 counters the writer keeps, batches written and flushes done (a
flush done before any error: the episodes ended before it are on disk, as the recorder reports)."""


GATHERED_DTYPES: tuple[np.dtype[Any], ...] = (
    np.dtype(np.float64),
    np.dtype("<f4"),
    np.dtype(np.uint8),
)
"""Of the rows, the scans and the images of :class:`~bubblerob_env.ros.fastpath.batch.Gathered`."""


def serve(
    conn: multiprocessing.connection.Connection,
    ours: multiprocessing.connection.Connection,
    args: tuple[Any, ...],
    shared: mmap.mmap,
) -> None:
    """The writer process: open the bag, then carry out each request until close or the end."""
    ours.close()  # the recorder's end: else its death would never end our reads
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the recorder closes the bag through us
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    signal.signal(signal.SIGHUP, signal.SIG_IGN)  # a closed terminal: drain the pipe, then stop
    try:
        sink = open_bag(*args)
    except BaseException as error:  # noqa: BLE001 - every error goes back to the recorder
        conn.send(("error", error))
        return
    conn.send(("ok", None))
    state = Writer(sink, conn, shared)
    while True:
        try:
            requests = conn.recv()  # a list, in order
        except (EOFError, OSError):  # the recorder died: leave the bag as it was (unfinished)
            return  # multiprocessing ends the process without atexit hooks or destructors
        for request in requests:
            if state.carry_out(request):
                return


class Writer:
    """The writer process's side: the bag and what it needs to read batches."""

    def __init__(
        self, sink: BagSink, conn: multiprocessing.connection.Connection, shared: mmap.mmap
    ) -> None:
        self.sink = sink
        self.conn = conn
        self.layouts: list[FrameLayout] = []
        self.done = np.frombuffer(shared, dtype=np.int64, count=1)  # batches written
        self.flushed = np.frombuffer(shared, dtype=np.int64, count=1, offset=8)  # flushes done
        self.slots = memoryview(shared)[HEADER_BYTES:]
        self.failed = False  # after an error, writes are left out: the first error is reported
        self.packer: FramePacker | None = None
        self.converter: FrameBatch | None = None

    def set_packer(self, specs: EnvSpecs, topics: Topics) -> None:
        """Pack frames as the recorder's fan-out would for this bag."""
        framing = self.sink.framing()
        self.packer = FrameSerializer(specs, self.sink.distro, topics).packer(framing, stepped=True)
        self.converter = FrameBatch(specs, 1)

    def write_gathered(
        self, slot: int, shapes: list[tuple[int, ...]], scalars: list[tuple[Any, ...]]
    ) -> None:
        """Frames as gathered (:meth:`FrameBatch.take`), from their slot: converted and packed."""
        try:
            if self.failed:
                return
            assert self.packer is not None and self.converter is not None
            arrays: list[NDArray[Any]] = []
            start = slot * SLOT_BYTES
            for shape, dtype in zip(shapes, GATHERED_DTYPES, strict=True):
                size = int(np.prod(shape)) * dtype.itemsize
                view = self.slots[start : start + size]
                arrays.append(np.frombuffer(view, dtype=dtype).reshape(shape))
                start += size
            rows, lasers, images = arrays
            columns = self.converter.convert(Gathered(rows, lasers, images, scalars))
            data = self.packer.pack_many(columns, len(scalars))
            stamps = columns["log_ns"], columns["action_log_ns"]
            self.sink.packed_batch_writer()(data, self.packer.layout, *stamps)
        finally:
            self.done[0] += 1  # the slot is free again

    def carry_out(self, request: tuple[Any, ...]) -> bool:
        """Do ``request``, answering it if the recorder waits; whether it was the close."""
        kind: str = request[0]
        try:
            if kind == "many":
                self.write_many(*request[1:])
                return False
            if kind == "gathered":
                self.write_gathered(*request[1:])
                return False
            if kind == "layout":
                self.layouts.append(request[1])
                return False
            if kind == "packer":
                self.set_packer(*request[1:])
                return False
            reply = None
            if not self.failed or kind in ("close", "flush"):
                reply = _carry_out(self.sink, request)
            if kind == "flush" and not self.failed:  # everything before it is on disk
                self.flushed[0] += 1
        except BaseException as error:  # noqa: BLE001 - raised in the recorder
            self.failed = True
            self.conn.send(("error" if kind in ANSWERED else "async", error))
            return kind == "close"
        if kind in ANSWERED:
            self.conn.send(("ok", reply))
        return kind == "close"

    def write_many(self, layout_index: int, slot: int, size: int, stamp_bytes: bytes) -> None:
        """A batch of packed frames, from its slot of shared memory (or the pipe, ``slot < 0``)."""
        data: Any
        if slot < 0:
            data = self.conn.recv_bytes()
        else:
            data = self.slots[slot * SLOT_BYTES : slot * SLOT_BYTES + size]
        stamps = np.frombuffer(stamp_bytes, dtype=np.int64).reshape(2, -1)
        try:
            if not self.failed:
                self.sink.packed_batch_writer()(data, self.layouts[layout_index], *stamps)
        finally:
            if slot >= 0:
                self.done[0] += 1  # the slot is free again


def _carry_out(sink: BagSink, request: tuple[Any, ...]) -> Any:
    kind = request[0]
    if kind == "one":
        _, data, layout, stamp, action_stamp = request
        sink.packed_writer()(data, layout, stamp, action_stamp)
    elif kind == "records":
        sink.write_batch(request[1])
    elif kind == "add_topic":
        sink.add_topic(*request[1:])
    elif kind == "framing":
        return sink.framing()
    elif kind == "metadata":
        sink.set_metadata(*request[1:])
    elif kind == "flush":
        sink.flush()
    elif kind == "close":
        sink.close()
    return None
