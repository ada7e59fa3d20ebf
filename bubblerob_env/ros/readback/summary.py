"""Reading bags back: what a bag holds (topics, counts, time span) and its episodes' metadata.

Any bag ``rosbags`` reads works: ROS 1 ``.bag`` files and ROS 2 bag directories (MCAP or sqlite3);
the path of the ``.mcap``/``.db3`` file inside a ROS 2 bag directory is accepted too. Episodes are
found by their metadata messages (JSON ``std_msgs/String``, see the recorder), on whatever topic
name they were recorded under.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rosbags.highlevel import AnyReader

from bubblerob_env.ros.readback.unfinished import read_unfinished

__all__ = [
    "BagSummary",
    "TopicSummary",
    "bag_root",
    "find_episodes",
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


def bag_root(path: str | Path) -> Path:
    """The path ``rosbags`` opens: a ROS 2 bag's directory even if given its storage file."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"no bag at {path}")
    if path.is_file() and path.suffix in (".mcap", ".db3"):
        return path.parent
    return path


@contextmanager
def open_reader(root: Path) -> Iterator[Any]:
    """The bag at ``root``, opened for reading: a ``rosbags`` ``AnyReader``.

    For a bag that was never finished (no ``metadata.yaml``, no MCAP summary, no ROS 1 index):
    an :class:`~bubblerob_env.ros.readback.unfinished.UnfinishedReader` of its complete episodes.

    Raises:
        OSError: ``root`` is not a bag (the message says why in one line).
    """
    reader: Any
    try:
        reader = AnyReader([root])
        reader.open()
    except Exception:  # noqa: BLE001 - rosbags' errors vary: no metadata, no index, cut short
        reader = read_unfinished(root)  # raises OSError for what is no bag at all
    try:
        yield reader
    finally:
        if not getattr(reader, "unfinished", False):
            reader.close()


def _storage(root: Path) -> str:
    if root.suffix == ".bag":
        return "ros1"
    if any(root.glob("*.mcap")):
        return "mcap"
    if any(root.glob("*.db3")):
        return "sqlite3"
    return "unknown"


def find_episodes(reader: Any) -> tuple[str | None, list[dict[str, Any]]]:
    """``(topic, metadata of each episode)``: the first String topic holding episode metadata."""
    for connection in reader.connections:
        if connection.msgtype != _STRING:
            continue
        episodes = []
        for conn, _, raw in reader.messages(connections=[connection]):
            try:
                data = json.loads(reader.deserialize(raw, conn.msgtype).data)
            except (ValueError, AttributeError):
                break
            if not isinstance(data, dict) or "start_time_ns" not in data or "episode" not in data:
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
