"""``write_png``: grey or RGB ``uint8`` images as PNG files with the standard library's zlib.

``bubblerob map`` writes its picture with it: the [ros] extra that the command needs brings no
image library, and a PNG of 8-bit pixels is four chunks (PNG specification, ISO/IEC 15948).
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["write_png"]

_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_COLOUR_TYPES = {2: 0, 3: 2}  # dimensions -> PNG colour type: 0 greyscale, 2 RGB


def _chunk(kind: bytes, payload: bytes) -> bytes:
    crc = zlib.crc32(kind + payload) & 0xFFFFFFFF
    return struct.pack(">I", len(payload)) + kind + payload + struct.pack(">I", crc)


def write_png(path: str | Path, image: NDArray[Any]) -> Path:
    """Write ``image`` (``(height, width)`` grey or ``(height, width, 3)`` RGB, uint8) as a PNG.

    Raises:
        ValueError: For another shape or dtype, or a path that does not end in ``.png``.
        OSError: When the file cannot be written.
    """
    path = Path(path)
    if path.suffix.lower() != ".png":
        raise ValueError(f"the image is written as PNG: name a .png file, got {path.name}")
    pixels = np.asarray(image)
    if pixels.dtype != np.uint8 or pixels.ndim not in _COLOUR_TYPES or 0 in pixels.shape:
        raise ValueError(
            f"write_png takes (height, width) or (height, width, 3) uint8 pixels, "
            f"got {pixels.dtype} of shape {pixels.shape}"
        )
    if pixels.ndim == 3 and pixels.shape[2] != 3:
        raise ValueError(f"write_png takes RGB pixels (3 channels), got shape {pixels.shape}")
    height, width = pixels.shape[:2]
    rows = pixels.reshape(height, -1)
    # Each row starts with its filter type: 0, none.
    raw = np.hstack([np.zeros((height, 1), dtype=np.uint8), rows]).tobytes()
    header = struct.pack(">IIBBBBB", width, height, 8, _COLOUR_TYPES[pixels.ndim], 0, 0, 0)
    path.write_bytes(
        _SIGNATURE
        + _chunk(b"IHDR", header)
        + _chunk(b"IDAT", zlib.compress(raw, 6))
        + _chunk(b"IEND", b"")
    )
    return path
