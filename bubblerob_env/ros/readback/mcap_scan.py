"""An MCAP file's records read in file order, checked, with the byte offset of the first damage.

MCAP (https://mcap.dev/spec): the magic, then records of an opcode (u8), a length (u64) and a
body. Chunks (op 0x06) hold schema, channel and message records, compressed with zstd or LZ4 or
not at all, with a CRC-32 of their uncompressed records; ``DataEnd`` (0x0F) closes the data
section with its CRC, and the ``Footer`` (0x02) holds the summary's CRC. A CRC of 0 means "not
computed" and is not checked.

Read to the first record that ends past the end of the file (a recording that was killed: *cut
short*) or to the first one that is wrong (a CRC mismatch, an opcode MCAP does not define, a chunk
that does not decompress or parse: *damage*, reported with its offset and chunk number).
"""

from __future__ import annotations

import mmap
import os
import struct
import sys
import zlib
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from bubblerob_env.ros.readback.scan import Scan

if sys.version_info >= (3, 14):  # the zstd that rosbags uses
    from compression import zstd
else:
    from backports import zstd

__all__ = ["MAGIC", "mapped", "check_mcap_crcs", "has_mcap_footer", "scan_mcap"]

MAGIC = b"\x89MCAP0\r\n"
_OP_FOOTER, _OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE, _OP_CHUNK, _OP_DATA_END = 2, 3, 4, 5, 6, 15
_LAST_DEFINED_OP = 0x0F  # 0x80-0xFF are private records, allowed; 0x10-0x7F are not defined
_FOOTER_SIZE = 1 + 8 + 8 + 8 + 4
_DATA_END_SIZE = 1 + 8 + 4


class _Malformed(ValueError):
    """A record whose fields do not fit its length."""


class _Fields:
    """Little-endian fields of one record body, read in order."""

    def __init__(self, body: bytes) -> None:
        self.body, self.pos = body, 0

    def take(self, size: int) -> bytes:
        if size < 0 or self.pos + size > len(self.body):
            raise _Malformed(f"a field of {size} bytes runs past its record")
        value = self.body[self.pos : self.pos + size]
        self.pos += size
        return value

    def int(self, fmt: str) -> int:
        (value,) = struct.unpack(fmt, self.take(struct.calcsize(fmt)))
        return int(value)

    def text(self) -> str:
        try:
            return self.take(self.int("<I")).decode()
        except UnicodeDecodeError as error:
            raise _Malformed(f"a string that is not UTF-8 ({error.reason})") from None

    def rest(self) -> bytes:
        return self.take(len(self.body) - self.pos)


def _decompress(compression: str, data: bytes) -> bytes:
    if compression == "":
        return data
    if compression == "zstd":
        return bytes(zstd.decompress(data))
    if compression == "lz4":
        import lz4.frame

        return bytes(lz4.frame.decompress(data))
    raise _Malformed(f"unknown chunk compression {compression!r}")


def _take_record(scan: Scan, schemas: dict[int, str], op: int, body: bytes) -> bool:
    """Add a schema, channel or message record to ``scan`` (others are skipped); True."""
    fields = _Fields(body)
    if op == _OP_SCHEMA:
        schema_id = fields.int("<H")
        schemas[schema_id] = fields.text()
    elif op == _OP_CHANNEL:
        channel_id, schema_id = fields.int("<H"), fields.int("<H")
        scan.topics[channel_id] = (fields.text(), schemas.get(schema_id, ""))
    elif op == _OP_MESSAGE:
        channel_id = fields.int("<H")
        fields.take(4)  # sequence
        log_time = fields.int("<Q")
        fields.take(8)  # publish time
        scan.messages.append((channel_id, log_time, fields.rest()))
    return True


def _chunk_records(body: bytes) -> bytes:
    """The uncompressed records of a chunk, its CRC checked."""
    fields = _Fields(body)
    fields.take(16)  # message start and end times
    size, crc = fields.int("<Q"), fields.int("<I")
    compression = fields.text()
    records = fields.take(fields.int("<Q"))
    try:
        inner = _decompress(compression, records)
    except _Malformed:
        raise
    except Exception as error:  # noqa: BLE001 - zstd and lz4 raise their own types
        raise _Malformed(f"its {compression} data does not decompress ({error})") from None
    if len(inner) != size:
        raise _Malformed(f"it holds {len(inner)} bytes, its header says {size}")
    if crc and zlib.crc32(inner) != crc:
        raise _Malformed("chunk CRC mismatch")
    return inner


def _walk(data: bytes, start: int, on_record: Callable[[int, int, bytes], bool]) -> int | None:
    """Call ``on_record(offset, op, body)`` for each whole record until it returns False.

    Returns the offset of a record that runs past the end of ``data``, or ``None``.
    """
    pos = start
    while pos < len(data):
        if pos + 9 > len(data):
            return pos
        op = data[pos]
        (length,) = struct.unpack_from("<Q", data, pos + 1)
        if pos + 9 + length > len(data):
            return pos
        if not on_record(pos, op, data[pos + 9 : pos + 9 + length]):
            return None
        pos += 9 + length
    return None


def scan_mcap(path: Path) -> Scan:
    """Every schema, channel and message of the MCAP file at ``path``.

    Read up to its data end, its end or its first damaged record (see the module docstring).

    Raises:
        OSError: ``path`` cannot be read or is not an MCAP file (no magic).
    """
    data = path.read_bytes()
    if not data.startswith(MAGIC):
        raise OSError(f"{path} is not an MCAP file (no MCAP magic at its start)")
    scan = Scan()
    schemas: dict[int, str] = {}
    chunks = 0

    def on_record(offset: int, op: int, body: bytes) -> bool:
        nonlocal chunks
        if op == 0 or _LAST_DEFINED_OP < op < 0x80:
            scan.damage = f"{path}: record opcode 0x{op:02x} (none such in MCAP) at byte {offset}"
            return False
        try:
            if op == _OP_CHUNK:
                chunks += 1
                inner = _chunk_records(body)
                where = _walk(inner, 0, lambda _, o, b: _take_record(scan, schemas, o, b))
                if where is not None:
                    raise _Malformed(f"a record in it runs past its end (at {where})")
            else:
                _take_record(scan, schemas, op, body)
        except (_Malformed, struct.error) as error:
            what = f"chunk {chunks} at byte {offset}" if op == _OP_CHUNK else f"record at {offset}"
            scan.damage = f"{path}: {what} is damaged: {error}"
            return False
        if op == _OP_DATA_END:
            scan.data_end = True
            return False
        return True

    scan.cut_short = _walk(data, len(MAGIC), on_record) is not None
    return scan


def has_mcap_footer(path: Path) -> bool:
    """Whether the file ends as a finished MCAP file does: a footer record, then the magic."""
    with path.open("rb") as stream:
        size = stream.seek(0, 2)
        if size < len(MAGIC) * 2 + _FOOTER_SIZE:
            return False
        stream.seek(size - len(MAGIC) - _FOOTER_SIZE)
        tail = stream.read()
    return tail[0] == _OP_FOOTER and tail.endswith(MAGIC)


@contextmanager
def mapped(path: Path) -> Iterator[bytes | mmap.mmap]:
    """The file's bytes, mapped (not read: bags run to gigabytes)."""
    with path.open("rb") as stream:
        if os.fstat(stream.fileno()).st_size == 0:
            yield b""
            return
        with mmap.mmap(stream.fileno(), 0, access=mmap.ACCESS_READ) as data:
            yield data


def _crc(data: bytes | mmap.mmap, start: int, stop: int) -> int:
    with memoryview(data) as view:
        return zlib.crc32(view[start:stop])


def check_mcap_crcs(path: Path) -> str | None:
    """Check the data section's and the summary's CRCs of a finished MCAP file.

    Returns ``None`` if they match (or were not computed), else the damage in words, located to
    the chunk when it is in one.
    """
    with mapped(path) as data:
        return _check_crcs(path, data)


def _check_crcs(path: Path, data: bytes | mmap.mmap) -> str | None:
    footer_at = len(data) - len(MAGIC) - _FOOTER_SIZE
    if footer_at < len(MAGIC) or data[footer_at] != _OP_FOOTER or data[-len(MAGIC) :] != MAGIC:
        return f"{path}: no MCAP footer at the end of the file (byte {max(footer_at, 0)})"
    summary_start, _, summary_crc = struct.unpack_from("<QQI", data, footer_at + 9)
    end = summary_start or footer_at
    if not len(MAGIC) <= end - _DATA_END_SIZE <= footer_at:
        return f"{path}: the footer's summary offset {summary_start} is outside the file"
    data_end_at = end - _DATA_END_SIZE
    if data[data_end_at] != _OP_DATA_END:
        return f"{path}: no data end record at byte {data_end_at}, where the footer puts it"
    (data_crc,) = struct.unpack_from("<I", data, data_end_at + 9)
    if data_crc and _crc(data, 0, data_end_at) != data_crc:
        located = scan_mcap(path).damage
        return located or f"{path}: the data section (bytes 0 to {data_end_at}) fails its CRC"
    if summary_start and summary_crc and _crc(data, summary_start, footer_at + 25) != summary_crc:
        return f"{path}: the summary (bytes {summary_start} to {footer_at}) fails its CRC"
    return None
