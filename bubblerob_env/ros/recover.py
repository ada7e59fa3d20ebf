"""``bubblerob recover BAG``: finish a bag whose recorder was killed, with its complete episodes.

``info`` and ``replay`` read an unfinished bag as it is (read-only,
:mod:`~bubblerob_env.ros.readback.unfinished`); other tools want a finished one: a ROS 1 index
(``rosbag check``/``play``), an MCAP summary, a ``metadata.yaml``. Recovering writes a new bag of
the same format and distro from the complete episodes' messages, byte for byte, with the episode
summary a recorder writes, then moves the unfinished original aside (``PATH.orig``) and the new
bag into its place. The messages of the episode that was cut short are left out (they are still
in the original).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bubblerob_env.ros.bags.lock import BagLock
from bubblerob_env.ros.bags.sinks import open_bag, remove_bag
from bubblerob_env.ros.messages.topics import LATCHED_TOPICS
from bubblerob_env.ros.readback.summary import bag_root, find_episodes, open_reader
from bubblerob_env.ros.readback.unfinished import UnfinishedReader, read_unfinished
from bubblerob_env.ros.recorder import EPISODES_KEY, RECORDING_KEY

__all__ = ["RecoverError", "RecoverReport", "recover_bag"]

_SUMMARY_KEYS = ("episode", "seed", "start_time_ns")
_SHARED_KEYS = ("episode", "seed", "rng_state", "options", "start_time_ns", "first_seq")
_BATCH = 4096


class RecoverError(OSError):
    """The bag cannot be recovered (the message says why)."""


@dataclass(frozen=True)
class RecoverReport:
    """What :func:`recover_bag` did."""

    path: Path
    original: Path
    episodes: int
    messages: int

    def __str__(self) -> str:
        return (
            f"recovered {self.episodes} complete episode(s), {self.messages} messages into "
            f"{self.path}; the unfinished original is at {self.original}"
        )


def _format(root: Path) -> str:
    if root.suffix == ".bag":
        return "ros1"
    return "mcap" if any(root.glob("*.mcap")) else "sqlite3"


def _latched(episodes: list[dict[str, Any]]) -> set[str]:
    topics = episodes[-1].get("topics") or {}
    return {name for key in LATCHED_TOPICS if (name := topics.get(key))}


def _write(reader: UnfinishedReader, target: Path, fmt: str, episodes: list[dict[str, Any]]) -> int:
    """Write the reader's messages as a finished bag at ``target``; the message count."""
    compression = {"mcap": "zstd", "sqlite3": "none", "ros1": "none"}[fmt]
    sink = open_bag(target, fmt, reader.distro, compression)
    try:
        latched = _latched(episodes)
        for connection in reader.connections:
            sink.add_topic(connection.topic, connection.msgtype, connection.topic in latched)
        batch = []
        for connection, stamp, raw in reader.messages():
            batch.append((connection.topic, stamp, bytes(raw)))
            if len(batch) == _BATCH:
                sink.write_batch(batch)
                batch = []
        sink.write_batch(batch)
        summary = [{k: e[k] for k in _SUMMARY_KEYS} for e in episodes]
        shared = {k: v for k, v in episodes[-1].items() if k not in _SHARED_KEYS}
        sink.set_metadata(EPISODES_KEY, json.dumps(summary, sort_keys=True))
        sink.set_metadata(RECORDING_KEY, json.dumps(shared, sort_keys=True))
    finally:
        sink.close()
    return reader.message_count


def recover_bag(path: str | Path) -> RecoverReport:
    """Finish the unfinished bag at ``path`` in place (see the module docstring).

    Raises:
        RecoverError: The bag is finished already, holds no complete episode, is being written,
            or ``PATH.orig`` exists.
        OSError: Not a bag, or the new one cannot be written.
    """
    root = bag_root(path)
    with open_reader(root) as reader:
        if not getattr(reader, "unfinished", False):
            raise RecoverError(f"{root} is a finished bag: nothing to recover")
    lock = BagLock(root)  # no recorder may still be writing it
    try:
        reader = read_unfinished(root)
        _, episodes = find_episodes(reader)
        if not episodes:
            raise RecoverError(f"{root} holds no complete episode: nothing to recover")
        original = root.with_name(root.name + ".orig")
        if original.exists():
            raise RecoverError(f"{original} exists: move it away first")
        fmt = _format(root)
        work = root.with_name(f".{root.name}.recovering")  # beside it: the same file system
        if work.exists():
            remove_bag(work)
        work.mkdir()
        target = work / root.name
        messages = _write(reader, target, fmt, episodes)
        os.replace(root, original)
        os.replace(target, root)
        work.rmdir()
    finally:
        lock.release()
    return RecoverReport(root, original, len(episodes), messages)
