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

__all__ = ["components", "frame_objects", "pixel_codes"]

MIN_OBSTACLE_SATURATION = 0.55
"""Palette colours have saturation >= 0.8; the walls' brown has 0.36, the floor's grey 0.02."""
WALL_SATURATION = (0.25, 0.47)
WALL_HUE = (18.0, 42.0)  # degrees; the brown is at 30
MIN_VALUE = 24  # darker pixels have too few levels to tell their hue
assert WALL_SATURATION[0] == 0.25 <= MIN_OBSTACLE_SATURATION, "pixel_codes' floor test"


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
    """Each pixel's code (see the module) and brightness (its largest channel).

    A code depends on the pixel's colour alone: a run of one colour (a flat face) is coded once.
    """
    height, width = frame.shape[0], frame.shape[1]
    wall_code = palette_hues.shape[0] + 1
    codes = np.zeros((height, width), np.uint8)
    value = np.empty((height, width), np.uint8)
    last_r, last_g, last_b, last_code = -1, -1, -1, 0
    for v in range(height):
        for u in range(width):
            red, green = np.int64(frame[v, u, 0]), np.int64(frame[v, u, 1])
            blue = np.int64(frame[v, u, 2])
            highest, lowest = max(red, green, blue), min(red, green, blue)
            value[v, u] = highest
            # The floor: saturation (spread / high) under WALL_SATURATION[0] = 0.25, which for
            # integers up to 255 is exactly 4 spread < high: no division, no hue.
            if highest < MIN_VALUE or 4 * (highest - lowest) < highest:
                continue
            if red == last_r and green == last_g and blue == last_b:
                codes[v, u] = last_code
                continue
            r, g, b = float(red), float(green), float(blue)
            high = float(highest)
            spread = high - float(lowest)
            saturation = spread / high
            hue = _hue(r, g, b, high, spread)
            code = 0
            if saturation >= MIN_OBSTACLE_SATURATION:
                best, best_gap = 0, 360.0
                for k in range(palette_hues.shape[0]):
                    gap = abs(hue - palette_hues[k])
                    gap = min(gap, 360.0 - gap)
                    if gap < best_gap:
                        best, best_gap = k, gap
                code = best + 1
            elif (
                WALL_SATURATION[0] <= saturation <= WALL_SATURATION[1]
                and WALL_HUE[0] <= hue <= WALL_HUE[1]
            ):
                code = wall_code
            codes[v, u] = code
            last_r, last_g, last_b, last_code = red, green, blue, code
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


KIND_BOX, KIND_CYLINDER, KIND_WALL = 0, 1, 2
"""Kinds in the rows of :func:`frame_objects`."""


@njit(cache=True, nogil=True)
def frame_objects(
    frames: NDArray[np.uint8], palette_hues: NDArray[np.float64], min_pixels: int, box_levels: int
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
    """The objects of ``n`` frames ``(n, height, width, 3)`` in one call, ready for their geometry.

    What the recogniser's frame-by-frame loop makes of :func:`pixel_codes` and :func:`components`:
    per frame, each obstacle component of at least ``min_pixels`` (a box if it shows at most
    ``box_levels`` brightness levels, else a cylinder), in component order, then the walls: the
    wall components of one brightness merged, in order of first appearance, kept if their pixels
    add up to ``min_pixels``. Returns ``offsets`` (frame ``i``'s rows are ``offsets[i]`` to
    ``offsets[i + 1]``), ``rows`` ``(kind, palette index or -1, pixels, u_min, v_min, u_max,
    v_max)`` and, per row, the mean column of a cylinder's brightest pixels where the frame's
    left or right edge cuts it (else NaN). The scratch arrays are made once for every frame.
    """
    count_frames, height, width = frames.shape[0], frames.shape[1], frames.shape[2]
    wall_code = palette_hues.shape[0] + 1
    labels = np.empty((height, width), np.int32)
    stack_v = np.empty(height * width, np.int64)  # pixels to visit: rows and columns
    stack_u = np.empty(height * width, np.int64)
    seen = np.zeros(256, np.bool_)
    wall_slot = np.full(256, -1, np.int64)  # brightness -> index among this frame's walls
    walls = np.empty((256, 5), np.int64)
    offsets = np.zeros(count_frames + 1, np.int64)
    rows = np.empty((max(16, 4 * count_frames), 7), np.int64)
    bright = np.empty(rows.shape[0], np.float64)
    total = 0
    for f in range(count_frames):
        codes, value = pixel_codes(frames[f], palette_hues)
        labels[:] = -1
        wall_slot[:] = -1
        wall_count = 0
        label = 0
        for start in range(height * width):
            v0, u0 = divmod(start, width)
            code = codes[v0, u0]
            if code == 0 or labels[v0, u0] >= 0:
                continue
            labels[v0, u0] = label
            pixels, u_min, v_min, u_max, v_max = 0, u0, v0, u0, v0
            levels, lowest, highest = 0, 255, 0
            top = 1
            stack_v[0], stack_u[0] = v0, u0
            while top > 0:  # the flood fill of components(), counting brightness levels
                top -= 1
                v, u = stack_v[top], stack_u[top]
                pixels += 1
                u_min, u_max = min(u_min, u), max(u_max, u)
                v_min, v_max = min(v_min, v), max(v_max, v)
                level = value[v, u]
                if not seen[level]:
                    seen[level] = True
                    levels += 1
                    lowest, highest = min(lowest, level), max(highest, level)
                for dv, du in ((-1, 0), (1, 0), (0, -1), (0, 1)):
                    nv, nu = v + dv, u + du
                    if nv < 0 or nv >= height or nu < 0 or nu >= width:
                        continue
                    if labels[nv, nu] >= 0 or codes[nv, nu] != code:
                        continue
                    if code == wall_code and value[nv, nu] != value[v, u]:
                        continue
                    labels[nv, nu] = label
                    stack_v[top], stack_u[top] = nv, nu
                    top += 1
            for level in range(lowest, highest + 1):
                seen[level] = False
            if code == wall_code:  # a wall broken up by an obstacle in front: one brightness
                slot = wall_slot[lowest]
                if slot < 0:
                    slot = wall_slot[lowest] = wall_count
                    wall_count += 1
                    walls[slot, 0], walls[slot, 1], walls[slot, 2] = pixels, u_min, v_min
                    walls[slot, 3], walls[slot, 4] = u_max, v_max
                else:
                    walls[slot, 0] += pixels
                    walls[slot, 1] = min(walls[slot, 1], u_min)
                    walls[slot, 2] = min(walls[slot, 2], v_min)
                    walls[slot, 3] = max(walls[slot, 3], u_max)
                    walls[slot, 4] = max(walls[slot, 4], v_max)
            elif pixels >= min_pixels:
                kind = KIND_BOX if levels <= box_levels else KIND_CYLINDER
                column = np.nan
                if kind == KIND_CYLINDER and (u_min == 0 or u_max == width - 1):
                    column = _bright_column(labels, value, label, highest)
                rows, bright = _grown(rows, bright, total)
                rows[total, 0], rows[total, 1], rows[total, 2] = kind, code - 1, pixels
                rows[total, 3], rows[total, 4] = u_min, v_min
                rows[total, 5], rows[total, 6] = u_max, v_max
                bright[total] = column
                total += 1
            label += 1
        for slot in range(wall_count):
            if walls[slot, 0] >= min_pixels:
                rows, bright = _grown(rows, bright, total)
                rows[total, 0], rows[total, 1] = KIND_WALL, -1
                rows[total, 2:] = walls[slot]  # pixels, u_min, v_min, u_max, v_max
                bright[total] = np.nan
                total += 1
        offsets[f + 1] = total
    return offsets, rows[:total].copy(), bright[:total].copy()


@njit(cache=True, nogil=True)
def _bright_column(
    labels: NDArray[np.int32], value: NDArray[np.uint8], label: int, highest: int
) -> float:
    """Mean column of component ``label``'s pixels of brightness ``highest`` (its brightest).

    The column sum is an exact integer, so the mean is the one ``numpy`` computes.
    """
    total, count = 0, 0
    for v in range(labels.shape[0]):
        for u in range(labels.shape[1]):
            if labels[v, u] == label and value[v, u] == highest:
                total += u
                count += 1
    return total / count


@njit(cache=True, nogil=True)
def _grown(
    rows: NDArray[np.int64], bright: NDArray[np.float64], used: int
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """``rows`` and ``bright`` with room for one more row (doubled when full)."""
    if used < rows.shape[0]:
        return rows, bright
    more_rows = np.empty((2 * rows.shape[0], rows.shape[1]), np.int64)
    more_rows[:used] = rows[:used]
    more_bright = np.empty(2 * rows.shape[0], np.float64)
    more_bright[:used] = bright[:used]
    return more_rows, more_bright
