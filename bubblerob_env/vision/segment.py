"""Pixel work of the recogniser, compiled by numba: colour codes, then connected components.

Each pixel gets a code: 0 for the floor and anything unsaturated, ``1..P`` for the nearest
palette hue of a saturated pixel, ``P + 1`` for the walls' brown. Lighting in the scene is white,
so shading scales a surface's RGB and keeps its hue and saturation: the code of a pixel does not
depend on how brightly its face is lit. Components join 4-neighbours of the same code; wall pixels
join only at the same brightness, because each wall is one flat face evenly lit by the camera's
headlight, so two walls meeting in a corner come apart.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["components", "pixel_codes"]

MIN_OBSTACLE_SATURATION = 0.55
"""Palette colours have saturation >= 0.8; the walls' brown has 0.36, the floor's grey 0.02."""
WALL_SATURATION = (0.25, 0.47)
WALL_HUE = (18.0, 42.0)  # degrees; the brown is at 30
MIN_VALUE = 24  # darker pixels have too few levels to tell their hue


@njit(cache=True, nogil=True)
def _hue(r: float, g: float, b: float, high: float, spread: float) -> float:
    if high == r:
        hue = 60.0 * ((g - b) / spread)
    elif high == g:
        hue = 60.0 * ((b - r) / spread + 2.0)
    else:
        hue = 60.0 * ((r - g) / spread + 4.0)
    return hue + 360.0 if hue < 0.0 else hue


@njit(cache=True, nogil=True)
def pixel_codes(
    frame: NDArray[np.uint8], palette_hues: NDArray[np.float64]
) -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
    """Each pixel's code (see the module) and brightness (its largest channel)."""
    height, width = frame.shape[0], frame.shape[1]
    wall_code = palette_hues.shape[0] + 1
    codes = np.zeros((height, width), np.uint8)
    value = np.empty((height, width), np.uint8)
    for v in range(height):
        for u in range(width):
            r, g, b = float(frame[v, u, 0]), float(frame[v, u, 1]), float(frame[v, u, 2])
            high = max(r, g, b)
            spread = high - min(r, g, b)
            value[v, u] = np.uint8(high)
            if high < MIN_VALUE or spread == 0.0:
                continue
            saturation = spread / high
            hue = _hue(r, g, b, high, spread)
            if saturation >= MIN_OBSTACLE_SATURATION:
                best, best_gap = 0, 360.0
                for k in range(palette_hues.shape[0]):
                    gap = abs(hue - palette_hues[k])
                    gap = min(gap, 360.0 - gap)
                    if gap < best_gap:
                        best, best_gap = k, gap
                codes[v, u] = best + 1
            elif (
                WALL_SATURATION[0] <= saturation <= WALL_SATURATION[1]
                and WALL_HUE[0] <= hue <= WALL_HUE[1]
            ):
                codes[v, u] = wall_code
    return codes, value


@njit(cache=True, nogil=True)
def components(
    codes: NDArray[np.uint8], value: NDArray[np.uint8], wall_code: int
) -> tuple[NDArray[np.int32], NDArray[np.int64], NDArray[np.int64], NDArray[np.bool_]]:
    """Connected components of the coded pixels.

    Returns:
        labels ``(height, width)`` (-1: code 0), per component its ``code``, its stats ``(pixels,
        u_min, v_min, u_max, v_max)`` and which of the 256 brightness levels occur in it.
    """
    height, width = codes.shape
    labels = np.full((height, width), -1, np.int32)
    stack = np.empty(height * width, np.int64)
    found_codes = np.empty(height * width, np.int64)
    stats = np.empty((height * width, 5), np.int64)
    levels = np.zeros((64, 256), np.bool_)
    count = 0
    for start in range(height * width):
        v0, u0 = start // width, start % width
        code = codes[v0, u0]
        if code == 0 or labels[v0, u0] >= 0:
            continue
        if count == levels.shape[0]:
            grown = np.zeros((2 * count, 256), np.bool_)
            grown[:count] = levels
            levels = grown
        labels[v0, u0] = count
        found_codes[count] = code
        pixels, u_min, v_min, u_max, v_max = 0, u0, v0, u0, v0
        top = 0
        stack[top] = start
        top += 1
        while top > 0:
            top -= 1
            v, u = stack[top] // width, stack[top] % width
            pixels += 1
            u_min, u_max = min(u_min, u), max(u_max, u)
            v_min, v_max = min(v_min, v), max(v_max, v)
            levels[count, value[v, u]] = True
            for dv, du in ((-1, 0), (1, 0), (0, -1), (0, 1)):
                nv, nu = v + dv, u + du
                if nv < 0 or nv >= height or nu < 0 or nu >= width:
                    continue
                if labels[nv, nu] >= 0 or codes[nv, nu] != code:
                    continue
                if code == wall_code and value[nv, nu] != value[v, u]:
                    continue
                labels[nv, nu] = count
                stack[top] = nv * width + nu
                top += 1
        stats[count] = (pixels, u_min, v_min, u_max, v_max)
        count += 1
    return labels, found_codes[:count].copy(), stats[:count].copy(), levels[:count].copy()
