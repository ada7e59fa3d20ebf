"""Reading bags that were never finished (SIGKILL, power loss), read-only.

A recorder flushes at the end of every episode, so an unfinished bag holds every finished
episode, but not what readers look for first: an MCAP file has no summary and its directory no
``metadata.yaml``, an sqlite3 bag no ``metadata.yaml``, a ROS 1 bag no index. This module reads
what is there, in file order, as the formats' own recovery tools do (``mcap recover``, ``rosbag
reindex``): MCAP records up to the first incomplete one, the committed rows of the ``.db3`` (a
copy is opened, so that SQLite rolls back the interrupted transaction there and not in the bag),
ROS 1 chunks up to the first incomplete one. :class:`UnfinishedReader` offers the part of
``rosbags``' ``AnyReader`` that :mod:`~bubblerob_env.ros.readback.summary` and
:mod:`~bubblerob_env.ros.readback.replay` use, holding only the complete episodes.
"""

from __future__ import annotations

import json
import shutil
import sqlite3
import tempfile
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bubblerob_env.ros.messages.distros import deserialize
from bubblerob_env.ros.readback.ros1_scan import read_ros1_records

__all__ = ["UnfinishedReader", "read_unfinished"]

_STRING = "std_msgs/msg/String"
Message = tuple[int, int, bytes]
"""``(connection id, log time ns, serialised message)``."""


@dataclass(frozen=True)
class Connection:
    """A topic of an unfinished bag (the fields of a ``rosbags`` connection that we read)."""

    id: int
    topic: str
    msgtype: str
    msgcount: int


class UnfinishedReader:
    """The complete episodes of an unfinished bag, with ``AnyReader``'s reading methods."""

    unfinished = True

    def __init__(self, distro: str, topics: dict[int, tuple[str, str]], messages: list[Message]):
        self.distro = distro
        messages = sorted(messages, key=lambda m: m[1])  # stable: file order within a stamp
        self._topics = topics
        self.found_episodes = 0
        """Episodes begun in the bag, the unfinished last one included."""
        messages = self._complete_episodes(messages)
        self._messages = messages
        counts: dict[int, int] = {}
        for cid, _, _ in messages:
            counts[cid] = counts.get(cid, 0) + 1
        self.connections = [
            Connection(cid, topic, msgtype, counts[cid])
            for cid, (topic, msgtype) in sorted(topics.items())
            if cid in counts
        ]
        self.message_count = len(messages)
        self.start_time = messages[0][1] if messages else 0
        self.end_time = messages[-1][1] + 1 if messages else 0

    def __enter__(self) -> UnfinishedReader:
        return self

    def __exit__(self, *_: object) -> None:
        return None

    def deserialize(self, raw: bytes, msgtype: str) -> Any:
        """A message of this bag as a ``rosbags`` object."""
        return deserialize(self.distro, bytes(raw), msgtype)

    def messages(
        self,
        connections: Sequence[Any] = (),
        start: int | None = None,
        stop: int | None = None,
    ) -> Iterator[tuple[Connection, int, bytes]]:
        """``(connection, log time, raw)`` in time order, as ``AnyReader.messages``."""
        by_id = {c.id: c for c in self.connections}
        wanted = {c.id for c in connections} if connections else set(by_id)
        for cid, stamp, raw in self._messages:
            if (
                cid in wanted
                and (start is None or stamp >= start)
                and (stop is None or stamp < stop)
            ):
                yield by_id[cid], stamp, raw

    def _complete_episodes(self, messages: list[Message]) -> list[Message]:
        """``messages`` up to the end of the last episode that ended (the rest is cut off).

        An episode ended if a later episode began, or if its terminated or truncated flag
        reads true (the recorder flushes right after that frame, so the frame is whole).
        """
        starts: list[tuple[int, dict[str, Any]]] = []
        for cid, stamp, raw in messages:
            if self._topics[cid][1] != _STRING:
                continue
            try:
                meta = json.loads(self.deserialize(raw, _STRING).data)
            except (ValueError, TypeError, AttributeError):
                continue
            if isinstance(meta, dict) and "start_time_ns" in meta and "episode" in meta:
                starts.append((stamp, meta))
        self.found_episodes = len(starts)
        if not starts:
            return []
        last_start, meta = starts[-1]
        if meta.get("distro") in ("humble", "jazzy", "noetic"):  # MCAP does not say
            self.distro = meta["distro"]
        flags = {
            name
            for key in ("terminated", "truncated")
            if (name := (meta.get("topics") or {}).get(key))
        }
        for cid, stamp, raw in messages:
            ended = stamp > last_start and self._topics[cid][0] in flags
            if ended and bool(self.deserialize(raw, self._topics[cid][1]).data):
                return [m for m in messages if m[1] <= stamp]
        return [m for m in messages if m[1] < last_start]


def _read_mcap(path: Path) -> tuple[str, dict[int, tuple[str, str]], list[Message]]:
    from mcap.records import Channel, Schema
    from mcap.records import Message as McapMessage
    from mcap.stream_reader import StreamReader

    schemas: dict[int, str] = {}
    topics: dict[int, tuple[str, str]] = {}
    messages: list[Message] = []
    with path.open("rb") as stream:
        if stream.read(8) != b"\x89MCAP0\r\n":
            raise OSError(f"{path} is not an MCAP file (no MCAP magic)")
        stream.seek(0)
        try:
            for record in StreamReader(stream, validate_crcs=True).records:
                if isinstance(record, Schema):
                    schemas[record.id] = record.name
                elif isinstance(record, Channel):
                    topics[record.id] = (record.topic, schemas.get(record.schema_id, ""))
                elif isinstance(record, McapMessage):
                    messages.append((record.channel_id, record.log_time, bytes(record.data)))
        except Exception:  # noqa: BLE001 - the file ends in the middle of a record: stop there
            pass
    return "jazzy", topics, messages


def _read_db3(path: Path) -> tuple[str, dict[int, tuple[str, str]], list[Message]]:
    with tempfile.TemporaryDirectory() as tmp:  # SQLite rolls back the copy, not the bag
        copy = Path(tmp) / path.name
        for suffix in ("", "-journal", "-wal"):
            source = path.with_name(path.name + suffix)
            if source.exists():
                shutil.copyfile(source, copy.with_name(copy.name + suffix))
        db = sqlite3.connect(copy)
        try:
            return _read_rows(db)
        except sqlite3.Error as error:
            raise OSError(f"{path} is not a rosbag2 sqlite3 file: {error}") from None
        finally:
            db.close()


def _read_rows(db: sqlite3.Connection) -> tuple[str, dict[int, tuple[str, str]], list[Message]]:
    topics = {
        int(i): (str(name), str(msgtype))
        for i, name, msgtype in db.execute("SELECT id, name, type FROM topics")
    }
    rows = db.execute("SELECT topic_id, timestamp, data FROM messages ORDER BY id")
    messages = [(int(t), int(s), bytes(d)) for t, s, d in rows]
    distro = "jazzy"
    try:  # Jazzy's schema table names the distro; Humble's bags have none
        (found,) = db.execute("SELECT ros_distro FROM schema").fetchone() or ("",)
        distro = "humble" if found == "humble" else "jazzy"
    except sqlite3.Error:
        distro = "humble"
    return distro, topics, messages


def read_unfinished(root: Path) -> UnfinishedReader:
    """An :class:`UnfinishedReader` of the bag at ``root`` (ROS 1 file or ROS 2 directory).

    Raises:
        OSError: Nothing readable there (not a bag of a format we write).
    """
    if root.is_file() and root.suffix == ".bag":
        topics, messages = read_ros1_records(root)
        return UnfinishedReader("noetic", topics, messages)
    for pattern, read in (("*.mcap", _read_mcap), ("*.db3", _read_db3)):
        files = sorted(root.glob(pattern)) if root.is_dir() else []
        if files:
            distro, topics, messages = read(files[0])
            return UnfinishedReader(distro, topics, messages)
    raise OSError(f"{root} is not a bag: no .bag file, .mcap or .db3 there")
