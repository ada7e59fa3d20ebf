"""Paths drawn on an occupancy grid as an RGB image: NumPy only, for ``bubblerob localize``'s PNG.

The ``ros`` extra that ``bubblerob localize`` needs brings no plotting library, so the picture is
rasterised here: the map's cells (occupied black, free white, unknown grey), north up, each
``scale`` pixels wide, and each path as a line of the width given (pixels), drawn in the order
given (the last on top), with a square at its start.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from bubblerob_env.mapping import OCCUPIED, UNKNOWN, Grid

__all__ = ["ESTIMATE", "ODOMETRY", "TRUTH", "draw_paths", "side_by_side"]

TRUTH = (40, 160, 40)
"""Green: the true path."""
ODOMETRY = (214, 39, 40)
"""Red: raw odometry."""
ESTIMATE = (31, 119, 180)
"""Blue: the filter's estimate."""


def _map_image(grid: Grid, scale: int) -> NDArray[np.uint8]:
    grey = np.full(grid.data.shape, 190, dtype=np.uint8)
    grey[grid.data >= OCCUPIED // 2] = 0
    grey[(grid.data >= 0) & (grid.data < OCCUPIED // 2)] = 255
    grey[grid.data == UNKNOWN] = 190
    image = grey[::-1].repeat(scale, axis=0).repeat(scale, axis=1)
    return np.repeat(image[:, :, None], 3, axis=2)


def _pixels(grid: Grid, scale: int, xy: NDArray[np.float64]) -> NDArray[np.float64]:
    """(row, col) pixel coordinates (floats) of map points ``xy`` (``(n, 2)``)."""
    height = grid.data.shape[0] * scale
    col = (xy[:, 0] - grid.origin[0]) / grid.resolution * scale
    row = height - (xy[:, 1] - grid.origin[1]) / grid.resolution * scale
    return np.column_stack([row, col])


def _line_points(points: NDArray[np.float64]) -> NDArray[np.float64]:
    """Points every half pixel along the polyline through ``points`` (``(n, 2)`` pixels)."""
    pieces = [points[:1]]
    for a, b in zip(points[:-1], points[1:], strict=True):
        count = max(1, int(np.ceil(2.0 * np.abs(b - a).max())))
        t = np.arange(1, count + 1)[:, None] / count
        pieces.append(a + t * (b - a))
    return np.concatenate(pieces)


def _stamp(image: NDArray[np.uint8], rows: NDArray[np.int64], cols: NDArray[np.int64],
           colour: tuple[int, int, int], size: int) -> None:  # fmt: skip
    height, width = image.shape[:2]
    for dr in range(size):
        for dc in range(size):
            r, c = rows + dr - size // 2, cols + dc - size // 2
            inside = (r >= 0) & (r < height) & (c >= 0) & (c < width)
            image[r[inside], c[inside]] = colour


def draw_paths(
    grid: Grid,
    paths: Sequence[tuple[NDArray[np.float64], tuple[int, int, int], int]],
    scale: int = 4,
) -> NDArray[np.uint8]:
    """The map of ``grid`` with each ``(poses, colour, width)`` path (poses ``(n, >=2)``, m)."""
    if scale < 1:
        raise ValueError(f"scale must be a whole number of pixels >= 1, got {scale}")
    image = _map_image(grid, scale)
    for poses, colour, width in paths:
        xy = np.asarray(poses, dtype=np.float64)[:, :2]
        xy = xy[np.isfinite(xy).all(axis=1)]
        if len(xy) == 0:
            continue
        line = np.floor(_line_points(_pixels(grid, scale, xy))).astype(np.int64)
        _stamp(image, line[:, 0], line[:, 1], colour, width)
        _stamp(image, line[:1, 0], line[:1, 1], colour, 2 * scale + 1)
    return image


def side_by_side(images: Sequence[NDArray[np.uint8]], columns: int = 4) -> NDArray[np.uint8]:
    """``images`` in rows of ``columns``, 4 grey pixels apart (smaller ones padded grey)."""
    if not images:
        raise ValueError("no image to arrange")
    gap = 4
    height = max(i.shape[0] for i in images)
    width = max(i.shape[1] for i in images)
    count = min(columns, len(images))
    rows = -(-len(images) // count)
    sheet = np.full(
        (rows * height + (rows - 1) * gap, count * width + (count - 1) * gap, 3), 96, np.uint8
    )
    for k, image in enumerate(images):
        top, left = (k // count) * (height + gap), (k % count) * (width + gap)
        sheet[top : top + image.shape[0], left : left + image.shape[1]] = image
    return sheet
