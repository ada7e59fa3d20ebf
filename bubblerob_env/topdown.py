"""A top-down view drawn with NumPy from the model's geometry: no OpenGL, a millisecond a frame.

MuJoCo's renderer on Mesa's CPU backend (llvmpipe, the headless default) takes about 48 ms for a
360x360 overhead frame, which made a video of one episode cost most of ``bubblerob demo``. The
view from straight above needs no 3D renderer: every geom's silhouette is known exactly.

A pixel shows a geom when the vertical line through the pixel's centre meets the geom: exact for
spheres, capsules, cylinders, boxes and ellipsoids in any orientation; meshes and other types are
drawn as their bounding box. Planes are the floor (a grid every metre); geoms of MuJoCo's hidden
groups (3 and up), fully transparent ones and ones below the floor (the env's parked obstacle
slots) are not drawn. Higher geoms cover lower ones.

Geoms of bodies that never move by themselves (the world's and mocap bodies': walls, obstacles)
are drawn once into a background, redrawn only when one of them moved or changed (a reset).
Each frame copies it, then draws the laser rays (translucent) and hits, the moving bodies (the
robot) and the robot's heading.
"""

from __future__ import annotations

import math
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from bubblerob_env import names
from bubblerob_env.sensors import LaserSpec

__all__ = ["TopDownRenderer"]

_FLOOR_RGB = np.array([232, 232, 226], dtype=np.uint8)
_GRID_RGB = np.array([205, 205, 198], dtype=np.uint8)
_RAY_RGB = np.array([255, 140, 0], dtype=np.float64)
_RAY_ALPHA = 0.4  # translucent: the floor and obstacles show through the fan of rays
_HIT_RGB = np.array([230, 25, 25], dtype=np.uint8)
_HEADING_RGB = np.array([255, 255, 255], dtype=np.uint8)
_MAX_DRAWN_RAYS = 90  # more lines than this hide the robot under the fan
_VISIBLE_GROUPS = 3  # MuJoCo's viewers show geom groups 0, 1 and 2 by default
_EPS = 1e-9
# An axis tilted less than this (radians) from level or upright is drawn as if exactly so (a
# rectangle or a disc): the silhouette then differs by under 1e-3 of the geom's size, below a pixel.
_ALIGNED = 1e-3

_SPHERE = int(mujoco.mjtGeom.mjGEOM_SPHERE)
_CAPSULE = int(mujoco.mjtGeom.mjGEOM_CAPSULE)
_ELLIPSOID = int(mujoco.mjtGeom.mjGEOM_ELLIPSOID)
_CYLINDER = int(mujoco.mjtGeom.mjGEOM_CYLINDER)
_BOX = int(mujoco.mjtGeom.mjGEOM_BOX)
_PLANE = int(mujoco.mjtGeom.mjGEOM_PLANE)

Image = NDArray[np.uint8]
Floats = NDArray[np.float64]


def _slab(a: Floats, b: float, half: float) -> tuple[Floats, Floats]:
    """The s interval where ``|a + s b| <= half`` (empty: lo > hi), per pixel."""
    if abs(b) < _EPS:
        inside = np.abs(a) <= half
        return np.where(inside, -np.inf, np.inf), np.where(inside, np.inf, -np.inf)
    first, second = (-half - a) / b, (half - a) / b
    return np.minimum(first, second), np.maximum(first, second)


def _quadratic(a: list[Floats], b: Floats, scale: Floats) -> tuple[Floats, Floats]:
    """The s interval where ``sum(((a_i + s b_i) * scale_i)^2) <= 1`` (empty: lo > hi)."""
    qa = float(np.sum((b * scale) ** 2))
    qb = 2.0 * sum(a[i] * (b[i] * scale[i] ** 2) for i in range(len(a)))
    qc = sum((a[i] * scale[i]) ** 2 for i in range(len(a))) - 1.0
    if qa < _EPS:  # the line runs along the axis of a round shape: inside everywhere or nowhere
        inside = qc <= 0.0
        return np.where(inside, -np.inf, np.inf), np.where(inside, np.inf, -np.inf)
    root = np.sqrt(np.maximum(qb * qb - 4.0 * qa * qc, 0.0))
    empty = qb * qb - 4.0 * qa * qc < 0.0
    lo, hi = (-qb - root) / (2.0 * qa), (-qb + root) / (2.0 * qa)
    return np.where(empty, np.inf, lo), np.where(empty, -np.inf, hi)


def _silhouette(kind: int, size: Floats, rot: Floats, dx: Floats, dy: Floats) -> NDArray[np.bool_]:
    """Which pixels (offsets ``dx``, ``dy`` from the geom's centre) a vertical line meets it at.

    Along the line ``(x, y, s)`` the geom's local coordinates are ``a + s * b``.
    """
    if kind == _SPHERE:
        hit: NDArray[np.bool_] = dx * dx + dy * dy <= size[0] ** 2
        return hit
    a = [rot[0, i] * dx + rot[1, i] * dy for i in range(3)]
    b = rot[2]
    if kind == _ELLIPSOID:
        lo, hi = _quadratic(a, b, 1.0 / np.maximum(size, _EPS))
        return lo <= hi
    if kind in (_CYLINDER, _CAPSULE):
        radius, half = float(size[0]), float(size[1])
        if abs(b[2]) < _ALIGNED:  # axis level (a wheel): a rectangle, the common case made cheap
            hit = (np.abs(a[2]) <= half) & (np.abs(a[0] * b[1] - a[1] * b[0]) <= radius)
            if kind == _CYLINDER:
                return hit
        else:
            hit = _tilted_cylinder(a, b, radius, half)
        if kind == _CAPSULE:  # and the two half-spheres at the ends of the axis
            for end in (-half, half):
                ex, ey = dx - end * rot[0, 2], dy - end * rot[1, 2]
                hit = hit | (ex * ex + ey * ey <= radius * radius)
        return hit
    if math.hypot(b[0], b[1]) < _ALIGNED:  # a box standing upright (walls, obstacles): a rectangle
        hit = (np.abs(a[0]) <= size[0]) & (np.abs(a[1]) <= size[1])
        return hit
    lo, hi = np.full(np.shape(a[0]), -np.inf), np.full(np.shape(a[0]), np.inf)
    for axis in range(3):  # a box: three slabs
        slab_lo, slab_hi = _slab(a[axis], float(b[axis]), float(size[axis]))
        lo, hi = np.maximum(lo, slab_lo), np.minimum(hi, slab_hi)
    hit = lo <= hi
    return hit


def _tilted_cylinder(a: list[Floats], b: Floats, radius: float, half: float) -> NDArray[np.bool_]:
    """Where the vertical line meets a cylinder whose axis is not level."""
    if math.hypot(b[0], b[1]) < _ALIGNED:  # upright: a disc
        hit: NDArray[np.bool_] = a[0] * a[0] + a[1] * a[1] <= radius * radius
        return hit
    lo, hi = _quadratic(a[:2], b[:2], np.full(2, 1.0 / max(radius, _EPS)))
    slab_lo, slab_hi = _slab(a[2], float(b[2]), half)
    hit = np.maximum(lo, slab_lo) <= np.minimum(hi, slab_hi)
    return hit


def _xy_half_extent(kind: int, size: Floats, rot: Floats) -> tuple[float, float]:
    """Half the width and height of the geom's silhouette's bounding rectangle (m)."""
    if kind == _SPHERE:
        return float(size[0]), float(size[0])
    if kind in (_CYLINDER, _CAPSULE):
        radius, half = float(size[0]), float(size[1])
        cap = radius if kind == _CAPSULE else 0.0
        extent = [
            abs(rot[row, 2]) * half + radius * math.hypot(rot[row, 0], rot[row, 1]) + cap
            for row in (0, 1)
        ]
        return extent[0], extent[1]
    if kind == _ELLIPSOID:
        return float(np.linalg.norm(rot[0] * size)), float(np.linalg.norm(rot[1] * size))
    return float(np.abs(rot[0]) @ size), float(np.abs(rot[1]) @ size)


def _moving_bodies(model: mujoco.MjModel) -> NDArray[np.bool_]:
    """Bodies that have a joint, or an ancestor with one: they move between resets."""
    moving = np.zeros(model.nbody, dtype=bool)
    for body in range(1, model.nbody):  # parents come before their children
        moving[body] = model.body_jntnum[body] > 0 or moving[model.body_parentid[body]]
    return moving


class TopDownRenderer:
    """Draws the scene from straight above (+x to the right, +y up) as an RGB ``uint8`` image.

    Args:
        model: The compiled model.
        data: Its data; each frame shows the poses in it (after ``mj_forward`` or a step).
        width: Image width in pixels.
        height: Image height in pixels.
        view_size: Metres shown across the image's height, centred on the world origin.
        laser_spec: The laser whose readings :meth:`render` draws (None: no laser).
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        width: int = 360,
        height: int = 360,
        view_size: float = 4.6,
        laser_spec: LaserSpec | None = None,
    ) -> None:
        if not (1 <= width <= 4096 and 1 <= height <= 4096):
            raise ValueError(f"image size must be within [1, 4096] pixels, got {width}x{height}")
        if not (view_size > 0 and math.isfinite(view_size)):
            raise ValueError(f"view_size must be a positive number of metres, got {view_size}")
        self.model, self.data = model, data
        self.width, self.height = width, height
        self.pixels_per_metre = height / view_size
        self.laser_spec = laser_spec
        # World coordinates of each column's and row's pixel centre (row 0 is the top, +y).
        columns, rows = np.arange(width, dtype=np.float64), np.arange(height, dtype=np.float64)
        self._x: Floats = (columns + 0.5 - width / 2.0) / self.pixels_per_metre
        self._y: Floats = (height / 2.0 - rows - 0.5) / self.pixels_per_metre
        # A scene without the robot (or its laser) is drawn without a heading (or rays).
        self._base = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, names.BASE_BODY)
        self._laser_site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, names.LASER_SITE)
        if laser_spec is not None and self._laser_site < 0:
            raise ValueError(f"a laser_spec needs the model's {names.LASER_SITE!r} site")
        if laser_spec is not None:
            angles = laser_spec.angles()
            self._laser_dirs = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], 1)
        moving = _moving_bodies(model)[model.geom_bodyid]
        drawn = (model.geom_group < _VISIBLE_GROUPS) & (model.geom_type != _PLANE)
        self._static_geoms = np.flatnonzero(drawn & ~moving)
        self._moving_geoms = np.flatnonzero(drawn & moving)
        self._background: Image | None = None
        self._background_key: Floats | None = None
        self._rayed: Image | None = None
        self._rayed_source: Image | None = None

    @classmethod
    def for_env(cls, env: Any, width: int = 360, height: int = 360) -> TopDownRenderer:
        """A renderer for a ``BubbleRobEnv`` (or a wrapper of one): its arena and walls in view."""
        from bubblerob_env.env import BubbleRobEnv

        base = env.unwrapped
        if not isinstance(base, BubbleRobEnv):
            raise TypeError(f"expected a BubbleRob env, got {type(base).__name__}")
        view_size = 1.05 * (float(base.arena_size) + 0.3)  # the walls stand outside the arena
        return cls(base.model, base.data, width, height, view_size, base.laser_spec)

    def render(self, laser_readings: NDArray[Any] | None = None) -> Image:
        """One frame; with the laser's readings (metres, one per ray) its rays and hits drawn."""
        frame: Image = self._current_background().copy()
        if laser_readings is not None and self.laser_spec is not None:
            readings = np.asarray(laser_readings, dtype=np.float64).reshape(-1)
            if readings.shape != (self.laser_spec.num_rays,):
                raise ValueError(
                    f"laser_readings must hold one reading per ray "
                    f"({self.laser_spec.num_rays}), got shape {np.shape(laser_readings)}"
                )
            origin, ends = self._laser_endpoints(readings)
            self._draw_rays(frame, origin, ends)
            self._draw_geoms(frame, self._moving_geoms)
            hits = ends[readings < self.laser_spec.range_max]
            self._draw_dots(frame, hits, _HIT_RGB)
        else:
            self._draw_geoms(frame, self._moving_geoms)
        self._draw_heading(frame)
        return frame

    def _static_key(self) -> Floats:
        geoms = self._static_geoms
        data, model = self.data, self.model
        key: Floats = np.concatenate(
            [
                data.geom_xpos[geoms].ravel(),
                data.geom_xmat[geoms].ravel(),
                model.geom_size[geoms].ravel(),
                model.geom_rgba[geoms].ravel(),
            ]
        )
        return key

    def _current_background(self) -> Image:
        key = self._static_key()
        previous = self._background_key
        if self._background is None or previous is None or not np.array_equal(key, previous):
            self._background = self._draw_background()
            self._background_key = key
        return self._background

    def _draw_background(self) -> Image:
        image = np.empty((self.height, self.width, 3), dtype=np.uint8)
        image[:] = _FLOOR_RGB
        # A line every metre (the floor's grid), so that distances can be read off the video.
        image[:, (np.abs(self._x - np.round(self._x)) * self.pixels_per_metre) < 0.5] = _GRID_RGB
        image[(np.abs(self._y - np.round(self._y)) * self.pixels_per_metre) < 0.5, :] = _GRID_RGB
        self._draw_geoms(image, self._static_geoms)
        return image

    def _colours(self, geoms: NDArray[np.intp]) -> tuple[NDArray[np.uint8], NDArray[np.bool_]]:
        """Each geom's RGB (its material's, as MuJoCo draws it) and whether it is visible."""
        model = self.model
        material = model.geom_matid[geoms]
        rgba = model.geom_rgba[geoms]
        if model.nmat:
            rgba = np.where((material >= 0)[:, None], model.mat_rgba[np.maximum(material, 0)], rgba)
        visible = (model.geom_rgba[geoms, 3] > 0.0) & (rgba[:, 3] > 0.0)
        return np.round(np.clip(rgba[:, :3], 0.0, 1.0) * 255).astype(np.uint8), visible

    def _draw_geoms(self, image: Image, geoms: NDArray[np.intp]) -> None:
        model, data = self.model, self.data
        tops = data.geom_xpos[geoms, 2] + model.geom_rbound[geoms]
        # Below the floor: a parked obstacle slot.
        visible_colours = self._colours(geoms)
        for index in np.argsort(tops, kind="stable"):
            if tops[index] >= 0.0 and visible_colours[1][index]:
                self._fill_geom(image, int(geoms[index]), visible_colours[0][index])

    def _fill_geom(self, image: Image, geom: int, colour: NDArray[np.uint8]) -> None:
        model, data = self.model, self.data
        kind = int(model.geom_type[geom])
        rot = data.geom_xmat[geom].reshape(3, 3)
        centre = data.geom_xpos[geom]
        size = model.geom_size[geom].astype(np.float64)
        if kind not in (_SPHERE, _CAPSULE, _ELLIPSOID, _CYLINDER, _BOX):
            box = model.geom_aabb[geom]  # centre and half sizes in the geom's frame
            centre, size, kind = centre + rot @ box[:3], box[3:].astype(np.float64), _BOX
        half_x, half_y = _xy_half_extent(kind, size, rot)
        columns = self._span(self._x, centre[0], half_x)
        rows = self._span(self._y, centre[1], half_y)
        if columns.start >= columns.stop or rows.start >= rows.stop:
            return
        dx = self._x[columns][None, :] - centre[0]
        dy = self._y[rows][:, None] - centre[1]
        mask = _silhouette(kind, size, rot, dx, dy)
        image[rows, columns][mask] = colour

    def _span(self, centres: Floats, middle: float, half: float) -> slice:
        """The pixels whose centres lie within ``middle +- half`` (ascending or descending)."""
        scale = self.pixels_per_metre
        if centres[0] < centres[-1]:  # columns: x grows with the index
            first = (middle - half - centres[0]) * scale
            last = (middle + half - centres[0]) * scale
        else:  # rows: y falls with the index
            first = (centres[0] - (middle + half)) * scale
            last = (centres[0] - (middle - half)) * scale
        start = max(0, math.ceil(first - 1e-9))
        stop = min(len(centres), math.floor(last + 1e-9) + 1)
        return slice(start, max(start, stop))

    def _pixel_coordinates(self, points: Floats) -> Floats:
        """``(column, row)`` of world ``(x, y)`` points as floats; the pixel is their floor."""
        scale = np.array([self.pixels_per_metre, -self.pixels_per_metre])
        result: Floats = points[..., :2] * scale + np.array([self.width, self.height]) / 2.0
        return result

    def _to_pixels(self, points: Floats) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        pixels = np.floor(self._pixel_coordinates(points)).astype(np.intp)
        return pixels[..., 0], pixels[..., 1]

    def _inside(
        self, columns: NDArray[np.intp], rows: NDArray[np.intp]
    ) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        keep = (columns >= 0) & (columns < self.width) & (rows >= 0) & (rows < self.height)
        return columns[keep], rows[keep]

    def _laser_endpoints(self, readings: Floats) -> tuple[Floats, Floats]:
        site = self._laser_site
        origin = self.data.site_xpos[site]
        directions = self._laser_dirs @ self.data.site_xmat[site].reshape(3, 3).T
        return origin[:2].copy(), origin[:2] + directions[:, :2] * readings[:, None]

    def _draw_rays(self, image: Image, origin: Floats, ends: Floats) -> None:
        """Rays over the background: pixels on a ray take the background's blended colour."""
        stride = max(1, -(-len(ends) // _MAX_DRAWN_RAYS))
        start = self._pixel_coordinates(origin)
        if not (0.0 <= start[0] < self.width and 0.0 <= start[1] < self.height):
            return  # the laser is out of view, and so are its rays' starts
        spans = self._clip_to_image(start, self._pixel_coordinates(ends[::stride]) - start)
        # A sample per column or row each ray crosses: short rays cost little.
        counts = np.ceil(np.abs(spans).max(axis=1)).astype(np.intp) + 1
        steps = spans / np.maximum(counts - 1, 1)[:, None]
        ray = np.repeat(np.arange(len(spans)), counts)
        index = np.arange(ray.size) - np.repeat(np.cumsum(counts) - counts, counts)
        columns = (start[0] + index * steps[ray, 0]).astype(np.intp)  # >= 0: truncation floors
        rows = (start[1] + index * steps[ray, 1]).astype(np.intp)
        flat = rows * self.width + columns
        pixel = np.dtype((np.void, 3))  # one RGB pixel: an index moves all three bytes
        rayed = self._rayed_background().view(pixel).reshape(-1)
        image.view(pixel).reshape(-1)[flat] = rayed[flat]

    def _clip_to_image(self, start: Floats, spans: Floats) -> Floats:
        """Shorten each ray from ``start`` (in the image) by ``spans`` (pixels) to end in it."""
        limit = np.array([self.width, self.height]) * (1.0 - 1e-9)
        with np.errstate(divide="ignore", invalid="ignore"):
            room = np.where(spans > 0, (limit - start) / spans, np.inf)
            room = np.where(spans < 0, -start / spans, room)
        scale = np.minimum(1.0, room.min(axis=1))
        clipped: Floats = spans * scale[:, None]
        return clipped

    def _rayed_background(self) -> Image:
        """The background with the ray colour blended in everywhere (made once per background)."""
        if self._rayed is None or self._rayed_source is not self._background:
            under = self._current_background()
            blended = np.round(under * (1.0 - _RAY_ALPHA) + _RAY_RGB * _RAY_ALPHA)
            self._rayed, self._rayed_source = blended.astype(np.uint8), self._background
        return self._rayed

    def _draw_dots(self, image: Image, points: Floats, colour: NDArray[np.uint8]) -> None:
        """A 3x3 pixel square at each point (none within a pixel of the image's edges)."""
        columns, rows = self._to_pixels(points)
        keep = (columns >= 1) & (columns < self.width - 1) & (rows >= 1) & (rows < self.height - 1)
        centres = rows[keep] * self.width + columns[keep]
        offsets = (np.arange(-1, 2)[:, None] * self.width + np.arange(-1, 2)).ravel()
        pixel = np.dtype((np.void, 3))  # one RGB pixel: an index moves all three bytes
        image.view(pixel).reshape(-1)[(centres[:, None] + offsets).ravel()] = colour.view(pixel)

    def _draw_heading(self, image: Image) -> None:
        """A line from the robot's centre along its +x, out to its front edge."""
        base = self._base
        if base < 0:
            return
        origin = self.data.xpos[base][:2]
        forward = self.data.xmat[base].reshape(3, 3)[:2, 0]
        length = 0.09  # metres: past the chassis, short of the nose sensor's reach
        samples = max(2, math.ceil(length * self.pixels_per_metre) + 1)
        steps = np.linspace(0.0, length, samples)[:, None]
        columns, rows = self._inside(*self._to_pixels(origin + steps * forward))
        image[rows, columns] = _HEADING_RGB
