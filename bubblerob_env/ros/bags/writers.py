"""``rosbags``' bag writers with batch writes and packed frames: the one module on its internals.

Writing one message costs a ``rosbags`` writer a few microseconds; a recorder writes ~15 per env
step. These subclasses take a whole frame at once straight into the open chunk (MCAP, ROS 1) or one
``executemany`` (sqlite3). With one message per batch the files are identical to ``rosbags``' own
(``tests/ros/test_sinks.py`` checks), with two deliberate differences in ROS 1 bags: LZ4 chunks
use the frame options Debian's ``roslz4`` requires, and the bag header record has rosbag's size
(the first chunk starts 8 bytes later), so that ``rosbag reindex`` can rewrite it in place.
Faster still, MCAP and ROS 1 take *packed frames* (:meth:`Ros1Writer.write_packed`,
:meth:`Rosbag2Writer.write_packed`, see :mod:`~bubblerob_env.ros.fastpath.framing`), appended with
one write each and indexed when their chunk closes.

Every use of ``rosbags``' private API (classes of ``rosbags.rosbag1.writer`` and its storages,
attributes of its writers) is in this module, and :data:`RELIED_ON` lists it:
``tests/ros/test_rosbags_internals.py`` fails loudly when a ``rosbags`` release changes any of it.
``pyproject.toml`` pins ``rosbags`` to the tested range.
"""

from __future__ import annotations

import struct
import sys
import zlib
from collections import defaultdict
from collections.abc import Callable, Sequence
from io import BytesIO
from pathlib import Path
from typing import Any, BinaryIO

import lz4.frame
import numpy as np
from numpy.typing import NDArray
from rosbags import rosbag1, rosbag2
from rosbags.interfaces import Connection
from rosbags.rosbag1 import writer as _rosbag1_writer
from rosbags.rosbag1.reader import RecordType
from rosbags.rosbag1.writer import Header, WriteChunk
from rosbags.rosbag2 import CompressionMode, StoragePlugin
from rosbags.rosbag2.storage_mcap import McapWriter, PendingChunk, write_channel
from rosbags.rosbag2.storage_sqlite3 import Sqlite3Writer

from bubblerob_env.ros.bags.humble import rewrite_metadata
from bubblerob_env.ros.bags.mcap_crc import seal
from bubblerob_env.ros.fastpath.framing import (
    NO_TIME,
    Frame,
    FrameLayout,
    Record,
    append_batch,
    index_entries,
    index_frames,
    record_header,
)

if sys.version_info >= (3, 14):  # the zstd that rosbags uses
    from compression import zstd
else:  # pragma: no cover
    from backports import zstd

__all__ = [
    "RELIED_ON",
    "PackedBatchWriter",
    "PackedWriter",
    "Ros1Writer",
    "Rosbag2Writer",
    "roslz4_compress",
]

RELIED_ON: dict[Any, tuple[str, ...]] = {
    rosbag1.Writer: (
        "bio", "chunks", "chunk_threshold", "compressor", "compression_format", "connections",
        "write_connection", "write_chunk", "set_compression", "open", "close",
    ),
    WriteChunk: ("data", "pos", "start", "end", "connections"),
    Header: ("set_string", "set_uint32", "set_uint64", "set_time", "write"),
    RecordType: ("BAGHEADER", "CHUNK", "CHUNK_INFO", "IDXDATA"),
    rosbag2.Writer: (
        "STORAGE_PLUGINS", "storage", "counts", "min_timestamp", "max_timestamp", "open", "close",
    ),
    McapWriter: (
        "bio", "chunk", "chunks", "channel_stats", "compression", "compressor", "close_chunk",
        "message_start_time", "message_end_time", "channels", "schemas", "path",
        "add_connection",
    ),
    PendingChunk: ("message_start_time", "message_end_time", "bio", "msgs"),
    Sqlite3Writer: ("cursor", "conn"),
}  # fmt: skip
"""Names of ``rosbags``' private API this module uses, per class (instance attributes included)."""


def rosbags_changes() -> list[str]:
    """What of :data:`RELIED_ON` the installed ``rosbags`` lacks (empty: nothing changed).

    Instance attributes are looked up on a freshly opened writer of each kind.
    """
    import tempfile

    missing = []
    if _rosbag1_writer.MAXSIZE != NO_TIME:
        missing.append(f"rosbag1.writer.MAXSIZE is {_rosbag1_writer.MAXSIZE}, not {NO_TIME}")
    with tempfile.TemporaryDirectory() as tmp:
        ros1 = rosbag1.Writer(Path(tmp) / "x.bag")
        ros1.open()
        instances: dict[Any, Any] = {rosbag1.Writer: ros1, WriteChunk: ros1.chunks[-1]}
        for plugin in (StoragePlugin.MCAP, StoragePlugin.SQLITE3):
            ros2 = rosbag2.Writer(Path(tmp) / plugin.name, version=9, storage_plugin=plugin)
            ros2.open()
            instances[rosbag2.Writer] = ros2
            instances[type(ros2.storage)] = ros2.storage
            if isinstance(ros2.storage, McapWriter):
                instances[PendingChunk] = ros2.storage.chunk
            ros2.close()
        ros1.close()
        for owner, names in RELIED_ON.items():
            where = instances.get(owner, owner)
            missing += [f"{owner.__qualname__}.{n}" for n in names if not hasattr(where, n)]
    return missing


PackedWriter = Callable[[bytes, FrameLayout, int, int], None]
"""``write_packed(data, layout, stamp, action_stamp)`` of a writer."""
PackedBatchWriter = Callable[[Any, FrameLayout, NDArray[np.int64], NDArray[np.int64]], None]
"""``write_packed_batch(data, layout, stamps, action_stamps)``: ``len(stamps)`` packed frames."""


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


_INSERT_MESSAGE = "INSERT INTO messages (topic_id, timestamp, data) VALUES(?, ?, ?)"
"""rosbags' sqlite3 insert of one message row."""
_BAG_HEADER_POS = len(b"#ROSBAG V2.0\n")


def _write_bag_header(bio: BinaryIO, index_pos: int, conn_count: int, chunk_count: int) -> None:
    """The bag header record as ``rosbag`` writes it: fields and padding fill 4096 bytes.

    ``rosbags`` makes the whole record 4096 bytes, 8 fewer: the first chunk starts at 4109, not
    4117. Readers follow the lengths either way, but ``rosbag reindex`` rewrites the header in
    place at rosbag's size, which overwrote the first 8 bytes of the first chunk.
    """
    header = Header()
    header.set_uint64("index_pos", index_pos)
    header.set_uint32("conn_count", conn_count)
    header.set_uint32("chunk_count", chunk_count)
    fields = header.write(bio, RecordType.BAGHEADER) - 4  # it returns the length field too
    padding = 4096 - fields
    bio.write(struct.pack("<I", padding) + b" " * padding)


class Ros1Writer(rosbag1.Writer):
    """``rosbags``' ROS 1 writer with batch writes, roslz4-style LZ4 and rosbag's header size.

    The header size lets ``rosbag reindex`` repair a bag that was cut short (see
    :func:`_write_bag_header`).
    """

    _frames: list[Frame]

    def set_chunk_size(self, size: int) -> None:
        """Close each chunk once it holds more than ``size`` bytes."""
        self.chunk_threshold = size

    def set_compression(self, fmt: rosbag1.Writer.CompressionFormat) -> None:
        """Compress chunks with ``fmt`` (bz2, or LZ4 in the frame format roslz4 reads)."""
        super().set_compression(fmt)
        if self.compression_format == "lz4":
            self.compressor = roslz4_compress

    def open(self) -> None:
        """Create the bag file."""
        self._frames = []
        super().open()
        assert self.bio is not None
        self.bio.seek(_BAG_HEADER_POS)  # replace rosbags' header record: nothing follows it yet
        _write_bag_header(self.bio, 0, 0, 0)

    def close(self) -> None:
        """``rosbags``' own, record for record, but for the bag header's size."""
        assert self.bio is not None
        for chunk in self.chunks:
            if chunk.pos == -1:
                self.write_chunk(chunk)
        index_pos = self.bio.tell()
        for connection in self.connections:
            self.write_connection(connection, self.bio)
        chunks = [chunk for chunk in self.chunks if chunk.pos != -1]
        for chunk in chunks:
            header = Header()
            header.set_uint32("ver", 1)
            header.set_uint64("chunk_pos", chunk.pos)
            header.set_time("start_time", 0 if chunk.start == NO_TIME else chunk.start)
            header.set_time("end_time", chunk.end)
            header.set_uint32("count", len(chunk.connections))
            header.write(self.bio, RecordType.CHUNK_INFO)
            self.bio.write(struct.pack("<I", len(chunk.connections) * 8))
            for cid, items in chunk.connections.items():
                self.bio.write(struct.pack("<II", cid, len(items)))
        self.bio.seek(_BAG_HEADER_POS)
        _write_bag_header(self.bio, index_pos, len(self.connections), len(chunks))
        self.bio.close()
        self.bio = None

    def write_packed(self, data: bytes, layout: FrameLayout, stamp: int, action_stamp: int) -> None:
        """Append a packed frame (records framed by ``Framing("ros1", ...)``) to the open chunk."""
        chunk = self.chunks[-1]
        self._frames.append((layout, chunk.data.tell(), stamp, action_stamp))
        chunk.data.write(data)
        if chunk.data.tell() > self.chunk_threshold:
            self.write_chunk(chunk)

    def write_packed_batch(
        self, data: Any, layout: FrameLayout, stamps: NDArray[np.int64], action_stamps: Any
    ) -> None:
        """Append ``len(stamps)`` packed frames, back to back in ``data`` (a bytes-like object).

        The chunks close where they would frame by frame (:func:`append_batch`).
        """
        append_batch(
            self._frames,
            lambda: self.chunks[-1].data,
            lambda: self.write_chunk(self.chunks[-1]),
            self.chunk_threshold,
            (data, layout, stamps, action_stamps),
        )

    def _index_pending(self, chunk: WriteChunk) -> None:
        if self._frames:
            low, high, _ = index_frames(self._frames, chunk.connections)
            self._frames.clear()  # in place: append_batch holds the list
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
            header = record_header("ros1", cid, len(payload), stamp)
            parts.append(header)
            parts.append(payload)
            pos += len(header) + len(payload)
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
            with chunk.data.getbuffer() as raw:  # no copy of the chunk (released before close)
                data = self.compressor(raw)  # type: ignore[arg-type]
                self.bio.write(struct.pack("<I", len(data)))
                self.bio.write(data)
                del data  # the raw view itself when uncompressed
            for cid, items in chunk.connections.items():
                entries = np.concatenate(list(index_entries(items)))
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
            self.chunks.append(WriteChunk(BytesIO(), -1, NO_TIME, 0, defaultdict(list)))

    def flush(self) -> None:
        """Write the open chunk and its index records to disk (the bag index waits for close)."""
        assert self.bio is not None
        if self.chunks[-1].data.tell():
            self.write_chunk(self.chunks[-1])
        self.bio.flush()


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


def mcap_zstd_compress(data: bytes) -> bytes:
    """Compress with zstd at level 1, the MCAP writer's default (``CompressionLevel::Default``).

    ``rosbags`` compresses MCAP chunks at zstd's own default, 3: on recorded frames that takes
    ~1.6x the time of level 1 for chunks ~1% smaller.
    """
    return zstd.compress(data, level=1)


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
        index = chunk.msgs
        stats = self.channel_stats
        counts = self.counts
        pos = chunk.bio.tell()
        low = high = records[0][1]
        parts = []
        for topic, stamp, payload in records:
            cid = ids[topic]
            index[cid].append((stamp, pos))
            header = record_header("mcap", cid, len(payload), stamp)
            parts.append(header)
            parts.append(payload)
            pos += len(header) + len(payload)
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
        """Compress and write the open chunk, its message indexes, and start a new chunk."""
        self.index_pending()
        chunk = self.chunk
        encoding = self.compression.encode()
        chunk_start = self.bio.tell()
        with chunk.bio.getbuffer() as raw:  # no copy of the chunk (released before it goes)
            compressed = self.compressor(raw)  # type: ignore[arg-type]
            times = (chunk.message_start_time, chunk.message_end_time)
            head = struct.pack("<QQQI", *times, len(raw), zlib.crc32(raw))  # rosbags: 0
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

    def compress_at_level_1(self) -> None:
        """Compress zstd MCAP chunks at level 1 (:func:`mcap_zstd_compress`); after :meth:`open`."""
        if isinstance(self.storage, McapStorage) and self.storage.compression == "zstd":
            self.storage.compressor = mcap_zstd_compress

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
