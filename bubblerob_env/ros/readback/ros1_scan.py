"""A ROS 1 bag's records read in file order, without its index (what ``rosbag reindex`` reads).

Format 2.0 (http://wiki.ros.org/Bags/Format/2.0): after the magic line, records of a header
(``name=value`` fields, ``op`` among them) and data. The first record (op 3) says where the index
starts (0 until the bag is finished). Chunks (op 5) hold connection (op 7) and message (op 2)
records, compressed with bz2 or LZ4 (roslz4's frame format) or not at all. Reading stops at a
record that runs past the end of the file (*cut short*: the recorder was killed) or at the first
record that is wrong (*damage*: a header that does not parse, a chunk that does not decompress,
reported with its byte offset and chunk number).
"""

from __future__ import annotations

import bz2
import struct
from collections.abc import Iterator
from pathlib import Path

from bubblerob_env.ros.readback.scan import CorruptBagError, Scan

__all__ = ["MAGIC", "index_is_cut_short", "index_position", "scan_ros1"]

MAGIC = b"#ROSBAG V2.0\n"
_OP_MESSAGE, _OP_BAG_HEADER, _OP_INDEX, _OP_CHUNK, _OP_CHUNK_INFO, _OP_CONNECTION = 2, 3, 4, 5, 6, 7
_OPS = {_OP_MESSAGE, _OP_BAG_HEADER, _OP_INDEX, _OP_CHUNK, _OP_CHUNK_INFO, _OP_CONNECTION}


class _Malformed(ValueError):
    """A record that does not parse."""


def _fields(header: bytes) -> dict[str, bytes]:
    fields: dict[str, bytes] = {}
    pos = 0
    while pos < len(header):
        if pos + 4 > len(header):
            raise _Malformed("a header field runs past its header")
        (size,) = struct.unpack_from("<I", header, pos)
        if pos + 4 + size > len(header):
            raise _Malformed("a header field runs past its header")
        name, equals, value = header[pos + 4 : pos + 4 + size].partition(b"=")
        if not equals:
            raise _Malformed("a header field without '='")
        try:
            fields[name.decode("ascii")] = value
        except UnicodeDecodeError:
            raise _Malformed("a header field name that is not ASCII") from None
        pos += 4 + size
    return fields


def _records(data: bytes, pos: int) -> Iterator[tuple[int, bytes, bytes] | int]:
    """``(offset, header, data)`` of each whole record from ``pos`` on.

    Then, if the last one runs past the end of ``data``, its offset.
    """
    while pos < len(data):
        if pos + 4 > len(data):
            yield pos
            return
        (header_len,) = struct.unpack_from("<I", data, pos)
        data_at = pos + 4 + header_len
        if data_at + 4 > len(data):
            yield pos
            return
        (data_len,) = struct.unpack_from("<I", data, data_at)
        end = data_at + 4 + data_len
        if end > len(data):
            yield pos
            return
        yield pos, data[pos + 4 : data_at], data[data_at + 4 : end]
        pos = end


def _decompress(compression: bytes, data: bytes) -> bytes:
    if compression == b"none":
        return data
    try:
        if compression == b"bz2":
            return bz2.decompress(data)
        if compression == b"lz4":
            import lz4.frame

            return bytes(lz4.frame.decompress(data))
    except Exception as error:  # noqa: BLE001 - bz2 and lz4 raise their own types
        raise _Malformed(f"its {compression.decode()} data does not decompress ({error})") from None
    raise _Malformed(f"unknown chunk compression {compression!r}")


def _msgtype(ros1_type: str) -> str:
    package, _, name = ros1_type.partition("/")
    return f"{package}/msg/{name}"


def _op(fields: dict[str, bytes]) -> int:
    op = fields.get("op", b"")
    if len(op) != 1 or op[0] not in _OPS:
        raise _Malformed(f"no record type {op!r} in ROS 1 bags")
    return op[0]


def _take(scan: Scan, fields: dict[str, bytes], body: bytes) -> None:
    """Add a connection or message record to ``scan``."""
    op = _op(fields)
    try:
        if op == _OP_CONNECTION:
            (cid,) = struct.unpack("<I", fields["conn"])
            msgtype = _fields(body)["type"].decode()
            scan.topics[cid] = (fields["topic"].decode(), _msgtype(msgtype))
        elif op == _OP_MESSAGE:
            (cid,) = struct.unpack("<I", fields["conn"])
            sec, nsec = struct.unpack("<II", fields["time"])
            scan.messages.append((cid, sec * 10**9 + nsec, body))
    except (KeyError, struct.error, UnicodeDecodeError) as error:
        raise _Malformed(f"a bad {type(error).__name__} field ({error})") from None


def index_position(path: Path) -> int:
    """Where the bag's index starts, from its header record (0: the bag was never finished).

    Raises:
        OSError: Not a ROS 1 bag.
        CorruptBagError: Its header record is damaged.
    """
    with path.open("rb") as stream:
        head = stream.read(len(MAGIC) + 4096 + 8)
    if not head.startswith(MAGIC):
        raise OSError(f"{path} is not a ROS 1 bag (no '#ROSBAG V2.0' line)")
    for record in _records(head, len(MAGIC)):
        try:
            if isinstance(record, int):
                raise _Malformed("it runs past the end of the file")
            fields = _fields(record[1])
            if _op(fields) != _OP_BAG_HEADER:
                raise _Malformed("it is not the bag header record")
            (position,) = struct.unpack("<Q", fields["index_pos"])
        except (_Malformed, KeyError, struct.error) as error:
            raise CorruptBagError(
                f"{path}: the bag header at byte {len(MAGIC)} is damaged: {error}"
            ) from None
        return int(position)
    raise CorruptBagError(f"{path}: the bag ends after its first line (no bag header record)")


def index_is_cut_short(path: Path) -> bool:
    """Whether the file ends inside a record of its index (a finished bag cut short there)."""
    start = index_position(path)
    data = path.read_bytes()
    return 0 < start < len(data) and any(isinstance(r, int) for r in _records(data, start))


def scan_ros1(path: Path) -> Scan:
    """Every connection and message of the ROS 1 bag at ``path``.

    Read up to its index, its end or its first damaged record (see the module docstring).

    Raises:
        OSError: ``path`` is not a ROS 1 bag.
    """
    data = path.read_bytes()
    if not data.startswith(MAGIC):
        raise OSError(f"{path} is not a ROS 1 bag (no '#ROSBAG V2.0' line)")
    scan, chunks = Scan(), 0
    for record in _records(data, len(MAGIC)):
        if isinstance(record, int):
            scan.cut_short, scan.cut_at = True, record
            break
        offset, header, body = record
        what = f"record at byte {offset}"
        try:
            fields = _fields(header)
            op = _op(fields)
            if op == _OP_CHUNK:
                chunks += 1
                what = f"chunk {chunks} at byte {offset}"
                inner = _decompress(fields.get("compression", b""), body)
                for inner_record in _records(inner, 0):
                    if isinstance(inner_record, int):
                        raise _Malformed(f"a record in it runs past its end (at {inner_record})")
                    _take(scan, _fields(inner_record[1]), inner_record[2])
            elif op == _OP_CHUNK_INFO:  # the index's last part: the data before it was all read
                scan.data_end = True
                break
            elif op in (_OP_MESSAGE, _OP_CONNECTION):
                _take(scan, fields, body)
        except _Malformed as error:
            scan.damage = f"{path}: {what} is damaged: {error}"
            break
    scan.messages = [m for m in scan.messages if m[0] in scan.topics]
    return scan
