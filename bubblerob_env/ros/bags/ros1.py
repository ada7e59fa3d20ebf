"""ROS 1 ``.bag`` writer: ``rosbags``' ROS 1 writer with batch writes and packed frames.

With one message per batch the files are identical to ``rosbags``' own (``tests/ros/test_sinks.py``
checks), with two deliberate differences: LZ4 chunks use the frame options Debian's ``roslz4``
requires, and the bag header record has rosbag's size (the first chunk starts 8 bytes later), so
that ``rosbag reindex`` can rewrite it in place.

It uses ``rosbags``' private API: :data:`~bubblerob_env.ros.bags.writers.RELIED_ON` lists it.
"""

from __future__ import annotations

import struct
from collections import defaultdict
from collections.abc import Sequence
from io import BytesIO
from typing import Any, BinaryIO

import lz4.frame
import numpy as np
from numpy.typing import NDArray
from rosbags import rosbag1
from rosbags.rosbag1.reader import RecordType
from rosbags.rosbag1.writer import Header, WriteChunk

from bubblerob_env.ros.fastpath.framing import (
    NO_TIME,
    Frame,
    FrameLayout,
    Record,
    append_batch,
    append_records,
    index_entries,
    index_frames,
)

__all__ = ["Ros1Writer", "roslz4_compress"]


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
        low, high, _ = append_records("ros1", chunk.data, chunk.connections, records, ids)
        chunk.start, chunk.end = min(chunk.start, low), max(chunk.end, high)
        if chunk.data.tell() > self.chunk_threshold:
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
