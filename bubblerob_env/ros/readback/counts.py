"""Messages per topic as a ROS 2 storage file itself counts them, to check ``metadata.yaml``.

``rosbags`` takes a ROS 2 bag's message counts from its ``metadata.yaml``, which no checksum
covers: a flipped digit there would be printed by ``info`` as the truth. The storage file counts
too: an MCAP file in its summary's ``Statistics`` record (per channel), an sqlite3 file in its
``messages`` table.
"""

from __future__ import annotations

import mmap
import sqlite3
import struct
from pathlib import Path

from bubblerob_env.ros.readback.mcap_scan import MAGIC, mapped

__all__ = ["storage_counts"]

_OP_CHANNEL, _OP_STATISTICS = 0x04, 0x0B
_FOOTER_SIZE = 1 + 8 + 8 + 8 + 4


def _text(body: bytes, pos: int) -> tuple[str, int]:
    (size,) = struct.unpack_from("<I", body, pos)
    return body[pos + 4 : pos + 4 + size].decode(), pos + 4 + size


def _mcap_counts(path: Path) -> dict[str, int] | None:
    with mapped(path) as data:
        return _summary_counts(data)


def _summary_counts(data: bytes | mmap.mmap) -> dict[str, int] | None:
    footer_at = len(data) - len(MAGIC) - _FOOTER_SIZE
    (summary_start,) = struct.unpack_from("<Q", data, footer_at + 9)
    if not summary_start:
        return None
    topics: dict[int, str] = {}
    per_channel: dict[int, int] | None = None
    pos = summary_start
    while pos + 9 <= footer_at:
        op = data[pos]
        (length,) = struct.unpack_from("<Q", data, pos + 1)
        body = data[pos + 9 : pos + 9 + length]
        if op == _OP_CHANNEL:
            (channel,) = struct.unpack_from("<H", body, 0)
            topics[channel] = _text(body, 4)[0]
        elif op == _OP_STATISTICS:
            # message, schema, channel, attachment, metadata and chunk counts, start and end
            # times (42 bytes), then the map's byte length and its (u16 channel, u64) entries.
            (size,) = struct.unpack_from("<I", body, 42)
            entries = body[46 : 46 + size]
            per_channel = {
                channel: count
                for channel, count in (
                    struct.unpack_from("<HQ", entries, at) for at in range(0, size, 10)
                )
            }
        pos += 9 + length
    if per_channel is None:
        return None
    counts: dict[str, int] = {}
    for channel, count in per_channel.items():
        topic = topics.get(channel, f"channel {channel}")
        counts[topic] = counts.get(topic, 0) + count
    return counts


def _sqlite_counts(path: Path) -> dict[str, int]:
    db = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True)
    try:
        rows = db.execute(
            "SELECT topics.name, COUNT(*) FROM messages JOIN topics "
            "ON messages.topic_id = topics.id GROUP BY topics.name"
        )
        return {str(name): int(count) for name, count in rows}
    finally:
        db.close()


def storage_counts(path: Path) -> dict[str, int] | None:
    """``topic -> messages`` as the storage file at ``path`` counts them.

    Topics with none are left out; ``None`` if the file does not say (MCAP without statistics).

    Raises:
        struct.error, UnicodeDecodeError, sqlite3.Error: The file's own records are damaged.
    """
    counts = _mcap_counts(path) if path.suffix == ".mcap" else _sqlite_counts(path)
    return None if counts is None else {t: n for t, n in counts.items() if n}
