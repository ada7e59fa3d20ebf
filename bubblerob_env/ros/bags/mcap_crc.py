"""CRCs of a finished MCAP file: the data section's and the summary's, written in place.

``rosbags`` writes 0 for every CRC ("not computed"), so corruption goes unnoticed. Chunk CRCs
(of the uncompressed records) are written with each chunk (:mod:`~bubblerob_env.ros.bags.ros2`);
the data section CRC (``DataEnd``) and the summary CRC (``Footer``) cover the whole file, so they
are computed when the file is finished: :func:`seal` reads it back once (CRC-32 runs at over a
GB/s) and patches the two fields, as the MCAP spec defines them
(https://mcap.dev/spec#data-end-op0x0f, https://mcap.dev/spec#footer-op0x02).

A chunk's CRC costs about half its compression (zlib's CRC-32 runs at ~1.2 GB/s here, zstd at
level 1 at ~0.5-0.7 GB/s on frames): :func:`crc_beside` computes it in a worker thread while the
caller compresses the same bytes. Both release the GIL, so on two cores the chunk closes in the
time of the compression alone; it still closes before the call returns (flushes and crash safety
see the same file as before).
"""

from __future__ import annotations

import os
import struct
import zlib
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import BinaryIO, TypeVar

__all__ = ["crc_beside", "seal"]

_T = TypeVar("_T")
BESIDE_FROM = 64 * 1024
"""Smaller chunks take their CRC in the caller: handing work to a thread costs ~50 us."""
_worker: tuple[int, ThreadPoolExecutor] | None = None  # this process's (pid): a fork has none


def crc_beside(data: memoryview, work: Callable[[memoryview], _T]) -> tuple[int, _T]:
    """``(zlib.crc32(data), work(data))``, the CRC computed in a worker thread meanwhile."""
    global _worker  # noqa: PLW0603 - one worker per process, made on first use
    if data.nbytes < BESIDE_FROM:
        return zlib.crc32(data), work(data)
    if _worker is None or _worker[0] != os.getpid():  # a forked child: its own worker
        _worker = (os.getpid(), ThreadPoolExecutor(1, thread_name_prefix="bubblerob-crc"))
    try:
        crc = _worker[1].submit(zlib.crc32, data)
    except RuntimeError:  # interpreter shutdown: safety's atexit hook finishing a bag
        return zlib.crc32(data), work(data)
    try:
        result = work(data)
    finally:
        value = crc.result()  # the worker lets go of data before the caller releases it
    return value, result


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
