"""Reading bags back: what a bag holds (topics, counts, time span) and its episodes' metadata.

Any bag ``rosbags`` reads works: ROS 1 ``.bag`` files and ROS 2 bag directories (MCAP or sqlite3);
the path of the ``.mcap``/``.db3`` file inside a ROS 2 bag directory is accepted too. Episodes are
found by their metadata messages (JSON ``std_msgs/String``, see the recorder), on whatever topic
name they were recorded under.
"""

from __future__ import annotations

import json
import sqlite3
import struct
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rosbags.highlevel import AnyReader

from bubblerob_env.ros.readback.counts import storage_counts
from bubblerob_env.ros.readback.layout import (
    BagLayoutError,
    bag_root,
    is_finished,
    metadata_damage,
    storage_file,
)
from bubblerob_env.ros.readback.mcap_scan import check_mcap_crcs
from bubblerob_env.ros.readback.ros1_scan import index_is_cut_short, index_position
from bubblerob_env.ros.readback.scan import CorruptBagError, Scan
from bubblerob_env.ros.readback.unfinished import read_unfinished, scan_bag

__all__ = [
    "BagLayoutError",
    "BagSummary",
    "CorruptBagError",
    "TopicSummary",
    "bag_root",
    "find_episodes",
    "locate_damage",
    "open_reader",
    "read_summary",
]

_STRING = "std_msgs/msg/String"


@dataclass(frozen=True)
class TopicSummary:
    """One topic of a bag."""

    name: str
    msgtype: str
    count: int


@dataclass(frozen=True)
class BagSummary:
    """What a bag holds. Times are nanoseconds of the bag's (simulated) clock."""

    path: Path
    storage: str
    topics: tuple[TopicSummary, ...]
    message_count: int
    start_ns: int
    end_ns: int
    episodes: tuple[dict[str, Any], ...] = field(default=())
    episode_topic: str | None = None
    unfinished: bool = False
    """The recording was never finished (killed): only its complete episodes are counted."""

    @property
    def duration_s(self) -> float:
        """Seconds from the first message to the last."""
        return max(0, self.end_ns - self.start_ns) / 1e9

    def to_dict(self) -> dict[str, Any]:
        """Plain data (for ``bubblerob info --json``)."""
        return {
            "path": str(self.path),
            "storage": self.storage,
            "message_count": self.message_count,
            "start_ns": self.start_ns,
            "end_ns": self.end_ns,
            "duration_s": self.duration_s,
            "topics": [t.__dict__ for t in self.topics],
            "episode_topic": self.episode_topic,
            "episodes": list(self.episodes),
            "unfinished": self.unfinished,
        }


class _CheckedReader:
    """An ``AnyReader`` whose read errors are :class:`CorruptBagError` naming the file and where."""

    unfinished = False

    def __init__(self, reader: Any, root: Path) -> None:
        self._reader, self.path = reader, root

    def __getattr__(self, name: str) -> Any:
        return getattr(self._reader, name)

    def messages(self, *args: Any, **kwargs: Any) -> Iterator[tuple[Any, int, bytes]]:
        """``AnyReader.messages``."""
        try:
            yield from self._reader.messages(*args, **kwargs)
        except Exception as error:  # noqa: BLE001 - rosbags' errors vary with the damage
            raise CorruptBagError(locate_damage(self.path, error)) from None

    def deserialize(self, raw: bytes, msgtype: str) -> Any:
        """``AnyReader.deserialize``."""
        try:
            return self._reader.deserialize(raw, msgtype)
        except Exception as error:  # noqa: BLE001 - damaged bytes fail in many ways
            raise CorruptBagError(
                f"{self.path}: a {msgtype} message does not deserialize ({error})"
            ) from None


def locate_damage(root: Path, error: BaseException) -> str:
    """Where the bag at ``root`` is damaged, in words (file and byte offset when found)."""
    try:
        file = storage_file(root)
        if file.suffix == ".mcap":
            found = check_mcap_crcs(file) or scan_bag(root)[1].damage
        elif file.suffix == ".bag":
            found = _ros1_damage(root, scan_bag(root)[1], error)
        else:
            found = None
    except OSError as scan_error:
        found = str(scan_error)
    return found or f"{root}: {type(error).__name__}: {error}"


def _ros1_damage(root: Path, scan: Scan, error: BaseException) -> str:
    """Where a finished ROS 1 bag that rosbags cannot read is damaged."""
    if scan.damage is not None:
        return scan.damage
    index = index_position(root)
    if scan.cut_at is not None and scan.cut_at < index:  # the index is after it: a bad length
        return (
            f"{root}: the record at byte {scan.cut_at} runs past the end of the file, before "
            f"the index at byte {index} (its length is damaged)"
        )
    return f"{root}: its index (from byte {index}) is damaged: {type(error).__name__}: {error}"


def _metadata_counts_damage(reader: Any, root: Path) -> str | None:
    """Where ``metadata.yaml``'s message counts differ from the storage file's own, or ``None``."""
    file = storage_file(root)
    try:
        stored = storage_counts(file)
    except (struct.error, UnicodeDecodeError, sqlite3.Error) as error:
        return locate_damage(root, error)
    if stored is None:
        return None
    listed: dict[str, int] = {}
    for connection in reader.connections:
        listed[connection.topic] = listed.get(connection.topic, 0) + connection.msgcount
    for topic in sorted(set(stored) | {t for t, n in listed.items() if n}):
        if listed.get(topic, 0) != stored.get(topic, 0):
            return (
                f"{root / 'metadata.yaml'} counts {listed.get(topic, 0)} messages on {topic}, "
                f"{file.name} holds {stored.get(topic, 0)}"
            )
    return None


def _cut_short_in_its_index(root: Path) -> bool:
    """A finished ROS 1 bag whose file ends inside its index: its data is whole."""
    if root.suffix != ".bag":
        return False
    # Cut inside the index, not before it: a length flipped in a chunk runs past the end too.
    return index_is_cut_short(root) and scan_bag(root)[1].damage is None


@contextmanager
def open_reader(root: Path) -> Iterator[Any]:
    """The bag at ``root`` (from :func:`bag_root`), opened for reading.

    A ``rosbags`` ``AnyReader`` whose errors are :class:`CorruptBagError`.

    For a bag that was never finished (no ``metadata.yaml``, no MCAP footer, no ROS 1 index):
    an :class:`~bubblerob_env.ros.readback.unfinished.UnfinishedReader` of its complete episodes.

    Raises:
        OSError: ``root`` is not a bag (the message says why in one line).
        CorruptBagError: It is damaged (a finished bag that does not read, a failed CRC).
    """
    if not is_finished(root):
        yield read_unfinished(root)
        return
    file = storage_file(root)
    damage = metadata_damage(root) if root.is_dir() else None
    if damage is None and file.suffix == ".mcap":
        damage = check_mcap_crcs(file)
    if damage is not None:
        raise CorruptBagError(damage)
    reader = AnyReader([root])
    try:
        reader.open()
    except Exception as error:  # noqa: BLE001 - rosbags' errors vary: index, header, summary
        if _cut_short_in_its_index(root):
            yield read_unfinished(root)
            return
        raise CorruptBagError(locate_damage(root, error)) from None
    try:
        damage = _metadata_counts_damage(reader, root) if root.is_dir() else None
        if damage is not None:
            raise CorruptBagError(damage)
        yield _CheckedReader(reader, root)
    finally:
        reader.close()


def _storage(root: Path) -> str:
    return {".bag": "ros1", ".mcap": "mcap", ".db3": "sqlite3"}[storage_file(root).suffix]


def find_episodes(reader: Any) -> tuple[str | None, list[dict[str, Any]]]:
    """``(topic, metadata of each episode)``: the first String topic holding episode metadata."""
    for connection in reader.connections:
        if connection.msgtype != _STRING:
            continue
        episodes: list[dict[str, Any]] = []
        for conn, stamp, raw in reader.messages(connections=[connection]):
            try:
                data = json.loads(reader.deserialize(raw, conn.msgtype).data)
            except (ValueError, AttributeError, CorruptBagError):
                data = None
            if not isinstance(data, dict) or "start_time_ns" not in data or "episode" not in data:
                if episodes:  # this topic holds episode metadata: one that does not read is damage
                    where = getattr(reader, "path", None) or "the bag"
                    raise CorruptBagError(
                        f"{where}: the episode metadata on {conn.topic} at {stamp} ns is damaged"
                    )
                break
            episodes.append(data)
        if episodes:
            episodes.sort(key=lambda e: (e["start_time_ns"], e["episode"]))
            return connection.topic, episodes
    return None, []


def read_summary(path: str | Path) -> BagSummary:
    """Topics, message counts, time span and episode metadata of the bag at ``path``."""
    root = bag_root(path)
    with open_reader(root) as reader:
        counts: dict[tuple[str, str], int] = {}
        for connection in reader.connections:
            key = (connection.topic, connection.msgtype)
            counts[key] = counts.get(key, 0) + connection.msgcount
        topics = tuple(TopicSummary(t, m, n) for (t, m), n in sorted(counts.items()))
        episode_topic, episodes = find_episodes(reader)
        return BagSummary(
            path=root,
            storage=_storage(root),
            topics=topics,
            message_count=reader.message_count,
            start_ns=reader.start_time if reader.message_count else 0,
            end_ns=reader.end_time - 1 if reader.message_count else 0,  # rosbags: exclusive
            episodes=tuple(episodes),
            episode_topic=episode_topic,
            unfinished=getattr(reader, "unfinished", False),
        )
