"""MCAP bags decode fully with the mcap + mcap-ros2-support packages, and with rosbags."""

from __future__ import annotations

import math

import pytest
import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from ros_helpers import read_all


@pytest.mark.parametrize("compression", ["zstd", "none"])
@pytest.mark.parametrize("distro", ["jazzy", "humble"])
def test_mcap_decodes_every_message_with_mcap_ros2(record, compression, distro):
    path = record("mcap", compression, steps=6, distro=distro, env_kwargs={"camera": True})
    (storage,) = path.glob("*.mcap")
    counts: dict[str, int] = {}
    with storage.open("rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert summary is not None
        for _, channel, _, decoded in reader.iter_decoded_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            if channel.topic == "/proximity":
                assert hasattr(decoded, "variance") == (distro == "jazzy")
                assert decoded.range > 0 or math.isinf(decoded.range)
        chunk_compression = {c.compression for c in summary.chunk_indexes}
        assert chunk_compression == {"" if compression == "none" else "zstd"}
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
    ours = {topic: len(messages) for topic, messages in read_all(path).items()}
    assert counts == ours
    assert summary.statistics.message_count == sum(ours.values())
    info = yaml.safe_load(metadata["rosbag2"]["serialized_metadata"])
    assert "bubblerob.episodes" in info["custom_data"]


def test_sqlite3_bag_reads_with_rosbags(record):
    path = record("sqlite3", steps=4)
    messages = read_all(path)
    assert len(messages["/scan"]) == len(messages["/cmd_vel"]) + 2
    assert (path / "metadata.yaml").exists() and any(path.glob("*.db3"))


LASER_SCAN_RIHS01 = "RIHS01_64c191398013af96509d518dac71d5164f9382553fce5c1f8cca5be7924bd828"
"""sensor_msgs/msg/LaserScan's type hash as Jazzy's rosidl generates it (published code)."""


@pytest.mark.parametrize("distro", ["jazzy", "humble"])
def test_channels_carry_jazzys_topic_type_hash(record, distro):
    from bubblerob_env.ros.messages.distros import message_definition

    path = record("mcap", "zstd", steps=3, distro=distro)
    (storage,) = path.glob("*.mcap")
    with storage.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None and summary.channels
    for channel in summary.channels.values():
        schema = summary.schemas[channel.schema_id]
        assert "offered_qos_profiles" in channel.metadata
        if distro == "jazzy":  # rosbag2 reads it into topic_metadata.type_description_hash
            assert channel.metadata["topic_type_hash"] == message_definition(distro, schema.name)[1]
        else:  # Humble has no type hashes
            assert "topic_type_hash" not in channel.metadata
    if distro == "jazzy":
        scan = next(c for c in summary.channels.values() if c.topic == "/scan")
        assert scan.metadata["topic_type_hash"] == LASER_SCAN_RIHS01


@pytest.mark.parametrize("compression", ["zstd", "none"])
def test_crcs_are_written_and_catch_corruption(record, compression):
    import struct
    import zlib
    from io import BytesIO

    from mcap.records import Chunk, DataEnd, Footer
    from mcap.stream_reader import CRCValidationError, StreamReader

    path = record("mcap", compression, episodes=2, steps=30)
    (storage,) = path.glob("*.mcap")
    data = storage.read_bytes()
    with storage.open("rb") as stream:  # the mcap package checks chunk and data section CRCs
        records = list(StreamReader(stream, validate_crcs=True, emit_chunks=True).records)
    chunks = [r for r in records if isinstance(r, Chunk)]
    (data_end,) = [r for r in records if isinstance(r, DataEnd)]
    (footer,) = [r for r in records if isinstance(r, Footer)]
    assert chunks and all(c.uncompressed_crc for c in chunks) and data_end.data_section_crc
    # The summary CRC (the mcap package does not check it): summary start .. the footer's field.
    end = len(data) - 8 - 4
    assert footer.summary_crc == zlib.crc32(data[footer.summary_start : end]) != 0
    assert struct.unpack_from("<I", data, end)[0] == footer.summary_crc
    first_chunk = 8
    while (op_length := struct.unpack_from("<BQ", data, first_chunk))[0] != 0x06:
        first_chunk += 9 + op_length[1]
    length = op_length[1]
    message_index = first_chunk + 9 + length
    assert data[message_index] == 0x07
    for at, what in ((message_index + 9 + 6 + 4, "DataEnd"), (message_index - 1, "Chunk")):
        if what == "Chunk" and compression != "none":
            continue  # a flipped byte in zstd data fails zstd's own checks first
        corrupt = bytearray(data)
        corrupt[at] ^= 0xFF  # a log time of a message index; the last byte of a message
        with pytest.raises(CRCValidationError, match=f"in {what}"):
            list(StreamReader(BytesIO(bytes(corrupt)), validate_crcs=True).records)


def _mcap_messages(path):  # type: ignore[no-untyped-def]
    """Every message as the mcap library reads it (CRCs checked): topic, times, sequence, data."""
    (storage,) = path.glob("*.mcap")
    with storage.open("rb") as stream:
        reader = make_reader(stream, validate_crcs=True)
        return [
            (channel.topic, m.log_time, m.publish_time, m.sequence, bytes(m.data))
            for _, channel, m in reader.iter_messages(log_time_order=False)
        ]


def test_chunks_at_the_fast_zstd_level_hold_level_1s_messages(record, monkeypatch):
    """Issue #40 item 5: MCAP chunks are compressed at zstd level -3 (2026-11-28; level 1
    before). The same episodes at both levels: the same messages for rosbags, the mcap library
    (CRCs checked) and mcap-ros2's decoder, in different compressed chunks."""
    from bubblerob_env.ros.bags import ros2

    assert ros2.MCAP_ZSTD_LEVEL == -3
    kwargs = {"episodes": 3, "steps": 40, "start_time": 1.7e9, "env_kwargs": {"camera": True}}
    fast = record("mcap", "zstd", name="fast", **kwargs)
    monkeypatch.setattr(ros2, "MCAP_ZSTD_LEVEL", 1)
    level_1 = record("mcap", "zstd", name="level_1", **kwargs)
    assert _mcap_messages(fast) == _mcap_messages(level_1)
    assert len(_mcap_messages(fast)) > 3 * 40 * 10
    assert repr(read_all(fast)) == repr(read_all(level_1))  # rosbags, decoded
    decoded = []
    for path in (fast, level_1):
        (storage,) = path.glob("*.mcap")
        with storage.open("rb") as stream:
            reader = make_reader(stream, decoder_factories=[DecoderFactory()])
            decoded.append([repr(d) for _, _, _, d in reader.iter_decoded_messages()])
            chunks = reader.get_summary().chunk_indexes  # type: ignore[union-attr]
            assert {c.compression for c in chunks} == {"zstd"}
            sizes = sum(c.compressed_size for c in chunks), sum(c.uncompressed_size for c in chunks)
            decoded[-1].append(sizes)
    fast_sizes, level_1_sizes = decoded[0].pop(), decoded[1].pop()
    assert decoded[0] == decoded[1]
    assert fast_sizes[1] == level_1_sizes[1] and fast_sizes[0] != level_1_sizes[0]
