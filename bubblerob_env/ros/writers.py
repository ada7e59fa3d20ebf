"""``rosbags``' bag writers with batch writes, byte for byte the files ``rosbags`` writes.

Writing one message costs a ``rosbags`` writer a few microseconds; a recorder writes ~15 per env
step. These subclasses take a whole frame at once straight into the open chunk (MCAP, ROS 1) or one
``executemany`` (sqlite3). With one message per batch the files are identical to ``rosbags``' own
(``tests/ros/test_sinks.py`` checks). One deliberate difference: ROS 1 LZ4 chunks use the frame
options Debian's ``roslz4`` requires.

Faster still, MCAP and ROS 1 take *packed frames* (:meth:`Rosbag2Writer.write_packed`,
:meth:`Ros1Writer.write_packed`): a frame's records, headers included, laid out by
:class:`Framing` and packed by one ``struct`` call upstream, appended with one write. Their index
entries are built when the chunk closes, with numpy, from each frame's position and stamps and its
:class:`FrameLayout`; the bytes are those the same records written one by one give.
"""

from __future__ import annotations

import struct
import sys
from collections import defaultdict
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from io import BytesIO
from pathlib import Path
from typing import Any

import lz4.frame  # type: ignore[import-untyped]
import numpy as np
from numpy.typing import NDArray
from rosbags import rosbag1, rosbag2
from rosbags.rosbag1.writer import MAXSIZE, Header, RecordType, WriteChunk
from rosbags.rosbag2 import CompressionMode, StoragePlugin
from rosbags.rosbag2.storage_mcap import McapWriter, PendingChunk
from rosbags.rosbag2.storage_sqlite3 import Sqlite3Writer

from bubblerob_env.ros.encode import Item, Slot

if sys.version_info >= (3, 14):  # the zstd that rosbags uses
    from compression import zstd
else:  # pragma: no cover
    from backports import zstd

__all__ = [
    "FrameLayout",
    "Framing",
    "Record",
    "Ros1Writer",
    "Rosbag2Writer",
    "mcap_zstd_compress",
    "roslz4_compress",
]

Record = tuple[str, int, bytes]
"""``(topic, log time in ns, serialised message)``."""

LOG_SLOTS = ("log_ns", "log_sec", "log_nsec")
"""Slot names of a record's log time in :meth:`Framing.header` (ns; ROS 1: sec and nsec); records
logged at the action's stamp use them prefixed with ``action_``."""


@dataclass(frozen=True)
class Framing:
    """The header a writer puts before each message record in a chunk, as ``struct`` items.

    ``kind`` is ``"mcap"`` or ``"ros1"``; ``ids`` maps each topic to its channel (MCAP) or
    connection (ROS 1) id. Two sinks with equal framings take the same packed bytes.
    """

    kind: str
    ids: tuple[tuple[str, int], ...]

    def header(self, topic: str, size: int, action: bool) -> list[Item]:
        """Items of the header of a ``size``-byte message on ``topic`` (see :data:`LOG_SLOTS`)."""
        cid = dict(self.ids)[topic]
        prefix = "action_" if action else ""
        if self.kind == "mcap":
            stamp = Slot(prefix + "log_ns")
            return [("B", 0x05), ("Q", 22 + size), ("H", cid), ("I", 0), ("Q", stamp), ("Q", stamp)]
        if self.kind == "ros1":
            sec, nsec = Slot(prefix + "log_sec"), Slot(prefix + "log_nsec")
            return [
                ("I", 38), ("I", 4), ("4s", b"op=\x02"), ("I", 9), ("5s", b"conn="), ("I", cid),
                ("I", 13), ("5s", b"time="), ("I", sec), ("I", nsec), ("I", size),
            ]  # fmt: skip
        raise ValueError(f"unknown framing {self.kind!r}")


@dataclass(frozen=True, eq=False)
class FrameLayout:
    """Where the records of a packed frame start, their channel ids, and which stamp each has.

    ``action[i]``: record ``i`` is logged at the action's stamp, else at the frame's.
    """

    channels: tuple[int, ...]
    offsets: tuple[int, ...]
    action: tuple[bool, ...]
    size: int

    @property
    def has_action(self) -> bool:
        """Whether any record is logged at the action's stamp."""
        return any(self.action)


_Frame = tuple[FrameLayout, int, int, int]  # layout, position in the chunk, stamp, action stamp
_Index = dict[int, list[Any]]  # channel -> (stamp, position) tuples and (n, 2) arrays of them


def _index_frames(frames: list[_Frame], index: _Index) -> tuple[int, int, dict[int, int]]:
    """Append the index entries of ``frames`` to ``index``, in the order records were written.

    Returns the lowest and highest log time and the number of records per channel.
    """
    low, high = MAXSIZE, 0
    counts: dict[int, int] = defaultdict(int)
    start = 0
    while start < len(frames):
        layout = frames[start][0]
        end = start + 1
        while end < len(frames) and frames[end][0] is layout:
            end += 1
        block = np.array([frame[1:] for frame in frames[start:end]], dtype=np.int64)
        stamps = {False: block[:, 1], True: block[:, 2]}
        for cid, offset, action in zip(layout.channels, layout.offsets, layout.action, strict=True):
            entries = np.empty((end - start, 2), dtype=np.int64)
            entries[:, 0] = stamps[action]
            entries[:, 1] = block[:, 0] + offset
            index[cid].append(entries)
            counts[cid] += end - start
        for action in set(layout.action):
            low = min(low, int(stamps[action].min()))
            high = max(high, int(stamps[action].max()))
        start = end
    return low, high, counts


def _entries(items: list[Any]) -> Iterator[NDArray[np.int64]]:
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


_MCAP_MESSAGE = struct.Struct("<BQHIQQ")  # opcode, length, channel, sequence, log/publish time
_ROS1_MESSAGE = struct.Struct("<II4sI5sII5sIII")  # header length, op, conn, time; data length


def mcap_zstd_compress(data: bytes) -> bytes:
    """Compress with zstd at level 1, the MCAP writer's default (``CompressionLevel::Default``).

    ``rosbags`` compresses MCAP chunks at zstd's own default, 3: on recorded frames that takes
    ~1.6x the time of level 1 for chunks ~1% smaller.
    """
    return zstd.compress(data, level=1)


def roslz4_compress(data: bytes) -> bytes:
    """LZ4 frame as ROS 1's ``roslz4`` reads it: independent blocks, no content size, checksum.

    ``rosbags`` compresses with ``lz4.frame``'s defaults (linked blocks, content size, no
    checksum), which Debian's ``rosbag`` rejects as "malformed data".
    """
    return lz4.frame.compress(  # type: ignore[no-any-return]
        data,
        compression_level=0,
        block_size=lz4.frame.BLOCKSIZE_MAX1MB,
        block_linked=False,
        content_checksum=True,
        store_size=False,
    )


class Ros1Writer(rosbag1.Writer):
    """``rosbags``' ROS 1 writer with a batch write into the open chunk, and roslz4-style LZ4."""

    _frames: list[_Frame]

    def set_compression(self, fmt: rosbag1.Writer.CompressionFormat) -> None:
        """Compress chunks with ``fmt`` (bz2, or LZ4 in the frame format roslz4 reads)."""
        super().set_compression(fmt)
        if self.compression_format == "lz4":
            self.compressor = roslz4_compress

    def open(self) -> None:
        """Create the bag file."""
        self._frames = []
        super().open()

    def write_packed(self, data: bytes, layout: FrameLayout, stamp: int, action_stamp: int) -> None:
        """Append a packed frame (records framed by ``Framing("ros1", ...)``) to the open chunk."""
        chunk = self.chunks[-1]
        self._frames.append((layout, chunk.data.tell(), stamp, action_stamp))
        chunk.data.write(data)
        if chunk.data.tell() > self.chunk_threshold:
            self.write_chunk(chunk)

    def _index_pending(self, chunk: WriteChunk) -> None:
        if self._frames:
            low, high, _ = _index_frames(self._frames, chunk.connections)
            self._frames = []
            chunk.start, chunk.end = min(chunk.start, low), max(chunk.end, high)

    def write_many(self, records: Sequence[Record], ids: dict[str, int]) -> None:
        """Append ``(topic, stamp, data)`` records to the open chunk (``ids``: topic -> conn)."""
        chunk = self.chunks[-1]
        self._index_pending(chunk)
        index = chunk.connections
        pos = chunk.data.tell()
        low, high = chunk.start, chunk.end
        parts = []
        for topic, stamp, payload in records:
            cid = ids[topic]
            index[cid].append((stamp, pos))
            sec, nsec = divmod(stamp, 1_000_000_000)
            size = len(payload)
            parts.append(
                _ROS1_MESSAGE.pack(
                    38, 4, b"op=\x02", 9, b"conn=", cid, 13, b"time=", sec, nsec, size
                )
            )
            parts.append(payload)
            pos += 46 + size
            if stamp < low:
                low = stamp
            if stamp > high:
                high = stamp
        chunk.data.write(b"".join(parts))
        chunk.start, chunk.end = low, high
        if pos > self.chunk_threshold:
            self.write_chunk(chunk)

    def write_chunk(self, chunk: WriteChunk) -> None:
        """``rosbags``' own, record for record, with each index data record packed by numpy."""
        assert self.bio is not None
        self._index_pending(chunk)
        if (size := chunk.data.tell()) > 0:
            chunk.pos = self.bio.tell()
            header = Header()
            header.set_string("compression", self.compression_format)
            header.set_uint32("size", size)
            header.write(self.bio, RecordType.CHUNK)
            data = self.compressor(chunk.data.getvalue())
            self.bio.write(struct.pack("<I", len(data)) + data)
            for cid, items in chunk.connections.items():
                entries = np.concatenate(list(_entries(items)))
                packed = np.empty((len(entries), 3), dtype="<u4")
                packed[:, 0], packed[:, 1] = np.divmod(entries[:, 0], 1_000_000_000)
                packed[:, 2] = entries[:, 1]
                header = Header()
                header.set_uint32("ver", 1)
                header.set_uint32("conn", cid)
                header.set_uint32("count", len(entries))
                header.write(self.bio, RecordType.IDXDATA)
                self.bio.write(struct.pack("<I", packed.nbytes) + packed.tobytes())
                # close() only counts them: keep the count, not the entries
                chunk.connections[cid] = [(0, 0)] * len(entries)
            chunk.data.close()
            self.chunks.append(WriteChunk(BytesIO(), -1, MAXSIZE, 0, defaultdict(list)))

    def flush(self) -> None:
        """Write the open chunk and its index records to disk (the bag index waits for close)."""
        assert self.bio is not None
        if self.chunks[-1].data.tell():
            self.write_chunk(self.chunks[-1])
        self.bio.flush()


class _McapStorage(McapWriter):
    """``rosbags``' MCAP storage with a batch write into the open chunk.

    ``close_chunk`` is ``rosbags``' own, record for record, with the message indexes packed in one
    call instead of two calls per message.
    """

    CHUNK_SIZE = 2**20
    """A chunk closes once it holds more than this many bytes (``rosbags``' size)."""

    def __init__(self, path: Path, compression: CompressionMode) -> None:
        super().__init__(path, compression)
        self._frames: list[_Frame] = []
        self._counts: dict[int, int] = defaultdict(int)  # the writer's, from write_packed

    def write_packed(
        self,
        data: bytes,
        layout: FrameLayout,
        stamp: int,
        action_stamp: int,
        counts: dict[int, int],
    ) -> None:
        """Append a packed frame (records framed by ``Framing("mcap", ...)``) to the open chunk."""
        bio = self.chunk.bio
        pos = bio.tell()
        self._counts = counts
        self._frames.append((layout, pos, stamp, action_stamp))
        bio.write(data)
        if pos + layout.size > self.CHUNK_SIZE:
            self.close_chunk()

    def index_pending(self) -> None:
        """Index the packed frames written so far and count their messages."""
        if self._frames:
            chunk = self.chunk
            low, high, counts = _index_frames(self._frames, chunk.msgs)  # type: ignore[arg-type]
            self._frames = []
            for cid, count in counts.items():
                self.channel_stats[cid] += count
                self._counts[cid] += count
            chunk.message_start_time = min(chunk.message_start_time, low)
            chunk.message_end_time = max(chunk.message_end_time, high)
            self.message_start_time = min(self.message_start_time, low)
            self.message_end_time = max(self.message_end_time, high)

    def write_many(
        self, records: Sequence[Record], ids: dict[str, int], counts: dict[int, int]
    ) -> tuple[int, int]:
        """Append ``(topic, stamp, data)`` records; returns their lowest and highest stamps."""
        self.index_pending()
        chunk = self.chunk
        index = chunk.msgs
        stats = self.channel_stats
        pos = chunk.bio.tell()
        low = high = records[0][1]
        parts = []
        for topic, stamp, payload in records:
            cid = ids[topic]
            size = len(payload)
            index[cid].append((stamp, pos))
            parts.append(_MCAP_MESSAGE.pack(0x05, 22 + size, cid, 0, stamp, stamp))
            parts.append(payload)
            pos += 31 + size
            stats[cid] += 1
            counts[cid] += 1
            if stamp < low:
                low = stamp
            if stamp > high:
                high = stamp
        chunk.bio.write(b"".join(parts))
        chunk.message_start_time = min(chunk.message_start_time, low)
        chunk.message_end_time = max(chunk.message_end_time, high)
        self.message_start_time = min(self.message_start_time, low)
        self.message_end_time = max(self.message_end_time, high)
        if pos > self.CHUNK_SIZE:
            self.close_chunk()
        return low, high

    def close_chunk(self) -> None:
        self.index_pending()
        chunk = self.chunk
        raw = chunk.bio.getvalue()
        compressed = self.compressor(raw)
        encoding = self.compression.encode()
        head = struct.pack("<QQQI", chunk.message_start_time, chunk.message_end_time, len(raw), 0)
        body = head + struct.pack("<I", len(encoding)) + encoding
        body += struct.pack("<Q", len(compressed))
        chunk_start = self.bio.tell()
        self.bio.write(struct.pack("<BQ", 0x06, len(body) + len(compressed)) + body)
        self.bio.write(compressed)
        chunk_end = self.bio.tell()

        offsets = []
        for cid, msgs in chunk.msgs.items():
            offsets.append((cid, self.bio.tell()))
            entries = b"".join(part.astype("<u8").tobytes() for part in _entries(msgs))
            record = struct.pack("<HI", cid, len(entries)) + entries
            self.bio.write(struct.pack("<BQ", 0x07, len(record)) + record)

        index = struct.pack(
            "<QQQQI",
            chunk.message_start_time,
            chunk.message_end_time,
            chunk_start,
            chunk_end - chunk_start,
            len(offsets) * 10,
        )
        index += b"".join(struct.pack("<HQ", cid, offset) for cid, offset in offsets)
        index += struct.pack("<QI", self.bio.tell() - chunk_end, len(encoding)) + encoding
        index += struct.pack("<QQ", len(compressed), len(raw))
        chunk_index = BytesIO()  # rosbags writes it at close, sized by its position
        chunk_index.write(index)
        self.chunks.append(chunk_index)
        self.chunk = PendingChunk(2**63 - 1, 0, BytesIO(), defaultdict(list))

    def flush(self) -> None:
        if self.chunk.bio.tell():
            self.close_chunk()
        self.bio.flush()


class _Sqlite3Storage(Sqlite3Writer):
    """``rosbags``' sqlite3 storage with a batch insert."""

    def write_many(
        self, records: Sequence[Record], ids: dict[str, int], counts: dict[int, int]
    ) -> tuple[int, int]:
        """Insert ``(topic, stamp, data)`` records; returns their lowest and highest stamps."""
        rows = [(ids[topic], stamp, payload) for topic, stamp, payload in records]
        self.cursor.executemany(
            "INSERT INTO messages (topic_id, timestamp, data) VALUES(?, ?, ?)", rows
        )
        for cid, _, _ in rows:
            counts[cid] += 1
        stamps = [stamp for _, stamp, _ in rows]
        return min(stamps), max(stamps)

    def flush(self) -> None:
        self.conn.commit()


class Rosbag2Writer(rosbag2.Writer):
    """``rosbags``' ROS 2 writer whose MCAP and sqlite3 storages take batches."""

    STORAGE_PLUGINS = {StoragePlugin.SQLITE3: _Sqlite3Storage, StoragePlugin.MCAP: _McapStorage}

    def write_many(self, records: Sequence[Record], ids: dict[str, int]) -> None:
        """Append ``(topic, stamp, data)`` records, keeping ``rosbags``' statistics."""
        storage = self.storage
        assert isinstance(storage, (_McapStorage, _Sqlite3Storage))
        low, high = storage.write_many(records, ids, self.counts)
        self.min_timestamp = min(self.min_timestamp, low)
        self.max_timestamp = max(self.max_timestamp, high)

    def write_packed(self, data: bytes, layout: FrameLayout, stamp: int, action_stamp: int) -> None:
        """MCAP: append a packed frame (records framed by ``Framing("mcap", ...)``)."""
        storage = self.storage
        assert isinstance(storage, _McapStorage)
        storage.write_packed(data, layout, stamp, action_stamp, self.counts)
        if layout.has_action:
            low, high = min(stamp, action_stamp), max(stamp, action_stamp)
            self.min_timestamp = min(self.min_timestamp, low)
            self.max_timestamp = max(self.max_timestamp, high)
        else:
            self.min_timestamp = min(self.min_timestamp, stamp)
            self.max_timestamp = max(self.max_timestamp, stamp)

    def close(self) -> None:
        """Index pending packed frames (counts go into metadata.yaml), then ``rosbags``' close."""
        if isinstance(self.storage, _McapStorage):
            self.storage.index_pending()
        super().close()

    def flush(self) -> None:
        """MCAP: write the open chunk; sqlite3: commit. The summary waits for close."""
        storage = self.storage
        assert isinstance(storage, (_McapStorage, _Sqlite3Storage))
        storage.flush()
