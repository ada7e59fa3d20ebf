"""Occupancy grids of the arena: the ground truth of an episode and a log-odds laser mapper.

Grids follow ``nav_msgs/OccupancyGrid``: ``int8`` cells, row-major from the origin at the grid's
lower-left corner (row ``i`` is ``y = origin_y + (i + 0.5) * resolution`` at its centre, column
``j`` likewise in ``x``), 100 occupied, 0 free, -1 unknown. No ROS import: the ROS layer can publish
these arrays as messages.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from bubblerob_env import names
from bubblerob_env.arena import ArenaLayout, Obstacle

__all__ = [
    "DEFAULT_RESOLUTION",
    "RESOLUTION_RANGE",
    "Grid",
    "LogOddsMapper",
    "check_resolution",
    "episode_grid",
    "has_arena",
    "ground_truth_grid",
    "occupied_iou",
]

DEFAULT_RESOLUTION = 0.05
"""Metres per cell."""
RESOLUTION_RANGE = (0.005, 1.0)
"""Allowed metres per cell, inclusive (a 4 m arena: 840 to 5 cells a side)."""
OCCUPIED = 100
FREE = 0
UNKNOWN = -1


@dataclass(frozen=True)
class Grid:
    """An occupancy grid: ``data[row, col]``, origin (m) of the lower-left corner, resolution."""

    data: NDArray[np.int8]
    origin: tuple[float, float]
    resolution: float

    @property
    def centres(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The x and y of every cell's centre, each shaped like ``data``."""
        rows, cols = self.data.shape
        xs = self.origin[0] + (np.arange(cols) + 0.5) * self.resolution
        ys = self.origin[1] + (np.arange(rows) + 0.5) * self.resolution
        x, y = np.meshgrid(xs, ys)
        return x, y


def check_resolution(resolution: Any) -> float:
    """``resolution`` (metres per cell) as a float, or a ``ValueError`` naming it and the range.

    Accepts numbers and their text (a command-line value).
    """
    low, high = RESOLUTION_RANGE
    try:
        value = float(resolution)
    except (TypeError, ValueError):
        value = math.nan
    if not low <= value <= high:  # NaN fails too
        raise ValueError(
            f"map resolution {resolution!r} is not a number of metres per cell from {low:g} to "
            f"{high:g}"
        )
    return value


def ground_truth_grid(
    layout: ArenaLayout,
    arena_size: float,
    wall_thickness: float = 0.1,
    resolution: float = DEFAULT_RESOLUTION,
) -> Grid:
    """The arena's walls and ``layout``'s obstacle footprints; a cell is occupied if its centre is.

    The grid covers the inside square and the walls around it (``wall_thickness`` m each). No
    obstacle or wall is ever lost: one whose footprint holds no cell centre (an obstacle smaller
    than a cell, walls thinner than half a cell) occupies every cell it touches instead.
    """
    resolution = check_resolution(resolution)
    arena = _arena_cells(float(arena_size), float(wall_thickness), resolution)
    grid = Grid(np.zeros(arena.walls.shape, dtype=np.int8), arena.origin, resolution)
    occupied = arena.walls.copy()
    for obstacle in layout.obstacles:
        # Only the cells around the obstacle: every centre its footprint holds is among them.
        window = _window(obstacle, arena)
        inside = _footprint(obstacle, arena.x[window], arena.y[window])
        if inside.any():
            occupied[window] |= inside
        else:
            occupied |= _touched(obstacle, grid)
    grid.data[occupied] = OCCUPIED
    return grid


@dataclass(frozen=True)
class _ArenaCells:
    """An arena's cells (read-only): their centres, the walls' cells, the lower-left corner."""

    x: NDArray[np.float64]
    y: NDArray[np.float64]
    walls: NDArray[np.bool_]
    origin: tuple[float, float]
    resolution: float


@functools.lru_cache(maxsize=16)
def _arena_cells(arena_size: float, wall_thickness: float, resolution: float) -> _ArenaCells:
    """The cells of an arena, made once per size, wall thickness and resolution."""
    outer = arena_size / 2.0 + wall_thickness
    cells = math.ceil(round(2 * outer / resolution, 9))
    origin = (-cells * resolution / 2.0, -cells * resolution / 2.0)
    x, y = Grid(np.zeros((cells, cells), dtype=np.int8), origin, resolution).centres
    half = arena_size / 2.0
    edge = resolution / 2.0  # from a cell's centre to its sides
    walls = np.zeros((cells, cells), dtype=bool)
    for axis, side in ((x, 1.0), (x, -1.0), (y, 1.0), (y, -1.0)):
        wall = side * axis > half
        walls |= wall if wall.any() else side * axis + edge > half
    for array in (x, y, walls):
        array.setflags(write=False)
    return _ArenaCells(x, y, walls, origin, resolution)


def _window(obstacle: Obstacle, arena: _ArenaCells) -> tuple[slice, slice]:
    """Rows and columns of the cells whose centres may lie in ``obstacle``'s footprint.

    Those within its bounding radius of its centre, with two cells to spare each way.
    """
    rows, cols = arena.walls.shape
    reach = obstacle.bounding_radius / arena.resolution + 2.0
    col = (obstacle.x - arena.origin[0]) / arena.resolution - 0.5
    row = (obstacle.y - arena.origin[1]) / arena.resolution - 0.5
    col_lo, col_hi = max(0, math.floor(col - reach)), min(cols, math.ceil(col + reach) + 1)
    row_lo, row_hi = max(0, math.floor(row - reach)), min(rows, math.ceil(row + reach) + 1)
    return slice(row_lo, max(row_lo, row_hi)), slice(col_lo, max(col_lo, col_hi))


def _footprint(obstacle: Obstacle, x: NDArray[np.float64], y: NDArray[np.float64]) -> Any:
    """Whether each point ``(x, y)`` lies in ``obstacle``'s footprint (its edge included)."""
    dx, dy = x - obstacle.x, y - obstacle.y
    if obstacle.kind == "cylinder":
        return np.hypot(dx, dy) <= obstacle.size[0]
    c, s = math.cos(obstacle.yaw), math.sin(obstacle.yaw)
    local_x, local_y = c * dx + s * dy, -s * dx + c * dy
    return (np.abs(local_x) <= obstacle.size[0]) & (np.abs(local_y) <= obstacle.size[1])


def _touched(obstacle: Obstacle, grid: Grid) -> NDArray[np.bool_]:
    """The cells holding points of a footprint smaller than a cell (its centre among them).

    Points on a lattice at a fifth of the footprint's smallest extent, clipped to the footprint:
    every cell the footprint covers a fifth of an extent of is found, and its own centre's always.
    """
    reach = obstacle.bounding_radius
    step = min(obstacle.size) / 5.0
    offsets = np.arange(-reach, reach + step / 2.0, step)
    px, py = np.meshgrid(obstacle.x + offsets, obstacle.y + offsets)
    keep = _footprint(obstacle, px, py)
    xs = np.append(px[keep], obstacle.x)
    ys = np.append(py[keep], obstacle.y)
    rows, cols = grid.data.shape
    col = np.clip(np.floor((xs - grid.origin[0]) / grid.resolution).astype(int), 0, cols - 1)
    row = np.clip(np.floor((ys - grid.origin[1]) / grid.resolution).astype(int), 0, rows - 1)
    touched = np.zeros(grid.data.shape, dtype=bool)
    touched[row, col] = True
    return touched


def has_arena(env: Any) -> bool:
    """Whether ``env``'s scene has the arena's walls (a scene from ``xml_file`` may not)."""
    model = env.unwrapped.model
    geom = mujoco.mjtObj.mjOBJ_GEOM
    return all(mujoco.mj_name2id(model, geom, name) >= 0 for name in names.ARENA_WALLS)


def episode_grid(env: Any, resolution: float = DEFAULT_RESOLUTION) -> Grid:
    """The ground-truth grid of ``env``'s current episode (call after ``reset``).

    Needs the arena's walls (:func:`has_arena`): other scenes raise ``KeyError``.
    """
    base = env.unwrapped
    model = base.model
    thickness = 0.0
    for name in names.ARENA_WALLS:
        size = model.geom(name).size
        thickness = max(thickness, 2.0 * float(min(size[0], size[1])))
    return ground_truth_grid(base.layout, float(base.arena_size), thickness, resolution)


class LogOddsMapper:
    """A log-odds occupancy mapper of 2D laser scans on a fixed grid.

    Each beam lowers the log odds of the cells it crosses and, if it hit something before its
    maximum range, raises the log odds of the cell at its end.
    """

    def __init__(
        self,
        like: Grid,
        hit: float = 0.85,
        miss: float = -0.4,
        clamp: float = 5.0,
        depth: float | None = None,
    ) -> None:
        """Map onto a grid of ``like``'s shape, origin and resolution.

        ``depth`` (m, default half a cell) moves each hit that far beyond the surface along its
        beam, so that the occupied cell is one whose centre lies inside the obstacle (a surface
        point lands in a cell whose centre is outside about half of the time).
        """
        self.depth = like.resolution / 2.0 if depth is None else depth
        self.origin = like.origin
        self.resolution = like.resolution
        self.log_odds: NDArray[np.float64] = np.zeros(tuple(like.data.shape), dtype=np.float64)
        self.hit, self.miss, self.clamp = hit, miss, clamp

    def _cells(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.int64]:
        cols = np.floor((x - self.origin[0]) / self.resolution).astype(np.int64)
        rows = np.floor((y - self.origin[1]) / self.resolution).astype(np.int64)
        rows_n, cols_n = self.log_odds.shape[:2]
        inside = (rows >= 0) & (rows < rows_n) & (cols >= 0) & (cols < cols_n)
        flat: NDArray[np.int64] = np.where(inside, rows * cols_n + cols, -1)
        return flat

    def add_scan(
        self,
        pose: tuple[float, float, float],
        angles: NDArray[np.float64],
        ranges: NDArray[np.float64],
        range_max: float,
    ) -> None:
        """Add one scan taken by a laser at ``pose`` (x, y, yaw in the map frame)."""
        x0, y0, yaw = pose
        ranges = np.asarray(ranges, dtype=np.float64)
        valid = np.isfinite(ranges)
        ranges = np.where(valid, ranges, range_max)
        hit = valid & (ranges < range_max - 1e-6)
        directions = yaw + np.asarray(angles, dtype=np.float64)
        step = self.resolution / 2.0
        flat = self.log_odds.reshape(-1)
        free_cells: list[NDArray[np.int64]] = []
        for distance, angle in zip(ranges, directions, strict=True):
            samples = np.arange(0.0, max(distance - self.resolution, 0.0), step)
            cells = self._cells(x0 + samples * math.cos(angle), y0 + samples * math.sin(angle))
            free_cells.append(cells[cells >= 0])
        if free_cells:
            free = np.unique(np.concatenate(free_cells))
            flat[free] += self.miss
        deep = ranges + self.depth
        ends = self._cells(x0 + deep * np.cos(directions), y0 + deep * np.sin(directions))
        ends = np.unique(ends[hit & (ends >= 0)])
        flat[ends] += self.hit
        np.clip(self.log_odds, -self.clamp, self.clamp, out=self.log_odds)

    def grid(self) -> Grid:
        """The map: occupied where the log odds are positive, free where negative, else unknown."""
        data = np.full(self.log_odds.shape, UNKNOWN, dtype=np.int8)
        data[self.log_odds > 0] = OCCUPIED
        data[self.log_odds < 0] = FREE
        return Grid(data, self.origin, self.resolution)


def occupied_iou(a: Grid, b: Grid) -> float:
    """Intersection over union of the occupied cells of two grids of the same shape."""
    if a.data.shape != b.data.shape:
        raise ValueError(f"grids differ in shape: {a.data.shape} and {b.data.shape}")
    occ_a, occ_b = a.data == OCCUPIED, b.data == OCCUPIED
    union = int(np.count_nonzero(occ_a | occ_b))
    return int(np.count_nonzero(occ_a & occ_b)) / union if union else 1.0
