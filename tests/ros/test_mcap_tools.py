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
