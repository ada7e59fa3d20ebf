"""Bag sinks: batch writes equal rosbags' own writes; bad paths fail early and clearly."""

from __future__ import annotations

import os
import random
import sqlite3
import struct
from pathlib import Path

import lz4.frame
import pytest
from mcap.stream_reader import StreamReader
from rosbags import rosbag1, rosbag2
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin

from bubblerob_env.ros.bags.sinks import BagPathError, open_bag
from bubblerob_env.ros.bags.writers import Ros1Writer, Rosbag2Writer, roslz4_compress
from bubblerob_env.ros.messages.distros import typestore

TOPICS = ("/a", "/b")


@pytest.fixture
def records():
    rng = random.Random(0)
    return [
        (rng.randrange(2), 10**9 + i * 5_000_000, rng.randbytes(rng.randrange(1, 4000)))
        for i in range(600)
    ]


@pytest.mark.parametrize("compression", [None, "BZ2"])
def test_ros1_batch_writes_are_byte_identical_to_rosbags(tmp_path, records, compression):
    files = []
    for cls in (rosbag1.Writer, Ros1Writer):
        path = tmp_path / cls.__name__ / "x.bag"
        path.parent.mkdir()
        writer = cls(path)
        if compression:
            writer.set_compression(rosbag1.Writer.CompressionFormat[compression])
        writer.open()
        connections = [
            writer.add_connection(t, "std_msgs/msg/String", typestore=typestore("noetic"))
            for t in TOPICS
        ]
        for cid, stamp, data in records:  # one record per batch: same chunk boundaries
            if cls is rosbag1.Writer:
                writer.write(connections[cid], stamp, data)
            else:
                writer.write_many([(TOPICS[cid], stamp, data)], {"/a": 0, "/b": 1})
        writer.close()
        files.append(path.read_bytes())
    theirs, ours = files
    # One deliberate difference: our bag header record is rosbag's size, 8 bytes longer, so the
    # chunks start at 4117 (rosbag) instead of 4109 (rosbags) and their positions shift by 8.
    assert ours[:13] == theirs[:13] and _chunk_positions(ours) == [
        pos + 8 for pos in _chunk_positions(theirs)
    ]
    assert ours[4117 : _index_pos(ours)] == theirs[4109 : _index_pos(theirs)]  # every chunk
    with rosbag1.Reader(tmp_path / "Ros1Writer" / "x.bag") as reader:
        assert len(list(reader.messages())) == len(records)


def _index_pos(bag: bytes) -> int:
    return int(struct.unpack_from("<Q", bag, bag.index(b"index_pos=") + 10)[0])


def _chunk_positions(bag: bytes) -> list[int]:
    with_index = bag[_index_pos(bag) :]
    return [
        int(struct.unpack_from("<Q", with_index, at + len(b"chunk_pos="))[0])
        for at in range(len(with_index))
        if with_index.startswith(b"chunk_pos=", at)
    ]


def test_ros1_bag_header_is_the_size_rosbag_writes_so_reindex_can_rewrite_it(tmp_path):
    path = tmp_path / "x.bag"
    sink = open_bag(path, "ros1")
    sink.close()
    data = path.read_bytes()
    (header_length,) = struct.unpack_from("<I", data, 13)
    (padding,) = struct.unpack_from("<I", data, 17 + header_length)
    assert header_length + padding == 4096  # rosbag's _FILE_HEADER_LENGTH: fields + padding


@pytest.mark.parametrize(
    ("plugin", "zstd"),
    [(StoragePlugin.MCAP, False), (StoragePlugin.MCAP, True), (StoragePlugin.SQLITE3, False)],
)
def test_rosbag2_batch_writes_match_rosbags(tmp_path, records, plugin, zstd):
    roots = []
    for cls in (rosbag2.Writer, Rosbag2Writer):
        root = tmp_path / cls.__name__ / "bag"
        root.parent.mkdir()
        writer = cls(root, version=9, storage_plugin=plugin)
        if zstd:
            writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
        writer.open()
        if cls is Rosbag2Writer and plugin == StoragePlugin.MCAP:
            assert writer.storage.type_hashes  # on for version 9; off here to compare bytes
            writer.storage.type_hashes = False
        connections = [
            writer.add_connection(t, "std_msgs/msg/String", typestore=typestore("jazzy"))
            for t in TOPICS
        ]
        ids = {t: c.id for t, c in zip(TOPICS, connections, strict=True)}
        for cid, stamp, data in records:
            if cls is rosbag2.Writer:
                writer.write(connections[cid], stamp, data)
            else:
                writer.write_many([(TOPICS[cid], stamp, data)], ids)
        writer.close()
        roots.append(root)
    assert (roots[0] / "metadata.yaml").read_text() == (roots[1] / "metadata.yaml").read_text()
    if plugin == StoragePlugin.MCAP:
        theirs, ours = ((root / "bag.mcap").read_bytes() for root in roots)
        crcs = _mcap_crcs(ours)  # rosbags writes 0 for every CRC: ours are the real ones
        assert len(crcs) == len(_mcap_crcs(theirs)) >= 3 and set(_mcap_crcs(theirs).values()) == {0}
        assert all(crcs.values())
        with (roots[1] / "bag.mcap").open("rb") as stream:  # the mcap package checks them
            assert len(list(StreamReader(stream, validate_crcs=True).records)) > 600
        unsealed = bytearray(ours)
        for at in crcs:
            unsealed[at : at + 4] = bytes(4)
        assert bytes(unsealed) == theirs  # and nothing else differs
    else:
        query = "SELECT topic_id, timestamp, data FROM messages ORDER BY id"
        rows = [sqlite3.connect(root / "bag.db3").execute(query).fetchall() for root in roots]
        assert rows[0] == rows[1]


def _mcap_crcs(data: bytes) -> dict[int, int]:
    """Offset and value of every CRC of an MCAP file: chunks', data end's and the footer's."""
    crcs = {}
    pos = 8
    while pos < len(data) - 8:
        op, length = struct.unpack_from("<BQ", data, pos)
        body = pos + 9
        at = {0x06: body + 24, 0x0F: body, 0x02: body + 16}.get(op)
        if at is not None:
            crcs[at] = struct.unpack_from("<I", data, at)[0]
        pos = body + length
    return crcs


def test_lz4_chunks_use_the_frame_flags_roslz4_requires():
    frame = roslz4_compress(b"bubblerob" * 1000)
    assert frame[:4] == b"\x04\x22\x4d\x18"  # LZ4 frame magic
    flags = frame[4]
    assert (flags >> 6) & 3 == 1  # version
    assert (flags >> 5) & 1 == 1  # independent blocks
    assert (flags >> 4) & 1 == 0  # no block checksum
    assert (flags >> 3) & 1 == 0  # no content size
    assert (flags >> 2) & 1 == 1  # content checksum
    assert lz4.frame.decompress(frame) == b"bubblerob" * 1000


@pytest.mark.parametrize("fmt", ["mcap", "sqlite3", "ros1"])
def test_existing_bag_is_not_overwritten(tmp_path, fmt):
    open_bag(tmp_path / "bag", fmt).close()
    with pytest.raises(FileExistsError, match="overwrite=True"):
        open_bag(tmp_path / "bag", fmt)
    open_bag(tmp_path / "bag", fmt, overwrite=True).close()


def test_overwrite_refuses_to_delete_a_directory_that_is_not_a_bag(tmp_path):
    (tmp_path / "bag").mkdir()
    (tmp_path / "bag" / "notes.txt").write_text("keep me")
    with pytest.raises(BagPathError, match="not part of a bag"):
        open_bag(tmp_path / "bag", "mcap", overwrite=True)
    assert (tmp_path / "bag" / "notes.txt").exists()


@pytest.mark.parametrize("fmt", ["mcap", "sqlite3", "ros1"])
def test_path_under_a_file_fails_with_the_path_in_the_message(tmp_path, fmt):
    (tmp_path / "file").write_text("")
    with pytest.raises(BagPathError, match=str(tmp_path / "file")):
        open_bag(tmp_path / "file" / "bag", fmt)


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes to read-only directories")
@pytest.mark.parametrize("fmt", ["mcap", "sqlite3", "ros1"])
def test_read_only_directory_fails_with_the_path_in_the_message(tmp_path, fmt):
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o500)
    with pytest.raises(BagPathError, match=str(locked)):
        open_bag(locked / "bag", fmt)


@pytest.mark.skipif(not Path("/proc/version").exists(), reason="needs Linux /proc")
def test_read_only_filesystem_fails_with_the_path_in_the_message():
    with pytest.raises(BagPathError, match="/proc/bubblerob_bag"):
        open_bag("/proc/bubblerob_bag", "mcap")


@pytest.mark.parametrize(
    ("fmt", "distro", "compression", "message"),
    [
        ("rosbag3", None, None, "unknown bag format"),
        ("ros1", "jazzy", None, "ROS 1"),
        ("mcap", "noetic", None, "ROS 2"),
        ("mcap", None, "bz2", "offers compression"),
        ("sqlite3", None, "zstd", "offers compression"),
        ("mcap", "iron", None, "unknown ROS distro"),
    ],
)
def test_bad_format_options_are_rejected(tmp_path, fmt, distro, compression, message):
    with pytest.raises(ValueError, match=message):
        open_bag(tmp_path / "bag", fmt, distro, compression)
    assert not (tmp_path / "bag").exists()
