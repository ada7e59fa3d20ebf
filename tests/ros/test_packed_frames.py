"""Packed frames (one ``struct`` call and one write per frame) give the bags records give."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from bubblerob_env.ros.bags.sinks import BagSink, open_bag
from bubblerob_env.ros.episodes import EpisodeStream
from bubblerob_env.ros.fanout import MessageFanout
from bubblerob_env.ros.fastpath.framing import Framing, Record
from bubblerob_env.ros.messages.topics import Topics
from bubblerob_env.specs import EnvSpecs
from bubblerob_env.vision.recognise import Recogniser

EPOCH_NS = 1_700_000_000_123_456_789
"""A real start time with every digit used: nanoseconds carry into seconds mid-episode."""


class _Collect(BagSink):
    """A sink that takes records only, like a live publisher."""

    def __init__(self, distro: str) -> None:
        super().__init__(Path("collect"), "collect", distro)
        self.records: list[Record] = []

    def add_topic(self, topic: str, msgtype: str, latched: bool = False) -> None:
        self._connections[topic] = None  # type: ignore[assignment]

    def write_batch(self, records: Sequence[Record]) -> None:
        self.records.extend(records)

    def close(self) -> None:
        self.closed = True


class _RecordsOnly(BagSink):
    """A bag sink that declares no framing: it gets records, never packed frames."""

    def __init__(self, sink: BagSink) -> None:
        super().__init__(sink.path, sink.format, sink.distro)
        self.sink = sink

    def add_topic(self, topic: str, msgtype: str, latched: bool = False) -> None:
        self.sink.add_topic(topic, msgtype, latched)

    def write_batch(self, records: Sequence[Record]) -> None:
        self.sink.write_batch(records)

    def flush(self) -> None:
        self.sink.flush()

    def close(self) -> None:
        self.sink.close()


def _record(
    path: Path,
    fmt: str,
    compression: str,
    mode: str,
    chunk_bytes: int,
    collect: bool = False,
    detections: bool = False,
    **env_kwargs: object,
) -> tuple[Path, list[Record]]:
    """Record three episodes as a recorder does; ``mode``: "batched", "packed" (frame by frame)
    or "records". ``detections``: camera frames with ``/detections``."""
    env = gym.make("BubbleRob-v0", max_episode_steps=70, **env_kwargs)
    bag = open_bag(path, fmt, compression=compression, chunk_size=chunk_bytes)
    assert bag.framing() is not None
    sink = _RecordsOnly(bag) if mode == "records" else bag  # the record-by-record path
    batch_frames = {"batched": 7, "packed": 0, "records": 0}[mode]
    topics = Topics() if detections else Topics(detections=None)
    fanout = MessageFanout(EnvSpecs.from_env(env), topics, batch_frames=batch_frames)
    if detections:
        fanout.detector = Recogniser.for_env(env.unwrapped)
    fanout.add_sink(sink)
    assert fanout.batching == (mode == "batched")
    records: list[Record] = []
    if collect:
        collector = _Collect(bag.distro)
        fanout.add_sink(collector)
        records = collector.records
        assert not fanout.batching  # a sink without framing turns batching off
    stream = EpisodeStream(fanout, round(float(env.unwrapped.dt) * 1e9), EPOCH_NS)
    rng = np.random.default_rng(3)
    for episode in range(3):
        stream.reset(env, episode, None, {"format": fmt})
        for _ in range(int(rng.integers(20, 90))):
            action = rng.uniform(-0.3, 1.0, size=2).astype(np.float32)
            obs, reward, terminated, truncated, info = env.step(action)
            stream.step(obs, info, action, reward, terminated, truncated)
            if terminated or truncated:
                fanout.flush()
                sink.flush()
                break
    fanout.remove_sink(sink)
    sink.close()
    env.close()
    return bag.path, records


def _assert_same_bags(a: Path, b: Path, fmt: str) -> None:
    if fmt == "ros1":
        assert a.read_bytes() == b.read_bytes()
    else:
        for name in ("metadata.yaml", "bag.mcap" if fmt == "mcap" else "bag.db3"):
            assert (a / name).read_bytes() == (b / name).read_bytes()


@pytest.mark.parametrize(
    ("fmt", "compression"),
    [("mcap", "zstd"), ("mcap", "none"), ("sqlite3", "none"), ("ros1", "none"), ("ros1", "lz4")],
)
@pytest.mark.parametrize("chunk_bytes", [2**20, 20_000])
def test_packed_frames_write_the_bytes_records_write(tmp_path, fmt, compression, chunk_bytes):
    packed, packed_records = _record(
        tmp_path / "a" / "bag", fmt, compression, "packed", chunk_bytes, collect=True
    )
    plain, plain_records = _record(
        tmp_path / "b" / "bag", fmt, compression, "records", chunk_bytes, collect=True
    )
    _assert_same_bags(packed, plain, fmt)
    # A sink that takes records beside a packing sink gets the same messages, sliced from the frame.
    assert packed_records == plain_records
    assert len(packed_records) > 100


@pytest.mark.parametrize(
    ("fmt", "compression"),
    [("mcap", "zstd"), ("mcap", "none"), ("sqlite3", "none"), ("ros1", "none"), ("ros1", "lz4")],
)
@pytest.mark.parametrize("chunk_bytes", [2**20, 20_000])
def test_batched_frames_write_the_bytes_frame_by_frame_packing_writes(
    tmp_path, fmt, compression, chunk_bytes
):
    # Batches of 7 frames; 20 kB chunks close inside batches: both split where frames would.
    batched, _ = _record(tmp_path / "a" / "bag", fmt, compression, "batched", chunk_bytes)
    packed, _ = _record(tmp_path / "b" / "bag", fmt, compression, "packed", chunk_bytes)
    _assert_same_bags(batched, packed, fmt)


@pytest.mark.parametrize(
    "env_kwargs",
    [
        {"action_type": "twist"},
        {"camera": True, "camera_width": 16, "camera_height": 12},
        {"laser_num_rays": 0},
        {"odometry_noise": 0.2},
    ],
    ids=["twist", "camera", "no-laser", "drifting-odometry"],
)
def test_batched_frames_match_frame_by_frame_for_every_observation_set(tmp_path, env_kwargs):
    batched, _ = _record(tmp_path / "a" / "bag", "mcap", "none", "batched", 20_000, **env_kwargs)
    packed, _ = _record(tmp_path / "b" / "bag", "mcap", "none", "packed", 20_000, **env_kwargs)
    _assert_same_bags(batched, packed, "mcap")


@pytest.mark.parametrize(
    ("fmt", "compression", "chunk_bytes"),
    [("mcap", "zstd", 2**20), ("mcap", "none", 20_000), ("sqlite3", "none", 2**20),
     ("ros1", "lz4", 20_000)],
)  # fmt: skip
def test_batched_detections_write_the_bytes_frame_by_frame_writes(
    tmp_path, fmt, compression, chunk_bytes
):
    # Each frame's /detections record follows it, also where a 20 kB chunk closes between them
    # (a 64x64 frame is ~13 kB): the batch recognises every image at once, the bytes stay.
    kwargs = {"camera": True, "obstacle_colours": True, "detections": True}
    batched, _ = _record(tmp_path / "a" / "bag", fmt, compression, "batched", chunk_bytes, **kwargs)
    packed, _ = _record(tmp_path / "b" / "bag", fmt, compression, "packed", chunk_bytes, **kwargs)
    _assert_same_bags(batched, packed, fmt)


def test_framing_headers_name_their_log_time_slots():
    mcap = Framing("mcap", (("/a", 3),)).header("/a", 10, action=True)
    assert [code for code, _ in mcap] == ["B", "Q", "H", "I", "Q", "Q"]
    assert mcap[1][1] == 32 and mcap[2][1] == 3
    assert {value.name for _, value in mcap[4:]} == {"action_log_ns"}
    ros1 = Framing("ros1", (("/a", 3),)).header("/a", 10, action=False)
    assert [getattr(value, "name", None) for _, value in ros1[8:10]] == ["log_sec", "log_nsec"]
    with pytest.raises(ValueError, match="unknown framing"):
        Framing("zip", (("/a", 3),)).header("/a", 10, action=False)
