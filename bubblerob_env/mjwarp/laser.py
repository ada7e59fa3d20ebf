# mypy: ignore-errors
# (Warp kernels: their builtins carry no annotations mypy can check, as kernels.py.)
"""The laser on the device, culled as the CPU kernel culls it.

``mujoco_warp.rays`` tests every ray against every geom of the model, a thread block per ray: on
an H100 it took 90% of a step at 65,536 worlds (physics alone ran 9x faster; docs/BENCHMARKS.md,
issue #41). The laser only sees the obstacle group (walls, obstacles), and those geoms are
vertical prisms: a prism can only be hit by the rays whose horizontal direction points into its
footprint, and those form one run of ray indices (:mod:`bubblerob_env.core.raycast`, the CPU
kernel, explains why that holds for a tilted scanner too). So one thread per world and obstacle
geom walks that run, widened by one ray on each side so that float32 rounding of the footprint's
angles can never drop a hit, and tests it with MuJoCo Warp's own ``ray_box`` / ``ray_cylinder``
on the same ray origins and directions that ``rays`` is given. Each ray keeps its nearest hit
through an atomic minimum, which does not depend on the order the threads run in, so the scan is
deterministic; a ray that hits nothing reads ``+inf`` (``laser_readings``: ``range_max``).
A geom that is not a vertical box or cylinder, or a laser tilted 90 degrees or more, is tested by
every ray.
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

# MuJoCo Warp's own intersection tests (private module, pinned by the [warp] extra's <4.1):
# the same arithmetic as mujoco_warp.rays, so the readings agree with it.
from mujoco_warp._src.ray import ray_box, ray_cylinder
from numpy.typing import NDArray

__all__ = ["GEOM_BOX", "GEOM_CYLINDER", "culled_laser", "obstacle_geoms"]

GEOM_CYLINDER = wp.constant(5)  # mjtGeom values
GEOM_BOX = wp.constant(6)
_TWO_PI = wp.constant(2.0 * math.pi)
_PI = wp.constant(math.pi)
# A footprint test this close to the boundary counts as "inside" (test every ray); float32.
_INSIDE_TOLERANCE = wp.constant(1e-5)
_VERTICAL = wp.constant(1.0 - 1e-5)  # |z axis . world z| above this: a vertical prism


@wp.func
def _wrapped(offset: float) -> float:
    """``offset`` moved into [-pi, pi] by one turn (the corners' offsets from the centre)."""
    if offset > _PI:
        return offset - _TWO_PI
    if offset < -_PI:
        return offset + _TWO_PI
    return offset


@wp.func
def _footprint(
    gtype: int, pos: wp.vec3, mat: wp.mat33, size: wp.vec3, px: float, py: float
) -> wp.vec3:
    """``(inside, lo, hi)``: the world azimuths from ``(px, py)`` that the footprint spans.

    ``inside`` is 1 where the point is in (or on) the footprint: then every ray is a candidate.
    """
    dx = pos[0] - px
    dy = pos[1] - py
    centre = wp.atan2(dy, dx)
    if gtype == GEOM_CYLINDER:
        distance = wp.sqrt(dx * dx + dy * dy)
        if distance <= size[0] * (1.0 + _INSIDE_TOLERANCE) + _INSIDE_TOLERANCE:
            return wp.vec3(1.0, 0.0, 0.0)
        half = wp.asin(size[0] / distance)
        return wp.vec3(0.0, centre - half, centre + half)
    ux = mat[0, 0]
    uy = mat[1, 0]
    vx = mat[0, 1]
    vy = mat[1, 1]
    lx = -(dx * ux + dy * uy)
    ly = -(dx * vx + dy * vy)
    tol = _INSIDE_TOLERANCE
    if wp.abs(lx) <= size[0] * (1.0 + tol) + tol and wp.abs(ly) <= size[1] * (1.0 + tol) + tol:
        return wp.vec3(1.0, 0.0, 0.0)
    lo = 0.0
    hi = 0.0
    for corner in range(4):
        sx = size[0]
        if corner % 2 == 0:
            sx = -size[0]
        sy = size[1]
        if corner < 2:
            sy = -size[1]
        cx = dx + sx * ux + sy * vx
        cy = dy + sx * uy + sy * vy
        offset = _wrapped(wp.atan2(cy, cx) - centre)
        lo = wp.min(lo, offset)
        hi = wp.max(hi, offset)
    return wp.vec3(0.0, centre + lo, centre + hi)


@wp.func
def _local_angle(azimuth: float, inverse: wp.vec4) -> float:
    """The ray angle (laser frame) whose horizontal projection points at world ``azimuth``."""
    cx = wp.cos(azimuth)
    cy = wp.sin(azimuth)
    return wp.atan2(inverse[2] * cx + inverse[3] * cy, inverse[0] * cx + inverse[1] * cy)


@wp.func
def _hit(
    gtype: int, pos: wp.vec3, mat: wp.mat33, size: wp.vec3, pnt: wp.vec3, vec: wp.vec3
) -> float:
    if gtype == GEOM_BOX:
        dist, _all, _normal = ray_box(pos, mat, size, pnt, vec)
        return dist
    if gtype == GEOM_CYLINDER:
        dist, _normal = ray_cylinder(pos, mat, size, pnt, vec)
        return dist
    return -1.0


@wp.kernel
def culled_laser(
    geoms: wp.array[int],
    geom_type: wp.array[int],
    geom_size: wp.array2d[wp.vec3],
    geom_xpos: wp.array2d[wp.vec3],
    geom_xmat: wp.array2d[wp.mat33],
    site_xmat: wp.array2d[wp.mat33],
    site: int,
    pnt: wp.array2d[wp.vec3],
    vec: wp.array2d[wp.vec3],
    angle_min: float,
    increment: float,
    full_circle: int,
    dist: wp.array2d[float],
) -> None:
    """World ``w``'s rays against its obstacle geom ``geoms[k]``; ``dist`` starts at +inf."""
    w, k = wp.tid()
    g = geoms[k]
    gtype = geom_type[g]
    pos = geom_xpos[w, g]
    mat = geom_xmat[w, g]
    size = geom_size[w % geom_size.shape[0], g]
    xmat = site_xmat[w, site]
    origin = pnt[w, 0]
    nray = dist.shape[1]
    first = 0
    count = nray
    second = nray
    windows = 1
    culled = False
    det = xmat[0, 0] * xmat[1, 1] - xmat[0, 1] * xmat[1, 0]
    prism = gtype == GEOM_BOX or gtype == GEOM_CYLINDER  # noqa: SIM109 (Warp: no tuples)
    if det > 1e-6 and prism and wp.abs(mat[2, 2]) > _VERTICAL:
        span = _footprint(gtype, pos, mat, size, origin[0], origin[1])
        if span[0] == 0.0:
            culled = True
            inverse = wp.vec4(
                xmat[1, 1] / det, -xmat[0, 1] / det, -xmat[1, 0] / det, xmat[0, 0] / det
            )
            a_lo = _local_angle(span[1], inverse)
            width = _local_angle(span[2], inverse) - a_lo
            if width < 0.0:
                width = width + _TWO_PI
            offset = a_lo - angle_min
            offset = offset - _TWO_PI * wp.floor(offset / _TWO_PI)
            first = int(wp.floor(offset / increment)) - 1
            count = int(wp.ceil(width / increment)) + 3
            if full_circle != 0:
                count = wp.min(count, nray)
            else:
                second = int(wp.floor((offset - _TWO_PI) / increment)) - 1
                windows = 2
    for window in range(windows):
        start = first
        if window == 1:
            start = second
        for i in range(count):
            r = start + i
            if full_circle != 0 or not culled:
                r = ((r % nray) + nray) % nray
            elif r < 0 or r >= nray:
                continue
            d = _hit(gtype, pos, mat, size, origin, vec[w, r])
            if d >= 0.0:
                wp.atomic_min(dist, w, r, d)


def obstacle_geoms(is_obstacle: NDArray[np.bool_]) -> NDArray[np.int32]:
    """The indices of the geoms the laser sees (``is_obstacle``: one flag per geom)."""
    return np.flatnonzero(is_obstacle).astype(np.int32)
