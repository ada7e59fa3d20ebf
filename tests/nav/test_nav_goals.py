"""Every drawn goal is reachable and far enough, checked on geometry this test computes itself.

The oracle rasterises the episode's layout (``env.unwrapped.layout``) with its own point-in-shape
tests, widens the obstacles by dilating the raster with a disc (not the env's exact Minkowski
sum at cell centres), and searches it breadth-first, 4-connected (not Dijkstra, 8-connected).
"""

from __future__ import annotations

import math
from collections import deque

import gymnasium as gym
import numpy as np
import pytest

import bubblerob_env  # noqa: F401  (registers the ids)


def _raster(layout, arena_size, cell):
    """Occupied cells of the walls and obstacles: True where a cell's centre is inside one."""
    n = round(arena_size / cell)
    centres = (np.arange(n) + 0.5) * cell - arena_size / 2
    x, y = np.meshgrid(centres, centres)  # [row, col] = (y, x)
    occupied = np.zeros((n, n), dtype=bool)
    for o in layout.obstacles:
        if o.kind == "cylinder":
            occupied |= (x - o.x) ** 2 + (y - o.y) ** 2 <= o.size[0] ** 2
        else:
            u = (x - o.x) * math.cos(o.yaw) + (y - o.y) * math.sin(o.yaw)
            v = -(x - o.x) * math.sin(o.yaw) + (y - o.y) * math.cos(o.yaw)
            occupied |= (abs(u) <= o.size[0]) & (abs(v) <= o.size[1])
    return occupied, centres


def _dilate(occupied, cells):
    """Grow the occupied cells by a disc of ``cells`` cells; the border counts as occupied."""
    r = math.ceil(cells)
    padded = np.pad(occupied, r, constant_values=True)
    grown = np.zeros_like(occupied)
    n = occupied.shape[0]
    for dy in range(-r, r + 1):
        for dx in range(-r, r + 1):
            if dx * dx + dy * dy <= cells * cells:
                grown |= padded[r + dy : r + dy + n, r + dx : r + dx + n]
    return grown


def _reachable(blocked, start, goal):
    """Breadth-first search, 4-connected, from ``start`` to ``goal`` (row, col)."""
    seen = np.zeros_like(blocked)
    queue = deque([start])
    seen[start] = True
    while queue:
        r, c = queue.popleft()
        if (r, c) == goal:
            return True
        for nr, nc in ((r + 1, c), (r - 1, c), (r, c + 1), (r, c - 1)):
            inside = 0 <= nr < blocked.shape[0] and 0 <= nc < blocked.shape[1]
            if inside and not blocked[nr, nc] and not seen[nr, nc]:
                seen[nr, nc] = True
                queue.append((nr, nc))
    return False


def _clearance(layout, arena_size, px, py):
    """Exact distance from the point to the nearest wall or obstacle footprint (m)."""
    half = arena_size / 2
    gaps = [half - abs(px), half - abs(py)]
    for o in layout.obstacles:
        if o.kind == "cylinder":
            gaps.append(math.hypot(px - o.x, py - o.y) - o.size[0])
        else:
            u = (px - o.x) * math.cos(o.yaw) + (py - o.y) * math.sin(o.yaw)
            v = -(px - o.x) * math.sin(o.yaw) + (py - o.y) * math.cos(o.yaw)
            gaps.append(math.hypot(max(abs(u) - o.size[0], 0), max(abs(v) - o.size[1], 0)))
    return min(gaps)


@pytest.mark.parametrize(("env_id", "seeds", "cell"), [
    ("BubbleRobNav-v0", range(40), 0.02),
    ("PioneerP3DXNav-v0", range(12), 0.05),
])  # fmt: skip
def test_every_drawn_goal_is_reachable_and_at_least_1_m_away(env_id, seeds, cell):
    env = gym.make(env_id)
    base = env.unwrapped
    radius, arena = base.robot.radius, float(base.arena_size)
    for seed in seeds:
        _, info = env.reset(seed=seed)
        layout = base.layout
        (sx, sy, _), (gx, gy) = layout.start_pose, info["goal"]
        assert math.hypot(gx - sx, gy - sy) >= 1.0
        # The robot fits at the goal: its circle touches nothing (the exact geometry).
        assert _clearance(layout, arena, gx, gy) >= radius
        # A way exists: the raster widened by the radius (less 1.5 cells: a disc of cells is
        # coarser than the exact widening) joins the start's cell to the goal's.
        occupied, centres = _raster(layout, arena, cell)
        blocked = _dilate(occupied, radius / cell - 1.5)
        row, col = (int(np.argmin(abs(centres - v))) for v in (sy, sx))
        start = (row, col)
        goal = (int(np.argmin(abs(centres - gy))), int(np.argmin(abs(centres - gx))))
        assert _reachable(blocked, start, goal), (env_id, seed)
        # The shortest path runs clear of everything (a grid's centres: within a cell's
        # half-diagonal) and is no shorter than the straight line.
        path = base.problem.path
        assert np.allclose(path[0], (sx, sy)) and np.allclose(path[-1], (gx, gy))
        for a, b in zip(path[:-1], path[1:], strict=True):
            for t in np.linspace(0, 1, 50):
                px, py = a + t * (b - a)
                tolerance = base.grid_resolution * math.sqrt(0.5)
                assert _clearance(layout, arena, px, py) >= radius - tolerance, (seed, px, py)
        euclid = math.hypot(gx - sx, gy - sy)
        assert euclid - 1e-9 <= info["shortest_path_length"]
        lengths = np.hypot(*np.diff(path, axis=0).T).sum()
        assert info["shortest_path_length"] == pytest.approx(lengths)
    env.close()
