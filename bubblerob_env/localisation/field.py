"""The likelihood field of an occupancy grid: every cell's distance to the nearest occupied cell.

AMCL's ``likelihood_field`` laser model scores a beam by how far its end point lies from the
nearest obstacle of the map; the distances are computed once per map. Here they are exact
Euclidean distances (Felzenszwalb and Huttenlocher's separable squared distance transform, 2012),
capped at ``max_distance`` as AMCL caps them at ``laser_likelihood_max_dist``.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

from bubblerob_env.mapping import OCCUPIED, Grid

__all__ = ["LikelihoodField", "compile_field_kernel", "squared_distance_transform"]

_FAR = 1e20  # squared distance of a cell with nothing occupied on its line (yet)


@njit(cache=True, nogil=True)
def _transform_line(f: NDArray[np.float64], out: NDArray[np.float64]) -> None:
    """1D squared distance transform of ``f`` (0 at sites, _FAR elsewhere) into ``out``."""
    n = f.shape[0]
    vertex = np.zeros(n, dtype=np.int64)
    bound = np.zeros(n + 1)
    k = 0
    vertex[0] = 0
    bound[0], bound[1] = -np.inf, np.inf
    for q in range(1, n):
        s = ((f[q] + q * q) - (f[vertex[k]] + vertex[k] * vertex[k])) / (2.0 * q - 2.0 * vertex[k])
        while s <= bound[k]:
            k -= 1
            s = ((f[q] + q * q) - (f[vertex[k]] + vertex[k] * vertex[k])) / (
                2.0 * q - 2.0 * vertex[k]
            )
        k += 1
        vertex[k] = q
        bound[k], bound[k + 1] = s, np.inf
    k = 0
    for q in range(n):
        while bound[k + 1] < q:
            k += 1
        out[q] = (q - vertex[k]) ** 2 + f[vertex[k]]


@njit(cache=True, nogil=True)
def squared_distance_transform(occupied: NDArray[np.bool_]) -> NDArray[np.float64]:
    """Each cell's squared distance (in cells) to the nearest ``True`` cell; huge if none."""
    rows, cols = occupied.shape
    first = np.empty((rows, cols))
    line = np.empty(max(rows, cols))
    for i in range(rows):
        sites = np.where(occupied[i], 0.0, _FAR)
        _transform_line(sites, line[:cols])
        first[i] = line[:cols]
    result = np.empty((rows, cols))
    for j in range(cols):
        column = first[:, j].copy()
        _transform_line(column, line[:rows])
        result[:, j] = line[:rows]
    return result


def compile_field_kernel() -> None:
    """Compile the transform now (or load it from numba's cache), not at the first map.

    A live node calls this before it says ready, so its first episode does not stall unpublished.
    """
    squared_distance_transform(np.ones((2, 2), dtype=np.bool_))


class LikelihoodField:
    """Distances (m) from every cell of ``grid`` to its nearest occupied cell, capped."""

    def __init__(self, grid: Grid, max_distance: float = 1.0) -> None:
        """Compute the field of ``grid`` (cells >= 50 are occupied, as ``map_server`` reads)."""
        occupied = grid.data >= OCCUPIED // 2
        if not occupied.any():
            raise ValueError("the map has no occupied cell: a laser cannot localise on it")
        squared = squared_distance_transform(np.ascontiguousarray(occupied))
        self.distance = np.minimum(np.sqrt(squared) * grid.resolution, max_distance)
        self.max_distance = float(max_distance)
        self.origin = (float(grid.origin[0]), float(grid.origin[1]))
        self.resolution = float(grid.resolution)
        self.grid = grid

    def lookup(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """The distance at each point (m); ``max_distance`` outside the grid."""
        rows, cols = self.distance.shape
        col = np.floor((x - self.origin[0]) / self.resolution).astype(np.int64)
        row = np.floor((y - self.origin[1]) / self.resolution).astype(np.int64)
        inside = (col >= 0) & (col < cols) & (row >= 0) & (row < rows)
        flat = np.where(inside, row * cols + col, 0)
        return np.where(inside, self.distance.ravel()[flat], self.max_distance)

    def free_cells(self, clearance: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Centres (x, y) of the cells at least ``clearance`` m from anything occupied.

        Only cells inside the map's walls count: a cell whose every straight line to the map's
        edge crosses an occupied cell (the arena is walled) is inside.
        """
        rows, cols = self.distance.shape
        inside = _enclosed(self.grid.data >= OCCUPIED // 2)
        keep = inside & (self.distance >= clearance - 1e-9)
        row, col = np.nonzero(keep)
        x = self.origin[0] + (col + 0.5) * self.resolution
        y = self.origin[1] + (row + 0.5) * self.resolution
        return x.astype(np.float64), y.astype(np.float64)


def _enclosed(occupied: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Free cells with an occupied cell on each side along both axes (inside the walls)."""
    before_x = np.maximum.accumulate(occupied, axis=1)
    after_x = np.maximum.accumulate(occupied[:, ::-1], axis=1)[:, ::-1]
    before_y = np.maximum.accumulate(occupied, axis=0)
    after_y = np.maximum.accumulate(occupied[::-1], axis=0)[::-1]
    return ~occupied & before_x & after_x & before_y & after_y
