"""Packed frames: the record headers writers put before messages, and the index entries of frames.

MCAP and ROS 1 writers take a frame's records, headers included, as one byte string packed by one
``struct`` call upstream (:class:`~bubblerob_env.ros.fastpath.serializer.FramePacker`).
:class:`Framing`
says which header goes before each message; :class:`FrameLayout` where each record of a packed
frame starts. Writers index packed frames when their chunk closes, with numpy
(:func:`index_frames`), giving the bytes the same records written one by one give.
"""

from __future__ import annotations

import struct
from collections import defaultdict
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, BinaryIO

import numpy as np
from numpy.typing import NDArray

from bubblerob_env.ros.fastpath.encode import PAD, Item, Slot

__all__ = [
    "NO_TIME",
    "FrameLayout",
    "Framing",
    "PackedBatchWriter",
    "PackedWriter",
    "Record",
    "append_batch",
    "append_records",
    "index_entries",
    "index_frames",
    "record_header",
]

Record = tuple[str, int, bytes]
"""``(topic, log time in ns, serialised message)``."""

NO_TIME = 2**63 - 1
"""The start time of a chunk that holds no record yet (``rosbags``' ``MAXSIZE``)."""


@dataclass(frozen=True)
class Framing:
    """The header a writer puts before each message record in a chunk, as ``struct`` items.

    ``kind`` is ``"mcap"``, ``"ros1"`` or ``"raw"`` (no header: messages back to back, for
    storages that keep each message apart, such as sqlite3); ``ids`` maps each topic to its
    channel (MCAP), connection (ROS 1) or topic (sqlite3) id. Two sinks with equal framings take
    the same packed bytes.
    """

    kind: str
    ids: tuple[tuple[str, int], ...]

    def header(self, topic: str, size: int, action: bool) -> list[Item]:
        """Items of the header of a ``size``-byte message on ``topic``.

        Its log time is slot ``log_ns`` (ROS 1: ``log_sec`` and ``log_nsec``), prefixed with
        ``action_`` for records logged at the action's stamp.
        """
        return _header(self.kind, dict(self.ids)[topic], size, "action_" if action else "")


def _header(kind: str, cid: int, size: int, prefix: str) -> list[Item]:
    """The one definition of every record header a writer puts before a message."""
    if kind == "mcap":
        stamp = Slot(prefix + "log_ns")
        return [("B", 0x05), ("Q", 22 + size), ("H", cid), ("I", 0), ("Q", stamp), ("Q", stamp)]
    if kind == "ros1":
        sec, nsec = Slot(prefix + "log_sec"), Slot(prefix + "log_nsec")
        return [
            ("I", 38), ("I", 4), ("4s", b"op=\x02"), ("I", 9), ("5s", b"conn="), ("I", cid),
            ("I", 13), ("5s", b"time="), ("I", sec), ("I", nsec), ("I", size),
        ]  # fmt: skip
    if kind == "raw":
        return []
    raise ValueError(f"unknown framing {kind!r}")


def record_header(kind: str, cid: int, size: int, stamp_ns: int) -> bytes:
    """The header of one record (``kind`` as :attr:`Framing.kind`), logged at ``stamp_ns``."""
    sec, nsec = divmod(stamp_ns, 1_000_000_000)
    times = {"log_ns": stamp_ns, "log_sec": sec, "log_nsec": nsec}
    items = _header(kind, cid, size, "")
    values = [times[v.name] if isinstance(v, Slot) else v for _, v in items if v is not PAD]
    return struct.pack("<" + "".join(code for code, _ in items), *values)


@dataclass(frozen=True, eq=False)
class FrameLayout:
    """Where the records of a packed frame start, their channel ids, and which stamp each has.

    ``action[i]``: record ``i`` is logged at the action's stamp, else at the frame's.
    """

    channels: tuple[int, ...]
    offsets: tuple[int, ...]
    action: tuple[bool, ...]
    size: int

    def spans(self) -> list[tuple[int, int, int, bool]]:
        """``(channel, start, end, action)`` of each record: where it lies in the packed frame."""
        ends = (*self.offsets[1:], self.size)
        return list(zip(self.channels, self.offsets, ends, self.action, strict=True))

    @property
    def has_action(self) -> bool:
        """Whether any record is logged at the action's stamp."""
        return any(self.action)


Frame = tuple[FrameLayout, int, Any, Any]
"""Packed frames in a chunk: their layout, the first one's position in the chunk, and the stamp
and action stamp (ints: one frame; equal-length ``int64`` arrays: that many frames in a row)."""
Index = dict[int, list[Any]]
"""Channel -> its ``(stamp, position)`` tuples and ``(n, 2)`` arrays of them, in write order."""
PackedWriter = Callable[[bytes, FrameLayout, int, int], None]
"""``write_packed(data, layout, stamp, action_stamp)`` of a writer."""
PackedBatchWriter = Callable[[Any, FrameLayout, NDArray[np.int64], NDArray[np.int64]], None]
"""``write_packed_batch(data, layout, stamps, action_stamps)``: ``len(stamps)`` packed frames."""


def _runs(frames: list[Frame]) -> Iterator[tuple[FrameLayout, NDArray[np.int64], Any, Any]]:
    """Layout, positions, stamps and action stamps of runs of frames with the same layout."""
    start = 0
    while start < len(frames):
        layout, pos, stamps, action_stamps = frames[start]
        if isinstance(stamps, np.ndarray):  # a batch of frames, back to back
            yield layout, pos + layout.size * np.arange(len(stamps)), stamps, action_stamps
            start += 1
            continue
        end = start + 1
        while (
            end < len(frames)
            and frames[end][0] is layout
            and not isinstance(frames[end][2], np.ndarray)
        ):
            end += 1
        block = np.array([frame[1:] for frame in frames[start:end]], dtype=np.int64)
        yield layout, block[:, 0], block[:, 1], block[:, 2]
        start = end


def index_frames(frames: list[Frame], index: Index) -> tuple[int, int, dict[int, int]]:
    """Append the index entries of ``frames`` to ``index``, in the order records were written.

    Returns the lowest and highest log time and the number of records per channel.
    """
    if len(frames) == 1 and not isinstance(frames[0][2], np.ndarray):
        return _index_frame(frames[0], index)
    low, high = NO_TIME, 0
    counts: dict[int, int] = defaultdict(int)
    for layout, positions, frame_stamps, action_stamps in _runs(frames):
        stamps = {False: frame_stamps, True: action_stamps}
        for cid, offset, action in zip(layout.channels, layout.offsets, layout.action, strict=True):
            entries = np.empty((len(positions), 2), dtype=np.int64)
            entries[:, 0] = stamps[action]
            entries[:, 1] = positions + offset
            index[cid].append(entries)
            counts[cid] += len(positions)
        for action in set(layout.action):
            low = min(low, int(stamps[action].min()))
            high = max(high, int(stamps[action].max()))
    return low, high, counts


def _index_frame(frame: Frame, index: Index) -> tuple[int, int, dict[int, int]]:
    """:func:`index_frames` of one frame: its entries as tuples, which numpy would only slow.

    Frames followed each by a record (``/detections``) are indexed one at a time.
    """
    layout, pos, stamp, action_stamp = frame
    counts: dict[int, int] = defaultdict(int)
    for cid, offset, action in zip(layout.channels, layout.offsets, layout.action, strict=True):
        index[cid].append((action_stamp if action else stamp, pos + offset))
        counts[cid] += 1
    used = [action_stamp if action else stamp for action in set(layout.action)]
    return min(used), max(used), counts


def append_records(
    kind: str, buffer: BinaryIO, index: Index, records: Sequence[Record], ids: Mapping[str, int]
) -> tuple[int, int, list[int]]:
    """Append ``(topic, stamp, data)`` records, framed as ``kind``, to a writer's open chunk.

    The one record loop of the MCAP and ROS 1 writers: each record's header
    (:func:`record_header`) and message go to the end of ``buffer`` in one write, and its
    ``(stamp, position)`` to ``index`` under its channel (``ids[topic]``). Returns the lowest and
    highest stamp (:data:`NO_TIME` and 0 for no records) and each record's channel, in order.
    """
    pos = buffer.tell()
    low, high = NO_TIME, 0
    channels = []
    parts = []
    for topic, stamp, payload in records:
        cid = ids[topic]
        index[cid].append((stamp, pos))
        header = record_header(kind, cid, len(payload), stamp)
        parts.append(header)
        parts.append(payload)
        pos += len(header) + len(payload)
        channels.append(cid)
        if stamp < low:
            low = stamp
        if stamp > high:
            high = stamp
    buffer.write(b"".join(parts))
    return low, high, channels


def append_batch(
    frames: list[Frame],
    chunk: Callable[[], BinaryIO],
    close_chunk: Callable[[], None],
    threshold: int,
    batch: tuple[Any, FrameLayout, NDArray[np.int64], NDArray[np.int64]],
) -> None:
    """Append a batch of packed frames to a writer's open chunks, noting them in ``frames``.

    ``batch`` is ``(data, layout, stamps, action_stamps)``: ``len(stamps)`` frames back to back
    in the bytes-like ``data``. ``chunk()`` is the open chunk's buffer; ``close_chunk()`` writes
    it (indexing and clearing ``frames``) and opens the next. Frame by frame, writers close the
    chunk right after the first frame that ends beyond ``threshold``; the batch is split at the
    same frames, so that both give the same chunks.
    """
    data, layout, stamps, action_stamps = batch
    size, view, done = layout.size, memoryview(data).cast("B"), 0
    while done < len(stamps):
        buffer = chunk()
        pos = buffer.tell()
        end = done + min(len(stamps) - done, max(1, (threshold - pos) // size + 1))
        frames.append((layout, pos, stamps[done:end], action_stamps[done:end]))
        buffer.write(view[done * size : end * size])
        if pos + (end - done) * size > threshold:
            close_chunk()
        done = end


def index_entries(items: list[Any]) -> Iterator[NDArray[np.int64]]:
    """``(n, 2)`` arrays of ``(stamp, position)`` from index tuples and arrays, in order."""
    run: list[tuple[int, int]] = []
    for item in items:
        if isinstance(item, tuple):
            run.append(item)
            continue
        if run:
            yield np.array(run, dtype=np.int64)
            run = []
        yield item
    if run:
        yield np.array(run, dtype=np.int64)
