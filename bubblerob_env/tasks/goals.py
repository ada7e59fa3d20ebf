"""Goals on the ground-truth grid: where the robot's centre may go, shortest paths, a drawn goal.

The robot's centre may be wherever its bounding circle touches nothing: outside every obstacle's
footprint and the walls widened by the robot's radius (their Minkowski sum with its circle),
decided exactly at each cell's centre (:func:`clearance_grid`). Paths are searched on those cells
by Dijkstra, 8-connected with exact costs (a side step one cell, a diagonal sqrt(2) cells; a
diagonal never cuts the corner of a blocked cell), then shortened by line of sight: a grid path
is up to 8% longer than the straight segments a robot drives, which would flatter every SPL.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import NDArray

from bubblerob_env.arena import ArenaLayout
from bubblerob_env.mapping import DEFAULT_RESOLUTION, FREE, OCCUPIED, Grid

__all__ = [
    "NavProblem",
    "clearance_grid",
    "distance_field",
    "draw_goal",
    "draw_problem",
    "line_of_sight",
    "path_length",
    "plan_path",
]

_SQRT2 = math.sqrt(2.0)
_NEIGHBOURS = np.array(
    [(-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (-1, 1), (1, -1), (1, 1)], dtype=np.int64
)


@dataclass(frozen=True)
class NavProblem:
    """One episode's task: drive from ``start`` to ``goal`` (x, y in metres).

    ``path`` is the shortest path's points ``(n, 2)`` from start to goal, ``length`` its length
    (m), ``grid`` the cells the robot's centre may occupy (``FREE``) for that robot's radius.
    """

    start: tuple[float, float]
    goal: tuple[float, float]
    path: NDArray[np.float64]
    length: float
    grid: Grid


def clearance_grid(
    layout: ArenaLayout, arena_size: float, inflation: float, resolution: float = DEFAULT_RESOLUTION
) -> Grid:
    """The cells whose centre keeps ``inflation`` metres from every wall and obstacle footprint.

    Occupied (100) where a circle of radius ``inflation`` about the cell's centre would overlap
    a wall (the arena's inside is the square of side ``arena_size``) or an obstacle; else free.
    The grid covers the arena's inside square.
    """
    cells = math.ceil(round(arena_size / resolution, 9))
    origin = (-cells * resolution / 2.0, -cells * resolution / 2.0)
    grid = Grid(np.full((cells, cells), FREE, dtype=np.int8), origin, resolution)
    x, y = grid.centres
    limit = arena_size / 2.0 - inflation
    occupied = (np.abs(x) > limit) | (np.abs(y) > limit)
    for obstacle in layout.obstacles:
        dx, dy = x - obstacle.x, y - obstacle.y
        if obstacle.kind == "cylinder":
            occupied |= np.hypot(dx, dy) < obstacle.size[0] + inflation
        else:
            c, s = math.cos(obstacle.yaw), math.sin(obstacle.yaw)
            outside_x = np.maximum(np.abs(c * dx + s * dy) - obstacle.size[0], 0.0)
            outside_y = np.maximum(np.abs(-s * dx + c * dy) - obstacle.size[1], 0.0)
            occupied |= np.hypot(outside_x, outside_y) < inflation
    grid.data[occupied] = OCCUPIED
    return grid


@njit(cache=True)
def _dijkstra(
    free: NDArray[np.bool_], source: int, neighbours: NDArray[np.int64]
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    rows, cols = free.shape
    dist = np.full(rows * cols, np.inf)
    parent = np.full(rows * cols, -1, dtype=np.int64)
    dist[source] = 0.0
    heap = [(0.0, source)]
    while heap:
        d, cell = heapq.heappop(heap)
        if d > dist[cell]:
            continue
        r, c = cell // cols, cell % cols
        for k in range(8):
            dr, dc = neighbours[k, 0], neighbours[k, 1]
            nr, nc = r + dr, c + dc
            if nr < 0 or nr >= rows or nc < 0 or nc >= cols or not free[nr, nc]:
                continue
            diagonal = dr != 0 and dc != 0
            if diagonal and not (free[r + dr, c] and free[r, c + dc]):
                continue  # never squeeze between two blocked cells' corners
            step = _SQRT2 if diagonal else 1.0
            nd = d + step
            neighbour = nr * cols + nc
            if nd < dist[neighbour]:
                dist[neighbour] = nd
                parent[neighbour] = cell
                heapq.heappush(heap, (nd, neighbour))
    return dist, parent


def cell_of(grid: Grid, point: tuple[float, float]) -> tuple[int, int]:
    """The (row, col) of the cell holding ``point``, clipped to the grid."""
    rows, cols = grid.data.shape
    col = int(np.clip(math.floor((point[0] - grid.origin[0]) / grid.resolution), 0, cols - 1))
    row = int(np.clip(math.floor((point[1] - grid.origin[1]) / grid.resolution), 0, rows - 1))
    return row, col


def distance_field(
    grid: Grid, source: tuple[float, float]
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Path lengths (m) from ``source``'s cell to every cell (inf: unreachable), and parents.

    Both are flat arrays over the grid's cells (row-major); ``parent[i]`` is the cell before
    ``i`` on a shortest path, -1 at the source and at unreachable cells.
    """
    row, col = cell_of(grid, source)
    cols = grid.data.shape[1]
    free = grid.data == FREE
    dist, parent = _dijkstra(free, row * cols + col, _NEIGHBOURS)
    return dist * grid.resolution, parent


def _cell_centres(grid: Grid, cells: NDArray[np.int64]) -> NDArray[np.float64]:
    cols = grid.data.shape[1]
    x = grid.origin[0] + (cells % cols + 0.5) * grid.resolution
    y = grid.origin[1] + (cells // cols + 0.5) * grid.resolution
    return np.stack([x, y], axis=1)


def line_of_sight(grid: Grid, a: NDArray[np.float64], b: NDArray[np.float64]) -> bool:
    """Whether the segment ``a``-``b`` crosses only free cells (sampled every quarter cell)."""
    samples = max(2, math.ceil(float(np.hypot(*(b - a))) / (grid.resolution / 4.0)) + 1)
    t = np.linspace(0.0, 1.0, samples)[:, None]
    points = a[None, :] + t * (b - a)[None, :]
    rows, cols = grid.data.shape
    col = np.floor((points[:, 0] - grid.origin[0]) / grid.resolution).astype(np.int64)
    row = np.floor((points[:, 1] - grid.origin[1]) / grid.resolution).astype(np.int64)
    inside = (row >= 0) & (row < rows) & (col >= 0) & (col < cols)
    return bool(inside.all() and (grid.data[row, col] == FREE).all())


def _shortcut(grid: Grid, points: NDArray[np.float64]) -> NDArray[np.float64]:
    """String pulling: from each kept point, jump to the farthest point in line of sight."""
    kept = [0]
    while kept[-1] < len(points) - 1:
        here = kept[-1]
        ahead = here + 1
        for later in range(len(points) - 1, here + 1, -1):
            if line_of_sight(grid, points[here], points[later]):
                ahead = later
                break
        kept.append(ahead)
    return points[kept]


def path_length(points: NDArray[np.float64]) -> float:
    """The length (m) of a polyline ``(n, 2)``."""
    return float(np.hypot(*np.diff(points, axis=0).T).sum()) if len(points) > 1 else 0.0


def _backtrack(parent: NDArray[np.int64], cell: int) -> NDArray[np.int64]:
    cells = [cell]
    while parent[cells[-1]] >= 0:
        cells.append(int(parent[cells[-1]]))
    return np.array(cells[::-1], dtype=np.int64)


def plan_path(
    grid: Grid, start: tuple[float, float], goal: tuple[float, float]
) -> NDArray[np.float64] | None:
    """The shortest path ``(n, 2)`` from ``start`` to ``goal`` on ``grid``, or None if none.

    The grid search's cells between the two points, shortened by line of sight.
    """
    dist, parent = distance_field(grid, start)
    row, col = cell_of(grid, goal)
    target = row * grid.data.shape[1] + col
    if not math.isfinite(dist[target]):
        return None
    return _polyline(grid, parent, target, start, goal)


def _polyline(
    grid: Grid,
    parent: NDArray[np.int64],
    target: int,
    start: tuple[float, float],
    goal: tuple[float, float],
) -> NDArray[np.float64]:
    centres = _cell_centres(grid, _backtrack(parent, target))
    points = np.vstack([np.array([start]), centres[1:-1], np.array([goal])])
    return _shortcut(grid, points)


def draw_problem(
    rng: np.random.Generator,
    layout: ArenaLayout,
    arena_size: float,
    robot_radius: float,
    min_distance: float,
    resolution: float = DEFAULT_RESOLUTION,
) -> NavProblem | None:
    """A goal drawn uniformly among the cells reachable from the layout's start pose.

    The goal is a free cell's centre at least ``min_distance`` metres (straight line) from the
    start, on a grid widened by ``robot_radius``. None when no cell qualifies (the start boxed
    in), so that the caller draws another layout.
    """
    grid = clearance_grid(layout, arena_size, robot_radius, resolution)
    start = (layout.start_pose[0], layout.start_pose[1])
    return draw_goal(rng, grid, start, min_distance)


def draw_goal(
    rng: np.random.Generator,
    grid: Grid,
    start: tuple[float, float],
    min_distance: float,
    taken: tuple[tuple[float, float], ...] = (),
    spacing: float = 0.0,
) -> NavProblem | None:
    """A goal drawn uniformly among the free cells of ``grid`` reachable from ``start``.

    At least ``min_distance`` m from the start and ``spacing`` m from every point of ``taken``
    (other robots' goals), in a straight line; None when no cell qualifies.
    """
    dist, parent = distance_field(grid, start)
    centres = _cell_centres(grid, np.arange(dist.size, dtype=np.int64))
    far = np.hypot(centres[:, 0] - start[0], centres[:, 1] - start[1]) >= min_distance
    for x, y in taken:
        far &= np.hypot(centres[:, 0] - x, centres[:, 1] - y) >= spacing
    candidates = np.flatnonzero(np.isfinite(dist) & far)
    if candidates.size == 0:
        return None
    target = int(candidates[rng.integers(candidates.size)])
    goal = (float(centres[target, 0]), float(centres[target, 1]))
    path = _polyline(grid, parent, target, start, goal)
    return NavProblem(start, goal, path, path_length(path), grid)
