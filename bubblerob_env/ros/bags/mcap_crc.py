"""CRCs of a finished MCAP file: the data section's and the summary's, written in place.

``rosbags`` writes 0 for every CRC ("not computed"), so corruption goes unnoticed. Chunk CRCs
(of the uncompressed records) are written with each chunk (:mod:`~bubblerob_env.ros.bags.ros2`);
the data section CRC (``DataEnd``) and the summary CRC (``Footer``) cover the whole file, so they
are computed when the file is finished: :func:`seal` reads it back once (CRC-32 runs at over a
GB/s) and patches the two fields, as the MCAP spec defines them
(https://mcap.dev/spec#data-end-op0x0f, https://mcap.dev/spec#footer-op0x02).
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path
from typing import BinaryIO

__all__ = ["seal"]

MAGIC = b"\x89MCAP0\r\n"
_FOOTER = 1 + 8 + 8 + 8 + 4  # opcode, length, summary_start, summary_offset_start, summary_crc
_DATA_END = 1 + 8 + 4  # opcode, length, data_section_crc


def _crc(stream: BinaryIO, start: int, stop: int) -> int:
    crc = 0
    stream.seek(start)
    left = stop - start
    while left > 0:
        block = stream.read(min(left, 1 << 22))
        if not block:
            raise ValueError("the MCAP file is shorter than its footer says")
        crc = zlib.crc32(block, crc)
        left -= len(block)
    return crc


def seal(path: Path) -> None:
    """Write the data section and summary CRCs of the finished MCAP file at ``path``.

    Raises:
        ValueError: ``path`` does not end as a finished MCAP file (footer, magic, data end).
    """
    with path.open("r+b") as stream:
        size = stream.seek(0, 2)
        stream.seek(size - len(MAGIC) - _FOOTER)
        footer = stream.read(_FOOTER + len(MAGIC))
        if footer[0] != 0x02 or footer[-len(MAGIC) :] != MAGIC:
            raise ValueError(f"{path} has no MCAP footer")
        summary_start, _ = struct.unpack_from("<QQ", footer, 9)
        footer_at = size - len(MAGIC) - _FOOTER
        data_end_at = (summary_start or footer_at) - _DATA_END
        stream.seek(data_end_at)
        if stream.read(9) != b"\x0f" + struct.pack("<Q", 4):
            raise ValueError(f"{path} has no MCAP data end record before its summary")
        data_crc = _crc(stream, 0, data_end_at)
        stream.seek(data_end_at + 9)
        stream.write(struct.pack("<I", data_crc))
        summary_crc = 0
        if summary_start:  # from the summary through the footer's summary_offset_start
            summary_crc = _crc(stream, summary_start, footer_at + 1 + 8 + 16)
        stream.seek(footer_at + 1 + 8 + 16)
        stream.write(struct.pack("<I", summary_crc))
