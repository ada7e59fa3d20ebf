"""A ROS 1 bag's records read in file order, without its index (what ``rosbag reindex`` reads).

Format 2.0 (http://wiki.ros.org/Bags/Format/2.0): after the magic line, records of a header
(``name=value`` fields, ``op`` among them) and data. Chunks (op 5) hold connection (op 7) and
message (op 2) records, compressed with bz2 or LZ4 (roslz4's frame format) or not at all. A file
that stops inside a record, or in a chunk that does not decompress, is read up to that record.
"""

from __future__ import annotations

import bz2
import struct
from collections.abc import Iterator
from pathlib import Path

__all__ = ["read_ros1_records"]

MAGIC = b"#ROSBAG V2.0\n"
_OP_MESSAGE, _OP_CHUNK, _OP_CONNECTION = 2, 5, 7


def _fields(header: bytes) -> dict[str, bytes]:
    fields: dict[str, bytes] = {}
    pos = 0
    while pos + 4 <= len(header):
        (size,) = struct.unpack_from("<I", header, pos)
        name, _, value = header[pos + 4 : pos + 4 + size].partition(b"=")
        fields[name.decode()] = value
        pos += 4 + size
    return fields


def _records(data: bytes, pos: int = 0) -> Iterator[tuple[dict[str, bytes], bytes]]:
    """``(header fields, data)`` of each whole record from ``pos`` on."""
    while pos + 4 <= len(data):
        (header_len,) = struct.unpack_from("<I", data, pos)
        data_at = pos + 4 + header_len
        if data_at + 4 > len(data):
            return
        (data_len,) = struct.unpack_from("<I", data, data_at)
        end = data_at + 4 + data_len
        if end > len(data):
            return
        yield _fields(data[pos + 4 : data_at]), data[data_at + 4 : end]
        pos = end


def _decompress(compression: bytes, data: bytes) -> bytes:
    if compression == b"none":
        return data
    if compression == b"bz2":
        return bz2.decompress(data)
    if compression == b"lz4":
        import lz4.frame

        return bytes(lz4.frame.decompress(data))
    raise ValueError(f"unknown chunk compression {compression!r}")


def _msgtype(ros1_type: str) -> str:
    package, _, name = ros1_type.partition("/")
    return f"{package}/msg/{name}"


def read_ros1_records(
    path: Path,
) -> tuple[dict[int, tuple[str, str]], list[tuple[int, int, bytes]]]:
    """``(topics by connection id: (topic, msgtype), messages: (connection, log ns, raw))``.

    Raises:
        OSError: ``path`` is not a ROS 1 bag.
    """
    data = path.read_bytes()
    if not data.startswith(MAGIC):
        raise OSError(f"{path} is not a ROS 1 bag (no '#ROSBAG V2.0' line)")
    topics: dict[int, tuple[str, str]] = {}
    messages: list[tuple[int, int, bytes]] = []

    def take(fields: dict[str, bytes], body: bytes) -> None:
        op = fields.get("op", b"\0")[0]
        if op == _OP_CONNECTION:
            (cid,) = struct.unpack("<I", fields["conn"])
            info = _fields(body)
            topics[cid] = (fields["topic"].decode(), _msgtype(info["type"].decode()))
        elif op == _OP_MESSAGE:
            (cid,) = struct.unpack("<I", fields["conn"])
            sec, nsec = struct.unpack("<II", fields["time"])
            messages.append((cid, sec * 10**9 + nsec, body))

    for fields, body in _records(data, len(MAGIC)):
        if fields.get("op", b"\0")[0] != _OP_CHUNK:
            take(fields, body)
            continue
        try:
            inner = _decompress(fields["compression"], body)
        except Exception:  # noqa: BLE001 - a chunk cut short: the bag ends before it
            break
        for inner_fields, inner_body in _records(inner):
            take(inner_fields, inner_body)
    messages = [m for m in messages if m[0] in topics]
    return topics, messages
