"""Bag files that serialised messages go to: ROS 1 ``.bag`` and ROS 2 MCAP or sqlite3.

A sink takes messages already serialised for its distro, in batches (one batch per env frame),
and writes them with the ``rosbags`` writers (batched, see :mod:`~bubblerob_env.ros.bags.writers`).
MCAP and ROS 1 sinks also take *packed frames*: a frame's records, headers included, in one byte
string laid out by the sink's :meth:`BagSink.framing`.
A bag becomes readable by every tool when :meth:`BagSink.close` writes its index; the recorder
closes it from its ``close``, an ``atexit`` hook and its signal handlers
(:mod:`~bubblerob_env.ros.bags.safety`). :meth:`BagSink.flush` puts everything so far on disk after
each episode, so that even a hard kill loses at most the current episode (``rosbag reindex``,
``mcap recover`` or ``ros2 bag reindex`` restore the index).
"""

from __future__ import annotations

import errno
import shutil
import sqlite3
from collections.abc import Sequence
from pathlib import Path
from typing import Literal

from rosbags import rosbag1, rosbag2
from rosbags.interfaces import (
    Connection,
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin

from bubblerob_env.ros.bags.humble import humble_qos
from bubblerob_env.ros.bags.lock import BagLock, BagLockedError
from bubblerob_env.ros.bags.writers import Ros1Writer, Rosbag2Writer
from bubblerob_env.ros.fastpath.framing import (
    FrameLayout,
    Framing,
    PackedBatchWriter,
    PackedWriter,
    Record,
)
from bubblerob_env.ros.messages.distros import get_distro, message_definition

__all__ = [
    "COMPRESSIONS",
    "DEFAULT_COMPRESSION",
    "DEFAULT_DISTRO",
    "FORMATS",
    "BagPathError",
    "BagSink",
    "bag_path",
    "check_bag_args",
    "lock_bag",
    "open_bag",
    "remove_bag",
]

FORMATS = ("mcap", "sqlite3", "ros1")
COMPRESSIONS: dict[str, tuple[str, ...]] = {
    "mcap": ("zstd", "none"),
    "sqlite3": ("none",),
    "ros1": ("none", "bz2", "lz4"),
}
"""Compressions each format offers; the first one is the default."""
DEFAULT_COMPRESSION = {fmt: options[0] for fmt, options in COMPRESSIONS.items()}
DEFAULT_DISTRO = {"mcap": "jazzy", "sqlite3": "jazzy", "ros1": "noetic"}

_CALLERID = "/bubblerob_recorder"


class BagPathError(OSError):
    """A bag cannot be written where asked (the message names the path and the reason)."""


def bag_path(path: str | Path, fmt: str) -> Path:
    """Where a bag of format ``fmt`` asked for at ``path`` goes: ROS 1 bags end in ``.bag``.

    ROS 2 bags are directories (``path/`` holds ``metadata.yaml`` and ``<name>.mcap``/``.db3``).
    """
    path = Path(path)
    if fmt == "ros1" and path.suffix != ".bag":
        path = path.with_name(path.name + ".bag")
    return path


def remove_bag(path: Path) -> None:
    """Delete a bag: a ROS 2 bag directory with its files, or a ROS 1 file (or a link)."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    else:
        path.unlink(missing_ok=True)


def _prepare(path: Path, overwrite: bool) -> None:
    """Refuse or clear an existing bag, and make sure the parent directory is writable."""
    if path.exists() or path.is_symlink():
        if not overwrite:
            # The path as the error's filename: the CLI words its own message ("--overwrite").
            raise FileExistsError(
                errno.EEXIST, "bag already exists; pass overwrite=True to replace it", str(path)
            )
        if path.is_dir() and not path.is_symlink():
            unknown = [
                p.name
                for p in path.iterdir()
                if p.name != "metadata.yaml" and p.suffix not in (".mcap", ".db3", ".zstd")
            ]
            if unknown:
                raise BagPathError(
                    f"not overwriting {path}: it is a directory with files that are not part of "
                    f"a bag ({', '.join(sorted(unknown)[:5])})"
                )
        remove_bag(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise BagPathError(f"cannot create the directory for bag {path}: {error}") from error


class BagSink:
    """One bag file (or ROS 2 bag directory) being written. Use :func:`open_bag` to make one."""

    def __init__(self, path: Path, fmt: str, distro: str) -> None:
        self.path = path
        self.format = fmt
        self.distro = distro
        self.closed = False
        self._connections: dict[str, Connection] = {}
        self.lock: BagLock | None = None
        """This process's lock on the bag (:func:`open_bag` takes it, ``close`` gives it back)."""

    def add_topic(self, topic: str, msgtype: str, latched: bool = False) -> None:
        """Declare ``topic`` with type ``msgtype`` (the distro's definition goes in the bag)."""
        raise NotImplementedError

    def write_batch(self, records: Sequence[Record]) -> None:
        """Append messages; topics must have been added."""
        raise NotImplementedError

    def framing(self) -> Framing | None:
        """How this sink frames records, if it takes packed frames (:meth:`write_packed`)."""
        return None

    def write_packed(self, data: bytes, layout: FrameLayout, stamp_ns: int, action_ns: int) -> None:
        """Append one packed frame: records framed by :meth:`framing`, laid out as ``layout``."""
        raise NotImplementedError

    def packed_writer(self) -> PackedWriter:
        """The fastest callable doing :meth:`write_packed` (looked up once, called per frame)."""
        return self.write_packed

    def packed_batch_writer(self) -> PackedBatchWriter:
        """The callable that appends many packed frames at once (sinks with a framing)."""
        raise NotImplementedError

    def set_metadata(self, key: str, value: str) -> None:
        """Bag-level metadata (ROS 2 ``custom_data``, also in MCAP's metadata); ROS 1: ignored."""

    def flush(self) -> None:
        """Put everything written so far on disk (data only; the index comes with ``close``)."""

    def close(self) -> None:
        """Finish the file (index and summary), then give back the bag's lock. Safe twice."""
        if self.closed:
            return
        self.closed = True
        try:
            self._finish()
        finally:
            if self.lock is not None:
                self.lock.release()

    def _finish(self) -> None:
        """Write the format's index and summary and close the file."""
        raise NotImplementedError

    @property
    def topics(self) -> tuple[str, ...]:
        """Topics added so far."""
        return tuple(self._connections)


class _Ros1Sink(BagSink):
    def __init__(self, path: Path, distro: str, compression: str, chunk_size: int | None) -> None:
        super().__init__(path, "ros1", distro)
        self._ids: dict[str, int] = {}
        self._writer = Ros1Writer(path)
        if chunk_size is not None:
            self._writer.set_chunk_size(chunk_size)
        if compression != "none":
            self._writer.set_compression(rosbag1.Writer.CompressionFormat[compression.upper()])
        self._writer.open()

    def add_topic(self, topic: str, msgtype: str, latched: bool = False) -> None:
        text, md5sum = message_definition(self.distro, msgtype)
        self._connections[topic] = self._writer.add_connection(
            topic,
            msgtype,
            msgdef=text,
            md5sum=md5sum,
            callerid=_CALLERID,
            latching=1 if latched else None,
        )
        self._ids[topic] = self._connections[topic].id

    def write_batch(self, records: Sequence[Record]) -> None:
        self._writer.write_many(records, self._ids)

    def framing(self) -> Framing | None:
        return Framing("ros1", tuple(self._ids.items()))

    def write_packed(self, data: bytes, layout: FrameLayout, stamp_ns: int, action_ns: int) -> None:
        self._writer.write_packed(data, layout, stamp_ns, action_ns)

    def packed_writer(self) -> PackedWriter:
        return self._writer.write_packed

    def packed_batch_writer(self) -> PackedBatchWriter:
        return self._writer.write_packed_batch

    def flush(self) -> None:
        self._writer.flush()

    def _finish(self) -> None:
        self._writer.close()


def _qos(latched: bool) -> list[Qos]:
    """Offered QoS: transient-local (latched) where it matters, else none (``ros2 bag`` default).

    Every profile becomes YAML in metadata.yaml, which ``rosbags`` writes slowly at close.
    """
    if not latched:
        return []
    forever = QosTime(0, 0)
    return [
        Qos(
            QosHistory.KEEP_LAST,
            1,
            QosReliability.RELIABLE,
            QosDurability.TRANSIENT_LOCAL,
            forever,
            forever,
            QosLiveliness.AUTOMATIC,
            forever,
            False,
        )
    ]


class _Rosbag2Sink(BagSink):
    def __init__(
        self, path: Path, fmt: str, distro: str, compression: str, chunk_size: int | None
    ) -> None:
        super().__init__(path, fmt, distro)
        self._ids: dict[str, int] = {}
        plugin = StoragePlugin.MCAP if fmt == "mcap" else StoragePlugin.SQLITE3
        self._humble = distro == "humble"  # Humble's format: see bags/humble.py
        version: Literal[8, 9] = 8 if self._humble else 9
        self._writer = Rosbag2Writer(path, version=version, storage_plugin=plugin)
        self._writer.humble = self._humble
        if compression == "zstd":  # MCAP chunk compression, as `ros2 bag record` does it
            self._writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
        self._writer.open()
        self._writer.compress_chunks_fast()  # zstd level -3: ros2.MCAP_ZSTD_LEVEL
        if chunk_size is not None:
            self._writer.set_chunk_size(chunk_size)

    def add_topic(self, topic: str, msgtype: str, latched: bool = False) -> None:
        text, digest = message_definition(self.distro, msgtype)
        self._connections[topic] = self._writer.add_connection(
            topic,
            msgtype,
            msgdef=text,
            rihs01=digest,
            offered_qos_profiles=humble_qos(latched) if self._humble else _qos(latched),
        )
        self._ids[topic] = self._connections[topic].id

    def write_batch(self, records: Sequence[Record]) -> None:
        if records:
            self._writer.write_many(records, self._ids)

    def framing(self) -> Framing | None:
        kind = "mcap" if self.format == "mcap" else "raw"  # sqlite3: one row per message
        return Framing(kind, tuple(self._ids.items()))

    def write_packed(self, data: bytes, layout: FrameLayout, stamp_ns: int, action_ns: int) -> None:
        self._writer.write_packed(data, layout, stamp_ns, action_ns)

    def packed_writer(self) -> PackedWriter:
        return self._writer.packed_writer()

    def packed_batch_writer(self) -> PackedBatchWriter:
        return self._writer.packed_batch_writer()

    def set_metadata(self, key: str, value: str) -> None:
        self._writer.set_custom_data(key, value)

    def flush(self) -> None:
        self._writer.flush()

    def _finish(self) -> None:
        self._writer.close()


def open_bag(
    path: str | Path,
    fmt: str = "mcap",
    distro: str | None = None,
    compression: str | None = None,
    overwrite: bool = False,
    chunk_size: int | None = None,
    lock_held: bool = False,
) -> BagSink:
    """Create a bag and open it for writing.

    Args:
        path: ROS 1: the ``.bag`` file (``.bag`` is appended if missing); ROS 2: the bag directory.
        fmt: ``"mcap"`` (ROS 2, default), ``"sqlite3"`` (ROS 2) or ``"ros1"``.
        distro: Whose message definitions the bag carries: ``"noetic"`` for ``ros1``, ``"jazzy"``
            (default) or ``"humble"`` for the ROS 2 formats.
        compression: See :data:`COMPRESSIONS`; default: the format's first.
        overwrite: Replace an existing bag instead of raising ``FileExistsError``.
        chunk_size: MCAP and ROS 1: a chunk closes once it holds more than this many bytes
            (default: ``rosbags``' sizes, 1 MiB for MCAP and 768 KiB for ROS 1).
        lock_held: The caller holds the bag's lock (:func:`lock_bag`) and gives it back: a
            writer process, whose recording process locked the bag before starting it.

    Raises:
        FileExistsError: The bag exists and ``overwrite`` is false.
        BagPathError: The bag cannot be created there (the message says why).
        ValueError: An unknown format, or a distro or compression the format does not offer.
    """
    distro, compression = check_bag_args(fmt, distro, compression)
    target = bag_path(path, fmt)
    lock = None if lock_held else lock_bag(target)
    try:
        _prepare(target, overwrite)
        sink: BagSink
        if fmt == "ros1":
            sink = _Ros1Sink(target, distro, compression, chunk_size)
        else:
            sink = _Rosbag2Sink(target, fmt, distro, compression, chunk_size)
    except (OSError, sqlite3.Error, rosbag1.WriterError, rosbag2.WriterError) as error:
        if lock is not None:
            lock.release()
        if target.is_dir() and not any(target.iterdir()):
            target.rmdir()  # do not leave an empty "bag" behind
        if isinstance(error, (FileExistsError, BagPathError)):
            raise  # from _prepare: the message says it all
        raise BagPathError(f"cannot write bag {target}: {error}") from error
    except BaseException:
        if lock is not None:
            lock.release()
        raise
    sink.lock = lock
    return sink


def check_bag_args(fmt: str, distro: str | None, compression: str | None) -> tuple[str, str]:
    """``(distro, compression)`` of a bag of format ``fmt``, defaults filled in (:func:`open_bag`).

    Raises:
        ValueError: An unknown format, or a distro or compression the format does not offer.
    """
    if fmt not in FORMATS:
        raise ValueError(f"unknown bag format {fmt!r}; choose one of {list(FORMATS)}")
    distro = distro or DEFAULT_DISTRO[fmt]
    ros_version = get_distro(distro).ros_version
    if (ros_version == 1) != (fmt == "ros1"):
        kind = "ROS 1 (noetic)" if fmt == "ros1" else "ROS 2 (humble, jazzy)"
        raise ValueError(f"format {fmt!r} needs a {kind} distro, got {distro!r}")
    compression = compression or DEFAULT_COMPRESSION[fmt]
    if compression not in COMPRESSIONS[fmt]:
        raise ValueError(
            f"format {fmt!r} offers compression {list(COMPRESSIONS[fmt])}, got {compression!r}"
        )
    return distro, compression


def lock_bag(target: Path) -> BagLock:
    """Take the lock of the bag at ``target`` (creating its directory), as :func:`open_bag` does.

    Raises:
        BagLockedError: Another process writes the bag.
        BagPathError: The lock cannot be created there.
    """
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        return BagLock(target)
    except BagLockedError:
        raise
    except OSError as error:
        raise BagPathError(f"cannot create bag {target}: {error.strerror or error}") from error
