"""``rosbags``' bag writers with batch writes, byte for byte the files ``rosbags`` writes.

Writing one message costs a ``rosbags`` writer a few microseconds; a recorder writes ~15 per env
step. These subclasses take a whole frame at once straight into the open chunk (MCAP, ROS 1) or one
``executemany`` (sqlite3). With one message per batch the files are identical to ``rosbags``' own
(``tests/ros/test_sinks.py`` checks). One deliberate difference: ROS 1 LZ4 chunks use the frame
options Debian's ``roslz4`` requires.
"""

from __future__ import annotations

import struct
from collections import defaultdict
from collections.abc import Sequence
from io import BytesIO

import lz4.frame  # type: ignore[import-untyped]
import numpy as np
from rosbags import rosbag1, rosbag2
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2.storage_mcap import McapWriter, PendingChunk
from rosbags.rosbag2.storage_sqlite3 import Sqlite3Writer

__all__ = ["Record", "Ros1Writer", "Rosbag2Writer", "roslz4_compress"]

Record = tuple[str, int, bytes]
"""``(topic, log time in ns, serialised message)``."""

_MCAP_MESSAGE = struct.Struct("<BQHIQQ")  # opcode, length, channel, sequence, log/publish time
_ROS1_MESSAGE = struct.Struct("<II4sI5sII5sIII")  # header length, op, conn, time; data length


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

    def set_compression(self, fmt: rosbag1.Writer.CompressionFormat) -> None:
        """Compress chunks with ``fmt`` (bz2, or LZ4 in the frame format roslz4 reads)."""
        super().set_compression(fmt)
        if self.compression_format == "lz4":
            self.compressor = roslz4_compress

    def write_many(self, records: Sequence[Record], ids: dict[str, int]) -> None:
        """Append ``(topic, stamp, data)`` records to the open chunk (``ids``: topic -> conn)."""
        chunk = self.chunks[-1]
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

    def write_many(
        self, records: Sequence[Record], ids: dict[str, int], counts: dict[int, int]
    ) -> tuple[int, int]:
        """Append ``(topic, stamp, data)`` records; returns their lowest and highest stamps."""
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
        if pos > 2**20:
            self.close_chunk()
        return low, high

    def close_chunk(self) -> None:
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
            entries = np.asarray(msgs, dtype="<u8").tobytes()
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

    def flush(self) -> None:
        """MCAP: write the open chunk; sqlite3: commit. The summary waits for close."""
        storage = self.storage
        assert isinstance(storage, (_McapStorage, _Sqlite3Storage))
        storage.flush()
