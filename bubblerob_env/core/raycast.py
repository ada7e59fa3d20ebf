"""An exact analytic laser for scenes made of boxes and cylinders, in numba.

The intersection tests follow MuJoCo's own (``engine_ray.c``: ``ray_box``, ``ray_cylinder`` with
their bounding-sphere tests, in the same arithmetic order), so a reading equals ``mj_multiRay``'s
to the last float32 bit. What makes it fast is the culling in front of them: a geom that is a
vertical prism (box or cylinder whose local z axis is vertical) can only be hit by rays whose
horizontal direction points into its footprint, and the footprint's azimuth interval maps to a
contiguous run of ray indices. Only those rays are tested, widened by one ray on each side so
that rounding can never drop a hit. A tilted scanner is exact too: the rays are 3D and the tests
are MuJoCo's 3D tests; only the culling looks at the horizontal projection, which is monotonic in
the ray angle for any tilt below 90 degrees.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = [
    "GEOM_BOX",
    "GEOM_CYLINDER",
    "cast_cylinders",
    "cast_prisms",
    "ray_box",
    "ray_cylinder",
    "world_rays",
]

GEOM_CYLINDER = 5  # mjtGeom values (mujoco.mjtGeom.mjGEOM_CYLINDER, mjGEOM_BOX)
GEOM_BOX = 6
_MINVAL = 1e-15  # MuJoCo's mjMINVAL
_TWO_PI = 2.0 * math.pi
# Footprint tests that are this close to the boundary count as "inside" (test every ray).
_INSIDE_TOLERANCE = 1e-9
# Relative margin of a geom's distance bound (_gap): hit distances are rounded by at most ~2e-8
# relative (a near-tangent ray's square root in _ray_quad), the bound and |ray| by ~1e-15.
_GAP_MARGIN = 1e-6


@njit(cache=True, nogil=True)
def _ray_quad(a: float, b: float, c: float) -> float:  # pragma: no cover - numba
    det = b * b - a * c
    if det < _MINVAL:
        return -1.0
    det = math.sqrt(det)
    x0 = (-b - det) / a
    x1 = (-b + det) / a
    if x0 >= 0:
        return x0
    if x1 >= 0:
        return x1
    return -1.0


@njit(cache=True, nogil=True)
def _ray_sphere(
    pos: NDArray[np.float64], dist_sqr: float, pnt: NDArray[np.float64], vec: NDArray[np.float64]
) -> float:  # pragma: no cover - numba
    dif0, dif1, dif2 = pnt[0] - pos[0], pnt[1] - pos[1], pnt[2] - pos[2]
    a = vec[0] * vec[0] + vec[1] * vec[1] + vec[2] * vec[2]
    b = vec[0] * dif0 + vec[1] * dif1 + vec[2] * dif2
    c = dif0 * dif0 + dif1 * dif1 + dif2 * dif2 - dist_sqr
    return _ray_quad(a, b, c)


@njit(cache=True, nogil=True)
def _ray_map(
    pos: NDArray[np.float64],
    mat: NDArray[np.float64],
    pnt: NDArray[np.float64],
    vec: NDArray[np.float64],
) -> tuple[float, float, float, float, float, float]:  # pragma: no cover - numba
    """The ray's point and direction in the geom's frame (MuJoCo's ``ray_map``)."""
    dif0, dif1, dif2 = pnt[0] - pos[0], pnt[1] - pos[1], pnt[2] - pos[2]
    return (
        mat[0] * dif0 + mat[3] * dif1 + mat[6] * dif2,
        mat[1] * dif0 + mat[4] * dif1 + mat[7] * dif2,
        mat[2] * dif0 + mat[5] * dif1 + mat[8] * dif2,
        mat[0] * vec[0] + mat[3] * vec[1] + mat[6] * vec[2],
        mat[1] * vec[0] + mat[4] * vec[1] + mat[7] * vec[2],
        mat[2] * vec[0] + mat[5] * vec[1] + mat[8] * vec[2],
    )


@njit(cache=True, nogil=True)
def _box_face(
    side: float,
    size_i: float,
    p_i: float,
    v_i: float,
    p_j: float,
    v_j: float,
    size_j: float,
    p_k: float,
    v_k: float,
    size_k: float,
    x: float,
) -> float:  # pragma: no cover - numba
    # One face of MuJoCo's ray_box loop: the nearer of x and this face's hit.
    sol = (side * size_i - p_i) / v_i
    if sol >= 0:
        p0 = p_j + sol * v_j
        p1 = p_k + sol * v_k
        if abs(p0) <= size_j and abs(p1) <= size_k and (x < 0 or sol < x):
            return sol
    return x


@njit(cache=True, nogil=True)
def ray_box(
    pos: NDArray[np.float64],
    mat: NDArray[np.float64],
    size: NDArray[np.float64],
    pnt: NDArray[np.float64],
    vec: NDArray[np.float64],
) -> float:  # pragma: no cover
    """Distance along ``vec`` from ``pnt`` to the box, or -1 (MuJoCo's ``ray_box``)."""
    s0, s1, s2 = size[0], size[1], size[2]
    if _ray_sphere(pos, s0 * s0 + s1 * s1 + s2 * s2, pnt, vec) < 0:
        return -1.0
    p0, p1, p2, v0, v1, v2 = _ray_map(pos, mat, pnt, vec)
    return _box_faces(p0, p1, p2, v0, v1, v2, s0, s1, s2)


@njit(cache=True, nogil=True)
def ray_cylinder(
    pos: NDArray[np.float64],
    mat: NDArray[np.float64],
    size: NDArray[np.float64],
    pnt: NDArray[np.float64],
    vec: NDArray[np.float64],
) -> float:  # pragma: no cover
    """Distance along ``vec`` from ``pnt`` to the cylinder, or -1 (MuJoCo's ``ray_cylinder``)."""
    radius, half_height = size[0], size[1]
    if _ray_sphere(pos, radius * radius + half_height * half_height, pnt, vec) < 0:
        return -1.0
    p0, p1, p2, v0, v1, v2 = _ray_map(pos, mat, pnt, vec)
    return _cylinder_sides(p0, p1, p2, v0, v1, v2, radius, half_height)


@njit(cache=True, nogil=True)
def world_rays(
    local_dirs: NDArray[np.float64], xmat: NDArray[np.float64], out: NDArray[np.float64]
) -> None:  # pragma: no cover - numba
    """``out = local_dirs @ xmat.reshape(3, 3).T``: each ray's direction in the world frame."""
    for r in range(local_dirs.shape[0]):
        l0, l1, l2 = local_dirs[r, 0], local_dirs[r, 1], local_dirs[r, 2]
        for j in range(3):
            out[r, j] = l0 * xmat[3 * j] + l1 * xmat[3 * j + 1] + l2 * xmat[3 * j + 2]


@njit(cache=True, nogil=True)
def _footprint_interval(
    gtype: int,
    pos: NDArray[np.float64],
    mat: NDArray[np.float64],
    size: NDArray[np.float64],
    px: float,
    py: float,
) -> tuple[bool, float, float, float, float]:  # pragma: no cover - numba
    """``(everywhere, lo_x, lo_y, hi_x, hi_y)``: directions from ``(px, py)`` bounding a footprint.

    Every horizontal direction into the footprint is counter-clockwise of ``lo`` and clockwise
    of ``hi``, which are less than pi apart (vectors of any length). ``everywhere``: the point
    is in (or on) the footprint. No trigonometry: the cylinder's tangents are its centre's direction
    turned by +-asin(radius / distance), written with the sine and cosine of that angle; the
    box's are its outermost corners (of the centre's direction and the four corners, within
    a half-plane, the most clockwise and counter-clockwise by cross products).
    """
    dx, dy = pos[0] - px, pos[1] - py
    if gtype == GEOM_CYLINDER:
        radius = size[0]
        distance_sqr = dx * dx + dy * dy
        if math.sqrt(distance_sqr) <= radius * (1.0 + _INSIDE_TOLERANCE) + _INSIDE_TOLERANCE:
            return True, 0.0, 0.0, 0.0, 0.0
        along = math.sqrt(distance_sqr - radius * radius)  # distance * cos, radius = distance * sin
        return (
            False,
            dx * along + dy * radius,
            dy * along - dx * radius,
            dx * along - dy * radius,
            dy * along + dx * radius,
        )
    # Box: the point in the box's frame, then its four corners.
    ux, uy, vx, vy = mat[0], mat[3], mat[1], mat[4]
    lx, ly = -(dx * ux + dy * uy), -(dx * vx + dy * vy)
    tol = _INSIDE_TOLERANCE
    if abs(lx) <= size[0] * (1 + tol) + tol and abs(ly) <= size[1] * (1 + tol) + tol:
        return True, 0.0, 0.0, 0.0, 0.0
    lo_x, lo_y, hi_x, hi_y = dx, dy, dx, dy
    for corner in range(4):
        sx = size[0] if corner & 1 else -size[0]
        sy = size[1] if corner & 2 else -size[1]
        cx, cy = dx + sx * ux + sy * vx, dy + sx * uy + sy * vy
        if lo_x * cy - lo_y * cx < 0.0:
            lo_x, lo_y = cx, cy
        if hi_x * cy - hi_y * cx > 0.0:
            hi_x, hi_y = cx, cy
    return False, lo_x, lo_y, hi_x, hi_y


@njit(cache=True, nogil=True)
def _local_angle(
    x: float, y: float, inverse: tuple[float, float, float, float]
) -> float:  # pragma: no cover - numba
    """The ray angle (laser frame) whose horizontal projection points along world ``(x, y)``."""
    return math.atan2(inverse[2] * x + inverse[3] * y, inverse[0] * x + inverse[1] * y)


@njit(cache=True, nogil=True)
def _horizontal_inverse(
    xmat: NDArray[np.float64],
) -> tuple[bool, tuple[float, float, float, float]]:  # pragma: no cover - numba
    """Whether rays can be culled by azimuth, and the inverse of the laser's horizontal map.

    The map takes a ray angle's (cos, sin) in the laser frame to its world direction's
    horizontal part; culling needs it invertible (a laser tilted less than 90 degrees) and
    keeping orientation (so that a positive multiple of a direction maps to the same angle).
    """
    m00, m01, m10, m11 = xmat[0], xmat[1], xmat[3], xmat[4]
    det = m00 * m11 - m01 * m10
    if det > 1e-6:
        return True, (m11 / det, -m01 / det, -m10 / det, m00 / det)
    return False, (0.0, 0.0, 0.0, 0.0)


@njit(cache=True, nogil=True)
def _candidate_rays(
    cull: bool,
    inverse: tuple[float, float, float, float],
    gtype: int,
    pos: NDArray[np.float64],
    mat: NDArray[np.float64],
    size: NDArray[np.float64],
    pnt: NDArray[np.float64],
    angle_min: float,
    increment: float,
    full_circle: bool,
    nray: int,
) -> tuple[int, int, int]:  # pragma: no cover - numba
    """``(first, count, second)``: the rays that may hit a prism's footprint.

    Windows of indices ``[first, first + count)``, taken modulo ``nray`` for a full circle and
    clamped to the fan otherwise (where the interval may also lie one turn lower: that is the
    second window, from ``second``).
    """
    first, count, second = 0, nray, nray
    if cull:
        everywhere, lo_x, lo_y, hi_x, hi_y = _footprint_interval(
            gtype, pos, mat, size, pnt[0], pnt[1]
        )
        if not everywhere:
            a_lo = _local_angle(lo_x, lo_y, inverse)
            span = _local_angle(hi_x, hi_y, inverse) - a_lo
            if span < 0:
                span += _TWO_PI
            offset = (a_lo - angle_min) % _TWO_PI
            first = int(math.floor(offset / increment)) - 1
            count = int(math.ceil(span / increment)) + 3
            if full_circle:
                count = min(count, nray)  # a whole turn: every ray once
            else:
                second = int(math.floor((offset - _TWO_PI) / increment)) - 1
    return first, count, second


@njit(cache=True, nogil=True)
def cast_prisms(
    pnt: NDArray[np.float64],
    xmat: NDArray[np.float64],
    dirs: NDArray[np.float64],
    angle_min: float,
    increment: float,
    full_circle: bool,
    cutoff: float,
    geoms: NDArray[np.int32],
    geom_type: NDArray[np.int32],
    geom_xpos: NDArray[np.float64],
    geom_xmat: NDArray[np.float64],
    geom_size: NDArray[np.float64],
    geom_rbound: NDArray[np.float64],
    dist: NDArray[np.float64],
) -> None:  # pragma: no cover - numba
    """Cast every ray of one scan against ``geoms`` (boxes and cylinders); -1 where none is hit.

    ``pnt`` and ``xmat`` are the laser site's world position and rotation, ``dirs`` the rays'
    world directions (:func:`world_rays`), ray ``i`` at ``angle_min + i * increment`` in the
    laser frame. Geoms farther than ``cutoff`` plus their bounding radius are skipped, as
    ``mj_multiRay`` skips them.
    """
    nray = dirs.shape[0]
    dist[:] = -1.0
    cull, inverse = _horizontal_inverse(xmat)
    order, nearest = _nearest_first(
        pnt, cutoff, geoms, geom_type, geom_xpos, geom_xmat, geom_size, geom_rbound
    )
    for gi in range(order.shape[0]):
        g = order[gi]
        pos, mat, size = geom_xpos[g], geom_xmat[g], geom_size[g]
        first, count, second = _candidate_rays(
            cull,
            inverse,
            geom_type[g],
            pos,
            mat,
            size,
            pnt,
            angle_min,
            increment,
            full_circle,
            nray,
        )
        is_box = geom_type[g] == GEOM_BOX
        near = nearest[gi]
        if full_circle or not cull:
            _cast_window(first, count, nray, True, is_box, pos, mat, size, pnt, dirs, dist, near)
        else:
            _cast_window(first, count, nray, False, is_box, pos, mat, size, pnt, dirs, dist, near)
            _cast_window(second, count, nray, False, is_box, pos, mat, size, pnt, dirs, dist, near)


@njit(cache=True, nogil=True)
def _nearest_first(
    pnt: NDArray[np.float64],
    cutoff: float,
    geoms: NDArray[np.int32],
    geom_type: NDArray[np.int32],
    geom_xpos: NDArray[np.float64],
    geom_xmat: NDArray[np.float64],
    geom_size: NDArray[np.float64],
    geom_rbound: NDArray[np.float64],
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:  # pragma: no cover - numba
    """The geoms within ``cutoff`` of their bounding spheres, nearest first, and their bounds.

    A geom's bound is below the distance along any ray (of unit length) from ``pnt`` to a point
    of the geom: a ray that already hit something nearer than that keeps its reading, whatever
    the geom's test would give, so :func:`_cast_window` skips the test. The order and the skips
    change no reading: each is the smallest hit over the geoms, as before.
    """
    order = np.empty(geoms.shape[0], dtype=np.int64)
    nearest = np.empty(geoms.shape[0], dtype=np.float64)
    kept = 0
    for gi in range(geoms.shape[0]):
        g = geoms[gi]
        pos = geom_xpos[g]
        d0, d1, d2 = pos[0] - pnt[0], pos[1] - pnt[1], pos[2] - pnt[2]
        if math.sqrt(d0 * d0 + d1 * d1 + d2 * d2) > cutoff + geom_rbound[g]:
            continue
        bound = _gap(geom_type[g] == GEOM_BOX, pos, geom_xmat[g], geom_size[g], pnt)
        at = kept  # insertion sort: a few dozen geoms
        while at > 0 and nearest[at - 1] > bound:
            order[at], nearest[at] = order[at - 1], nearest[at - 1]
            at -= 1
        order[at], nearest[at] = g, bound
        kept += 1
    return order[:kept], nearest[:kept]


@njit(cache=True, nogil=True)
def _gap(
    is_box: bool,
    pos: NDArray[np.float64],
    mat: NDArray[np.float64],
    size: NDArray[np.float64],
    pnt: NDArray[np.float64],
) -> float:  # pragma: no cover - numba
    """A lower bound of the distance from ``pnt`` to the box or cylinder (0 from inside).

    The distance in the geom's frame, less a margin (:data:`_GAP_MARGIN`) for rounding.
    """
    dif0, dif1, dif2 = pnt[0] - pos[0], pnt[1] - pos[1], pnt[2] - pos[2]
    p0 = mat[0] * dif0 + mat[3] * dif1 + mat[6] * dif2
    p1 = mat[1] * dif0 + mat[4] * dif1 + mat[7] * dif2
    p2 = mat[2] * dif0 + mat[5] * dif1 + mat[8] * dif2
    if is_box:
        e0 = max(0.0, abs(p0) - size[0])
        e1 = max(0.0, abs(p1) - size[1])
        e2 = max(0.0, abs(p2) - size[2])
    else:
        e0 = max(0.0, math.sqrt(p0 * p0 + p1 * p1) - size[0])
        e1 = max(0.0, abs(p2) - size[1])
        e2 = 0.0
    return math.sqrt(e0 * e0 + e1 * e1 + e2 * e2) * (1.0 - _GAP_MARGIN)


@njit(cache=True, nogil=True)
def _cast_window(
    first: int,
    count: int,
    nray: int,
    wrap: bool,
    is_box: bool,
    pos: NDArray[np.float64],
    mat: NDArray[np.float64],
    size: NDArray[np.float64],
    pnt: NDArray[np.float64],
    dirs: NDArray[np.float64],
    dist: NDArray[np.float64],
    nearest: float,
) -> None:  # pragma: no cover - numba
    """Test rays ``first .. first + count - 1`` (modulo ``nray``, or clamped to the fan).

    Rays that already hit something nearer than ``nearest`` (the geom's :func:`_gap`) are not
    tested: no hit of this geom could lower their reading.

    MuJoCo's tests, with what does not depend on the ray computed once: the ray's origin in
    the geom's frame, and the bounding-sphere test's ``c``. When the origin is well inside the
    bounding sphere that test passes for every ray (``c < 0`` makes ``b*b - a*c`` at least
    ``-a*c``), so it is skipped; the numbers that decide a hit are computed as MuJoCo does.
    """
    if wrap:
        start, stop = first, first + count
    else:
        start, stop = max(0, first), min(nray, first + count)
    dif0, dif1, dif2 = pnt[0] - pos[0], pnt[1] - pos[1], pnt[2] - pos[2]
    p0 = mat[0] * dif0 + mat[3] * dif1 + mat[6] * dif2
    p1 = mat[1] * dif0 + mat[4] * dif1 + mat[7] * dif2
    p2 = mat[2] * dif0 + mat[5] * dif1 + mat[8] * dif2
    s0, s1, s2 = size[0], size[1], size[2]
    ssz = s0 * s0 + s1 * s1 + s2 * s2 if is_box else s0 * s0 + s1 * s1
    c = dif0 * dif0 + dif1 * dif1 + dif2 * dif2 - ssz
    sphere_test = not c < -1e-12
    # An unrotated geom (the walls): the ray's direction in its frame is its world direction.
    # MuJoCo's products give the same numbers (1 * w plus zeros), but for the sign of a zero,
    # which no test below can see (zeros fail |v| > mjMINVAL; p + sol * 0 is p).
    identity = (
        mat[0] == 1.0 and mat[4] == 1.0 and mat[8] == 1.0
        and mat[1] == 0.0 and mat[2] == 0.0 and mat[3] == 0.0
        and mat[5] == 0.0 and mat[6] == 0.0 and mat[7] == 0.0
    )  # fmt: skip
    for k in range(start, stop):
        r = k
        if r < 0:
            r += nray
        elif r >= nray:
            r -= nray
        reading = dist[r]
        if 0.0 <= reading < nearest:
            continue
        w0, w1, w2 = dirs[r, 0], dirs[r, 1], dirs[r, 2]
        if sphere_test:
            a = w0 * w0 + w1 * w1 + w2 * w2
            b = w0 * dif0 + w1 * dif1 + w2 * dif2
            if _ray_quad(a, b, c) < 0:
                continue
        if identity:
            v0, v1, v2 = w0, w1, w2
        else:
            v0 = mat[0] * w0 + mat[3] * w1 + mat[6] * w2
            v1 = mat[1] * w0 + mat[4] * w1 + mat[7] * w2
            v2 = mat[2] * w0 + mat[5] * w1 + mat[8] * w2
        if is_box:
            x = _box_faces(p0, p1, p2, v0, v1, v2, s0, s1, s2)
        else:
            x = _cylinder_sides(p0, p1, p2, v0, v1, v2, s0, s1)
        if x >= 0 and (dist[r] < 0 or x < dist[r]):
            dist[r] = x


@njit(cache=True, nogil=True)
def _box_faces(
    p0: float,
    p1: float,
    p2: float,
    v0: float,
    v1: float,
    v2: float,
    s0: float,
    s1: float,
    s2: float,
) -> float:  # pragma: no cover - numba
    x = -1.0
    if abs(v0) > _MINVAL:
        x = _box_face(-1.0, s0, p0, v0, p1, v1, s1, p2, v2, s2, x)
        x = _box_face(1.0, s0, p0, v0, p1, v1, s1, p2, v2, s2, x)
    if abs(v1) > _MINVAL:
        x = _box_face(-1.0, s1, p1, v1, p0, v0, s0, p2, v2, s2, x)
        x = _box_face(1.0, s1, p1, v1, p0, v0, s0, p2, v2, s2, x)
    if abs(v2) > _MINVAL:
        x = _box_face(-1.0, s2, p2, v2, p0, v0, s0, p1, v1, s1, x)
        x = _box_face(1.0, s2, p2, v2, p0, v0, s0, p1, v1, s1, x)
    return x


@njit(cache=True, nogil=True)
def _cylinder_sides(
    p0: float,
    p1: float,
    p2: float,
    v0: float,
    v1: float,
    v2: float,
    radius: float,
    half_height: float,
) -> float:  # pragma: no cover - numba
    x = -1.0
    if abs(v2) > _MINVAL:
        for side in (-1.0, 1.0):
            sol = (side * half_height - p2) / v2
            if sol >= 0:
                q0 = p0 + sol * v0
                q1 = p1 + sol * v1
                if q0 * q0 + q1 * q1 <= radius * radius and (x < 0 or sol < x):
                    x = sol
    a = v0 * v0 + v1 * v1
    b = v0 * p0 + v1 * p1
    c = p0 * p0 + p1 * p1 - radius * radius
    sol = _ray_quad(a, b, c)
    if sol >= 0 and abs(p2 + sol * v2) <= half_height and (x < 0 or sol < x):
        x = sol
    return x


@njit(cache=True, nogil=True)
def cast_cylinders(
    pnt: NDArray[np.float64],
    xmat: NDArray[np.float64],
    dirs: NDArray[np.float64],
    angle_min: float,
    increment: float,
    full_circle: bool,
    cutoff: float,
    geoms: NDArray[np.int32],
    geom_xpos: NDArray[np.float64],
    geom_xmat: NDArray[np.float64],
    geom_size: NDArray[np.float64],
    geom_rbound: NDArray[np.float64],
    dist: NDArray[np.float64],
) -> None:  # pragma: no cover - numba
    """Lower ``dist`` (-1: no hit yet) where a ray hits one of ``geoms``, cylinders in any pose.

    For geoms that move and tilt (other robots' laser windows), with the arguments of
    :func:`cast_prisms`. The culling is conservative: a ray that meets a geom's bounding sphere
    crosses, seen from above, the disk of the sphere's radius about its centre, so only the rays
    pointing into that disk are tested, each with MuJoCo's own :func:`ray_cylinder` (bounding-
    sphere test first): every reading is exactly ``mj_multiRay``'s. Negative ids are skipped.
    """
    nray = dirs.shape[0]
    cull, inverse = _horizontal_inverse(xmat)
    bound = np.zeros(3)
    for gi in range(geoms.shape[0]):
        g = geoms[gi]
        if g < 0:
            continue
        pos, mat, size = geom_xpos[g], geom_xmat[g], geom_size[g]
        d0, d1, d2 = pos[0] - pnt[0], pos[1] - pnt[1], pos[2] - pnt[2]
        if math.sqrt(d0 * d0 + d1 * d1 + d2 * d2) > cutoff + geom_rbound[g]:
            continue
        bound[0] = geom_rbound[g]  # the bounding sphere's disk, as an upright cylinder's
        first, count, second = _candidate_rays(
            cull, inverse, GEOM_CYLINDER, pos, mat, bound, pnt, angle_min, increment,
            full_circle, nray,
        )  # fmt: skip
        wrap = full_circle or not cull
        for start in (first, second):
            lo, hi = (start, start + count) if wrap else (max(0, start), min(nray, start + count))
            for k in range(lo, hi):
                r = k % nray
                x = ray_cylinder(pos, mat, size, pnt, dirs[r])
                if x >= 0 and (dist[r] < 0 or x < dist[r]):
                    dist[r] = x
            if wrap:
                break
