"""``bubblerob recover BAG``: finish a bag whose recorder was killed, with its complete episodes.

``info`` and ``replay`` read an unfinished bag as it is (read-only,
:mod:`~bubblerob_env.ros.readback.unfinished`); other tools want a finished one: a ROS 1 index
(``rosbag check``/``play``), an MCAP summary, a ``metadata.yaml``. Recovering writes a new bag of
the same format and distro from the complete episodes' messages, byte for byte, with the episode
summary a recorder writes, then moves the unfinished original aside (``PATH.orig``) and the new
bag into its place. The messages of the episode that was cut short are left out (they are still
in the original).

A damaged bag (a failed CRC, a chunk that does not decompress: finished or not) is *salvaged*: the
complete episodes before the damage go into a new bag beside it, ``NAME.recovered`` (``.bag``),
and the original is not touched. So is a lone ``.mcap``/``.db3`` file named among other files.
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
from bubblerob_env.ros.readback.layout import bag_root, is_finished, storage_file
from bubblerob_env.ros.readback.scan import CorruptBagError
from bubblerob_env.ros.readback.summary import find_episodes, open_reader
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
    damage: str | None = None
    """Where the original is damaged (the episodes before it were salvaged), or ``None``."""

    def __str__(self) -> str:
        done = f"{self.episodes} complete episode(s), {self.messages} messages into {self.path}"
        if self.damage is not None:
            return (
                f"salvaged {done} (those before the damage: {self.damage}); the original is "
                f"untouched at {self.original}"
            )
        if self.original == self.path.with_name(self.path.name + ".orig"):
            return f"recovered {done}; the unfinished original is at {self.original}"
        return f"recovered {done}; the unfinished original is untouched at {self.original}"


def _format(file: Path) -> str:
    return {".bag": "ros1", ".mcap": "mcap", ".db3": "sqlite3"}[file.suffix]


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


def _damage(root: Path) -> str | None:
    """Where the bag at ``root`` is damaged (every message read through), or ``None``."""
    try:
        with open_reader(root) as reader:
            for _ in reader.messages():
                pass
    except CorruptBagError as error:
        return error.where
    return None


def _beside(root: Path) -> Path:
    """Where a bag recovered from ``root`` goes when the original stays where it is."""
    if root.suffix in (".bag", ".mcap", ".db3"):
        stem = root.with_suffix("")
        return stem.with_name(stem.name + ".recovered" + (".bag" if root.suffix == ".bag" else ""))
    return root.with_name(root.name + ".recovered")


def recover_bag(path: str | Path) -> RecoverReport:
    """Finish the unfinished bag at ``path``, or salvage a damaged one (see the module docstring).

    Raises:
        RecoverError: The bag is finished and whole, holds no complete episode (before the
            damage), is being written, or the path the new bag would take exists.
        OSError: Not a bag, or the new one cannot be written.
    """
    root = bag_root(path)
    finished = is_finished(root)
    damage = _damage(root) if finished else None
    if finished and damage is None:
        raise RecoverError(f"{root} is a finished bag and reads whole: nothing to recover")
    lock = BagLock(root)  # no recorder may still be writing it
    try:
        reader = read_unfinished(root, salvage=True)
        damage = reader.damage or damage
        _, episodes = find_episodes(reader)
        if not episodes:
            before = " before the damage" if damage else ""
            raise RecoverError(f"{root} holds no complete episode{before}: nothing to recover")
        in_place = damage is None and (root.is_dir() or root.suffix == ".bag")
        final = root if in_place else _beside(root)
        original = root.with_name(root.name + ".orig") if in_place else root
        for taken in (original, final) if in_place else (final,):
            if taken != root and (taken.exists() or taken.is_symlink()):
                raise RecoverError(f"{taken} exists: move it away first")
        _write_beside(reader, root, final, episodes, in_place)
    finally:
        lock.release()
    return RecoverReport(final, original, len(episodes), reader.message_count, damage)


def _write_beside(
    reader: UnfinishedReader, root: Path, final: Path, episodes: list[dict[str, Any]], swap: bool
) -> None:
    """Write the new bag in a work folder beside ``root``, then move it to ``final``.

    With ``swap``, ``root`` is moved to ``root.orig`` first.
    """
    fmt = _format(storage_file(root))
    work = root.with_name(f".{root.name}.recovering")  # beside it: the same file system
    if work.exists():
        remove_bag(work)
    work.mkdir()
    try:
        target = work / final.name
        _write(reader, target, fmt, episodes)
        if swap:
            os.replace(root, root.with_name(root.name + ".orig"))
        os.replace(target, final)
    finally:
        remove_bag(work)
