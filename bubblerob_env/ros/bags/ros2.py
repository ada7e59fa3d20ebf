"""ROS 2 bag writer: ``rosbags``' ROS 2 writer whose MCAP and sqlite3 storages take batches.

The MCAP storage also takes packed frames (:meth:`McapStorage.write_packed`, see
:mod:`~bubblerob_env.ros.fastpath.framing`), writes chunk CRCs and Jazzy's ``topic_type_hash``
channel metadata; sqlite3 inserts a batch with one ``executemany``.

It uses ``rosbags``' private API: :data:`~bubblerob_env.ros.bags.writers.RELIED_ON` lists it.
"""

from __future__ import annotations

import struct
import sys
from collections import defaultdict
from collections.abc import Callable, Sequence
from io import BytesIO
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from rosbags import rosbag2
from rosbags.interfaces import Connection
from rosbags.rosbag2 import CompressionMode, StoragePlugin
from rosbags.rosbag2.storage_mcap import McapWriter, PendingChunk, write_channel
from rosbags.rosbag2.storage_sqlite3 import Sqlite3Writer

from bubblerob_env.ros.bags.humble import rewrite_metadata
from bubblerob_env.ros.bags.mcap_crc import crc_beside, seal
from bubblerob_env.ros.fastpath.framing import (
    Frame,
    FrameLayout,
    PackedBatchWriter,
    PackedWriter,
    Record,
    append_batch,
    append_records,
    index_entries,
    index_frames,
)

if sys.version_info >= (3, 14):  # the zstd that rosbags uses
    from compression import zstd
else:  # pragma: no cover
    from backports import zstd

__all__ = [
    "MCAP_ZSTD_LEVEL",
    "McapStorage",
    "Rosbag2Writer",
    "mcap_zstd_compress",
    "mcap_zstd_compressor",
]

_INSERT_MESSAGE = "INSERT INTO messages (topic_id, timestamp, data) VALUES(?, ?, ?)"
"""rosbags' sqlite3 insert of one message row."""


class _Sqlite3Storage(Sqlite3Writer):
    """``rosbags``' sqlite3 storage with a batch insert."""

    def write_many(
        self, records: Sequence[Record], ids: dict[str, int], counts: dict[int, int]
    ) -> tuple[int, int]:
        """Insert ``(topic, stamp, data)`` records; returns their lowest and highest stamps."""
        rows = [(ids[topic], stamp, payload) for topic, stamp, payload in records]
        self.cursor.executemany(_INSERT_MESSAGE, rows)
        for cid, _, _ in rows:
            counts[cid] += 1
        stamps = [stamp for _, stamp, _ in rows]
        return min(stamps), max(stamps)

    def write_packed_batch(
        self,
        data: Any,
        layout: FrameLayout,
        stamps: NDArray[np.int64],
        action_stamps: NDArray[np.int64],
        counts: dict[int, int],
    ) -> tuple[int, int]:
        """Insert the messages of packed frames (``Framing("raw", ...)``); lowest, highest stamp."""
        size = layout.size
        spans = layout.spans()
        view = memoryview(data).cast("B")
        rows = []
        for index, (stamp, action_stamp) in enumerate(
            zip(stamps.tolist(), action_stamps.tolist(), strict=True)
        ):
            base = index * size
            for cid, start, end, action in spans:
                logged = action_stamp if action else stamp
                rows.append((cid, logged, view[base + start : base + end]))
        self.cursor.executemany(_INSERT_MESSAGE, rows)
        for cid in layout.channels:
            counts[cid] += len(stamps)
        used = [stamps] if not all(layout.action) else []
        used += [action_stamps] if layout.has_action else []
        return min(int(s.min()) for s in used), max(int(s.max()) for s in used)

    def flush(self) -> None:
        self.conn.commit()


def _mcap_string(text: str) -> bytes:
    data = text.encode()
    return struct.pack("<I", len(data)) + data


MCAP_ZSTD_LEVEL = -3
"""zstd level of MCAP chunks: the MCAP writer's ``CompressionLevel::Fast``.

On recorded frames (camera off, ~3.3 kB a step) level -3 compresses at ~2.1x the speed of level 1
(the MCAP writer's default, which bags used before 2026-11-28: ~5 -> ~2.4 us a step) into chunks
~13% larger (ratio 1.79 against 2.03); ``rosbags``' own default, 3, takes ~1.4x level 1's time
for chunks ~1% smaller than level 1's. The level is not stored: every zstd reader (rosbags, the
mcap library, Foxglove) reads any level."""


def mcap_zstd_compressor() -> Callable[[bytes], bytes]:
    """A compressor of MCAP chunks at :data:`MCAP_ZSTD_LEVEL`, one zstd frame per chunk.

    It keeps one zstd context for every chunk (``zstd.compress`` makes and frees one a call,
    ~10% of a 500 kB chunk's time); the frames are byte for byte those of ``zstd.compress``.
    One per writer: a context is not for two threads at once.
    """
    context = zstd.ZstdCompressor(level=MCAP_ZSTD_LEVEL)
    frame = zstd.ZstdCompressor.FLUSH_FRAME

    def compress(data: bytes) -> bytes:
        compressed: bytes = context.compress(data, mode=frame)
        return compressed

    return compress


def mcap_zstd_compress(data: bytes) -> bytes:
    """Compress one chunk at :data:`MCAP_ZSTD_LEVEL` (a context for this call only)."""
    compressed: bytes = zstd.compress(data, level=MCAP_ZSTD_LEVEL)
    return compressed


class McapStorage(McapWriter):
    """``rosbags``' MCAP storage with a batch write and packed frames into the open chunk."""

    CHUNK_SIZE = 2**20
    """A chunk closes once it holds more than this many bytes (``rosbags``' size)."""

    def __init__(self, path: Path, compression: CompressionMode) -> None:
        super().__init__(path, compression)
        self._frames: list[Frame] = []
        self.counts: dict[int, int] = defaultdict(int)
        """Messages per channel, the writer's (it replaces this dict with its own)."""
        self.packed_start, self.packed_end = 2**63 - 1, 0
        """Lowest and highest log time of the packed frames indexed so far."""
        self.type_hashes = True
        """Put each channel's RIHS01 type hash in its metadata (``topic_type_hash``), as
        rosbag2 does since Iron (metadata version 7); Humble's channels have none."""

    def add_connection(self, connection: Connection, offered_qos_profiles: str) -> None:
        """Add a channel with ``offered_qos_profiles`` and, if on, ``topic_type_hash``."""
        channel_at = self.chunk.bio.tell()
        super().add_connection(connection, offered_qos_profiles)
        if self.type_hashes and connection.digest:
            channel = self.channels[-1]
            metadata = channel.metadata + _mcap_string("topic_type_hash")
            metadata += _mcap_string(connection.digest)
            self.channels[-1] = channel._replace(metadata=metadata)
            chunk = self.chunk.bio  # rewrite the channel record rosbags just put in the chunk
            chunk.seek(channel_at)
            chunk.truncate()
            write_channel(chunk, self.channels[-1], self.schemas)

    def write_packed(self, data: bytes, layout: FrameLayout, stamp: int, action_stamp: int) -> None:
        """Append a packed frame (records framed by ``Framing("mcap", ...)``) to the open chunk.

        Called once per recorded step, so kept to the append: counts and times come with the index
        (:meth:`index_pending`).
        """
        bio = self.chunk.bio
        pos = bio.tell()
        self._frames.append((layout, pos, stamp, action_stamp))
        bio.write(data)
        if pos + layout.size > self.CHUNK_SIZE:
            self.close_chunk()

    def write_packed_batch(
        self, data: Any, layout: FrameLayout, stamps: NDArray[np.int64], action_stamps: Any
    ) -> None:
        """Append ``len(stamps)`` packed frames, back to back in ``data`` (a bytes-like object).

        The chunks close where they would frame by frame (:func:`append_batch`).
        """
        batch = (data, layout, stamps, action_stamps)
        append_batch(self._frames, lambda: self.chunk.bio, self.close_chunk, self.CHUNK_SIZE, batch)

    def index_pending(self) -> None:
        """Index the packed frames written so far and count their messages."""
        if self._frames:
            chunk = self.chunk
            low, high, counts = index_frames(self._frames, chunk.msgs)
            self._frames.clear()  # in place: append_batch holds the list
            for cid, count in counts.items():
                self.channel_stats[cid] += count
                self.counts[cid] += count
            chunk.message_start_time = min(chunk.message_start_time, low)
            chunk.message_end_time = max(chunk.message_end_time, high)
            self.message_start_time = min(self.message_start_time, low)
            self.message_end_time = max(self.message_end_time, high)
            self.packed_start = min(self.packed_start, low)
            self.packed_end = max(self.packed_end, high)

    def write_many(self, records: Sequence[Record], ids: dict[str, int]) -> tuple[int, int]:
        """Append ``(topic, stamp, data)`` records; returns their lowest and highest stamps."""
        self.index_pending()
        chunk = self.chunk
        low, high, channels = append_records("mcap", chunk.bio, chunk.msgs, records, ids)
        stats, counts = self.channel_stats, self.counts
        for cid in channels:
            stats[cid] += 1
            counts[cid] += 1
        chunk.message_start_time = min(chunk.message_start_time, low)
        chunk.message_end_time = max(chunk.message_end_time, high)
        self.message_start_time = min(self.message_start_time, low)
        self.message_end_time = max(self.message_end_time, high)
        if chunk.bio.tell() > self.CHUNK_SIZE:
            self.close_chunk()
        return low, high

    def close_chunk(self) -> None:
        """Compress and write the open chunk, its message indexes, and start a new chunk."""
        self.index_pending()
        chunk = self.chunk
        encoding = self.compression.encode()
        chunk_start = self.bio.tell()
        with chunk.bio.getbuffer() as raw:  # no copy of the chunk (released before it goes)
            crc, compressed = crc_beside(raw, self.compressor)  # type: ignore[arg-type]
            times = (chunk.message_start_time, chunk.message_end_time)
            head = struct.pack("<QQQI", *times, len(raw), crc)  # rosbags: 0
            body = head + struct.pack("<I", len(encoding)) + encoding
            body += struct.pack("<Q", len(compressed))
            self.bio.write(struct.pack("<BQ", 0x06, len(body) + len(compressed)) + body)
            self.bio.write(compressed)
            raw_size, compressed_size = len(raw), len(compressed)
            del compressed  # the raw view itself when uncompressed
        chunk_end = self.bio.tell()

        offsets = []
        for cid, msgs in chunk.msgs.items():
            offsets.append((cid, self.bio.tell()))
            entries = b"".join(part.astype("<u8").tobytes() for part in index_entries(msgs))
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
        index += struct.pack("<QQ", compressed_size, raw_size)
        chunk_index = BytesIO()  # rosbags writes it at close, sized by its position
        chunk_index.write(index)
        self.chunks.append(chunk_index)
        self.chunk = PendingChunk(2**63 - 1, 0, BytesIO(), defaultdict(list))

    def flush(self) -> None:
        """Write the open chunk and its message indexes to disk (the summary waits for close)."""
        if self.chunk.bio.tell():
            self.close_chunk()
        self.bio.flush()


class Rosbag2Writer(rosbag2.Writer):
    """``rosbags``' ROS 2 writer whose MCAP and sqlite3 storages take batches."""

    STORAGE_PLUGINS = {StoragePlugin.SQLITE3: _Sqlite3Storage, StoragePlugin.MCAP: McapStorage}
    humble = False
    """Write Humble's format (version 8 here, metadata.yaml rewritten as version 5 at close)."""

    def open(self) -> None:
        """Create the bag; the MCAP storage counts packed frames into this writer's counts."""
        super().open()
        if isinstance(self.storage, McapStorage):
            self.storage.counts = self.counts
            self.storage.type_hashes = self.version >= 7 and not self.humble

    def compress_chunks_fast(self) -> None:
        """Compress zstd MCAP chunks at :data:`MCAP_ZSTD_LEVEL` (:func:`mcap_zstd_compressor`).

        Call after :meth:`open`.
        """
        if isinstance(self.storage, McapStorage) and self.storage.compression == "zstd":
            self.storage.compressor = mcap_zstd_compressor()

    def set_chunk_size(self, size: int) -> None:
        """MCAP: close each chunk once it holds more than ``size`` bytes (sqlite3: no chunks)."""
        if isinstance(self.storage, McapStorage):
            self.storage.CHUNK_SIZE = size

    def write_many(self, records: Sequence[Record], ids: dict[str, int]) -> None:
        """Append ``(topic, stamp, data)`` records, keeping ``rosbags``' statistics."""
        storage = self.storage
        if isinstance(storage, McapStorage):
            low, high = storage.write_many(records, ids)
        else:
            assert isinstance(storage, _Sqlite3Storage)
            low, high = storage.write_many(records, ids, self.counts)
        self.min_timestamp = min(self.min_timestamp, low)
        self.max_timestamp = max(self.max_timestamp, high)

    def packed_writer(self) -> PackedWriter:
        """The storage's ``write_packed`` (MCAP; the index keeps the counts), else a batch of 1."""
        storage = self.storage
        if isinstance(storage, McapStorage):
            return storage.write_packed
        write_batch = self.packed_batch_writer()

        def write(data: bytes, layout: FrameLayout, stamp: int, action_stamp: int) -> None:
            write_batch(data, layout, np.array([stamp]), np.array([action_stamp]))

        return write

    def packed_batch_writer(self) -> PackedBatchWriter:
        """The storage's ``write_packed_batch`` (sqlite3: keeping ``rosbags``' statistics)."""
        storage = self.storage
        if isinstance(storage, McapStorage):
            return storage.write_packed_batch
        assert isinstance(storage, _Sqlite3Storage)

        def write(data: Any, layout: FrameLayout, stamps: Any, action_stamps: Any) -> None:
            low, high = storage.write_packed_batch(data, layout, stamps, action_stamps, self.counts)
            self.min_timestamp = min(self.min_timestamp, low)
            self.max_timestamp = max(self.max_timestamp, high)

        return write

    def write_packed(self, data: bytes, layout: FrameLayout, stamp: int, action_stamp: int) -> None:
        """Append a packed frame (records framed by ``Framing("mcap"|"raw", ...)``)."""
        self.packed_writer()(data, layout, stamp, action_stamp)

    def close(self) -> None:
        """Index pending packed frames (counts and times go into metadata.yaml), then close.

        MCAP: then write the file's CRCs (:func:`~bubblerob_env.ros.bags.mcap_crc.seal`).
        """
        storage = self.storage
        if isinstance(storage, McapStorage):
            storage.index_pending()
            self.min_timestamp = min(self.min_timestamp, storage.packed_start)
            self.max_timestamp = max(self.max_timestamp, storage.packed_end)
        super().close()
        if isinstance(storage, McapStorage):
            seal(storage.path)
        if self.humble:
            rewrite_metadata(self.path / "metadata.yaml")

    def flush(self) -> None:
        """MCAP: write the open chunk; sqlite3: commit. The summary waits for close."""
        storage = self.storage
        assert isinstance(storage, (McapStorage, _Sqlite3Storage))
        storage.flush()
