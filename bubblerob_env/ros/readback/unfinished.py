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
from bubblerob_env.ros.readback.layout import storage_file
from bubblerob_env.ros.readback.mcap_scan import scan_mcap
from bubblerob_env.ros.readback.ros1_scan import scan_ros1
from bubblerob_env.ros.readback.scan import CorruptBagError, Message, Scan

__all__ = ["UnfinishedReader", "read_unfinished", "scan_bag"]

_STRING = "std_msgs/msg/String"


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

    def __init__(
        self,
        distro: str,
        topics: dict[int, tuple[str, str]],
        messages: list[Message],
        path: Path | None = None,
    ) -> None:
        self.distro = distro
        self.path = path
        self.damage: str | None = None
        """Where the bag is damaged, when it was read up to there (salvaged), else ``None``."""
        # Sorted stably: file order within a stamp. A message on no known connection is dropped.
        messages = sorted((m for m in messages if m[0] in topics), key=lambda m: m[1])
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

    def _flag(self, raw: bytes, cid: int, stamp: int) -> bool:
        topic, msgtype = self._topics[cid]
        try:
            return bool(self.deserialize(raw, msgtype).data)
        except Exception as error:  # noqa: BLE001 - damaged bytes fail in many ways
            raise CorruptBagError(
                f"{self.path}: the {topic} message at {stamp} ns does not deserialize ({error})"
            ) from None

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
            if ended and bool(self._flag(raw, cid, stamp)):
                return [m for m in messages if m[1] <= stamp]
        return [m for m in messages if m[1] < last_start]


def _read_db3(path: Path, scan: Scan) -> str:
    """Read the committed rows of a ``.db3`` into ``scan``; its distro."""
    with tempfile.TemporaryDirectory() as tmp:  # SQLite rolls back the copy, not the bag
        copy = Path(tmp) / path.name
        for suffix in ("", "-journal", "-wal"):
            source = path.with_name(path.name + suffix)
            if source.exists():
                shutil.copyfile(source, copy.with_name(copy.name + suffix))
        db = sqlite3.connect(copy)
        try:
            return _read_rows(db, scan)
        except (sqlite3.Error, UnicodeDecodeError) as error:  # sqlite3 decodes its own message
            if not scan.topics:  # not even its topics table reads
                raise OSError(f"{path} is not a rosbag2 sqlite3 file: {error}") from None
            scan.damage = f"{path}: SQLite cannot read it past row {len(scan.messages)} ({error})"
            return "jazzy"
        finally:
            db.close()


def _read_rows(db: sqlite3.Connection, scan: Scan) -> str:
    """Topics, then messages row by row (up to a damaged row), into ``scan``; the distro."""
    distro = "jazzy"
    try:  # Jazzy's schema table names the distro; Humble's bags have none
        (found,) = db.execute("SELECT ros_distro FROM schema").fetchone() or ("",)
        distro = "humble" if found == "humble" else "jazzy"
    except (sqlite3.Error, UnicodeDecodeError):
        distro = "humble"
    scan.topics = {
        int(i): (str(name), str(msgtype))
        for i, name, msgtype in db.execute("SELECT id, name, type FROM topics")
    }
    rows = db.execute("SELECT topic_id, timestamp, data FROM messages ORDER BY id")
    while True:  # one at a time: the rows before a damaged page are kept
        row = rows.fetchone()
        if row is None:
            return distro
        topic_id, stamp, data = row
        if topic_id in scan.topics:
            scan.messages.append((int(topic_id), int(stamp), bytes(data)))


def scan_bag(root: Path) -> tuple[str, Scan]:
    """``(distro, scan)`` of the bag at ``root`` read in file order (see :func:`bag_root`).

    Raises:
        OSError: Nothing readable there (not a bag of a format we write).
    """
    file = storage_file(root)
    if file.suffix == ".bag":
        return "noetic", scan_ros1(file)
    if file.suffix == ".mcap":
        return "jazzy", scan_mcap(file)
    if file.suffix == ".db3":
        scan = Scan()
        return _read_db3(file, scan), scan
    raise OSError(f"{root} is not a bag: no .bag, .mcap or .db3 file")


def read_unfinished(root: Path, salvage: bool = False) -> UnfinishedReader:
    """An :class:`UnfinishedReader` of the bag at ``root`` (ROS 1 file or ROS 2 folder or file).

    Raises:
        OSError: Nothing readable there (not a bag of a format we write).
        CorruptBagError: A record before the end is damaged (unless ``salvage``: then the
            complete episodes before the damage are read, and ``damage`` says where it is).
    """
    distro, scan = scan_bag(root)
    if scan.damage is not None and not salvage:
        raise CorruptBagError(scan.damage)
    reader = UnfinishedReader(distro, scan.topics, scan.messages, root)
    reader.damage = scan.damage
    return reader
