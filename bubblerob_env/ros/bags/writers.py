"""``rosbags``' bag writers with batch writes and packed frames, and the internals they rely on.

Writing one message costs a ``rosbags`` writer a few microseconds; a recorder writes ~15 per env
step. These subclasses take a whole frame at once straight into the open chunk (MCAP, ROS 1) or one
``executemany`` (sqlite3). With one message per batch the files are identical to ``rosbags``' own
(``tests/ros/test_sinks.py`` checks), with two deliberate differences in ROS 1 bags: LZ4 chunks
use the frame options Debian's ``roslz4`` requires, and the bag header record has rosbag's size
(the first chunk starts 8 bytes later), so that ``rosbag reindex`` can rewrite it in place.
Faster still, MCAP and ROS 1 take *packed frames* (:meth:`Ros1Writer.write_packed`,
:meth:`Rosbag2Writer.write_packed`, see :mod:`~bubblerob_env.ros.fastpath.framing`), appended with
one write each and indexed when their chunk closes.

Every use of ``rosbags``' private API (classes of ``rosbags.rosbag1.writer`` and its storages,
attributes of its writers) is in :mod:`~bubblerob_env.ros.bags.ros1` (:class:`Ros1Writer`) and
:mod:`~bubblerob_env.ros.bags.ros2` (:class:`Rosbag2Writer`, its MCAP and sqlite3 storages),
which this module re-exports, and :data:`RELIED_ON` lists it:
``tests/ros/test_rosbags_internals.py`` fails loudly when a ``rosbags`` release changes any of it.
``pyproject.toml`` pins ``rosbags`` to the tested range.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from rosbags import rosbag1, rosbag2
from rosbags.rosbag1 import writer as _rosbag1_writer
from rosbags.rosbag1.reader import RecordType
from rosbags.rosbag1.writer import Header, WriteChunk
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2.storage_mcap import McapWriter, PendingChunk
from rosbags.rosbag2.storage_sqlite3 import Sqlite3Writer

from bubblerob_env.ros.bags.ros1 import Ros1Writer, roslz4_compress
from bubblerob_env.ros.bags.ros2 import Rosbag2Writer
from bubblerob_env.ros.fastpath.framing import NO_TIME

__all__ = [
    "RELIED_ON",
    "Ros1Writer",
    "Rosbag2Writer",
    "roslz4_compress",
]

RELIED_ON: dict[Any, tuple[str, ...]] = {
    rosbag1.Writer: (
        "bio", "chunks", "chunk_threshold", "compressor", "compression_format", "connections",
        "write_connection", "write_chunk", "set_compression", "open", "close",
    ),
    WriteChunk: ("data", "pos", "start", "end", "connections"),
    Header: ("set_string", "set_uint32", "set_uint64", "set_time", "write"),
    RecordType: ("BAGHEADER", "CHUNK", "CHUNK_INFO", "IDXDATA"),
    rosbag2.Writer: (
        "STORAGE_PLUGINS", "storage", "counts", "min_timestamp", "max_timestamp", "open", "close",
    ),
    McapWriter: (
        "bio", "chunk", "chunks", "channel_stats", "compression", "compressor", "close_chunk",
        "message_start_time", "message_end_time", "channels", "schemas", "path",
        "add_connection",
    ),
    PendingChunk: ("message_start_time", "message_end_time", "bio", "msgs"),
    Sqlite3Writer: ("cursor", "conn"),
}  # fmt: skip
"""Names of ``rosbags``' private API this module uses, per class (instance attributes included)."""


def rosbags_changes() -> list[str]:
    """What of :data:`RELIED_ON` the installed ``rosbags`` lacks (empty: nothing changed).

    Instance attributes are looked up on a freshly opened writer of each kind.
    """
    import tempfile

    missing = []
    if _rosbag1_writer.MAXSIZE != NO_TIME:
        missing.append(f"rosbag1.writer.MAXSIZE is {_rosbag1_writer.MAXSIZE}, not {NO_TIME}")
    with tempfile.TemporaryDirectory() as tmp:
        ros1 = rosbag1.Writer(Path(tmp) / "x.bag")
        ros1.open()
        instances: dict[Any, Any] = {rosbag1.Writer: ros1, WriteChunk: ros1.chunks[-1]}
        for plugin in (StoragePlugin.MCAP, StoragePlugin.SQLITE3):
            ros2 = rosbag2.Writer(Path(tmp) / plugin.name, version=9, storage_plugin=plugin)
            ros2.open()
            instances[rosbag2.Writer] = ros2
            instances[type(ros2.storage)] = ros2.storage
            if isinstance(ros2.storage, McapWriter):
                instances[PendingChunk] = ros2.storage.chunk
            ros2.close()
        ros1.close()
        for owner, names in RELIED_ON.items():
            where = instances.get(owner, owner)
            missing += [f"{owner.__qualname__}.{n}" for n in names if not hasattr(where, n)]
    return missing
