"""A classical recogniser for the forward camera: the obstacles and walls in an RGB frame.

Pipeline (see :mod:`~bubblerob_env.vision.segment` for the pixel work):

1. Colour segmentation: a saturated pixel takes the nearest palette hue, a brown one the walls'.
2. Connected components of equal codes (walls also split by brightness: one flat face each).
3. Class from shading: the headlight shines along the optical axis, so a flat box face has one
   brightness while a cylinder's curved side changes from column to column. A component with at
   most two brightness levels is a box (a box shows one or two faces), one with more a cylinder.
4. Bearing from the silhouette's edges: the two tangents from the camera to a cylinder are
   symmetric about its axis, so its bearing is the mean of the edges' bearings (for a box, an
   estimate of its centre's). An object cut by the frame's left or right edge has one edge in
   view: a cylinder whose brightest column is in view is solved from that edge and that column
   (the point facing the headlight has the axis's lateral offset); otherwise the axis is taken a
   typical half width (:data:`CUT_HALF_WIDTH`, a prior) beyond the edge.
5. Distance from the ground contact: the camera is level at a known height, so the silhouette's
   lowest row gives the depth of the nearest point of its base (or, when the frame cuts the base
   off, the top row and the obstacles' known height; when it cuts both, a fraction of the depth
   at which that starts); half the apparent width is added for the depth of the axis.

It needs obstacles in the palette's colours (``obstacle_colours=True``); the default material's
blue counts as the palette's blue.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from bubblerob_env import names
from bubblerob_env.arena import OBSTACLE_PALETTE
from bubblerob_env.robots.bubblerob import BUBBLEROB
from bubblerob_env.robots.description import RobotDescription
from bubblerob_env.sensors import CameraSpec
from bubblerob_env.vision.geometry import CameraPose, column_to_bearing
from bubblerob_env.vision.segment import (
    KIND_BOX,
    KIND_CYLINDER,
    KIND_WALL,
    components,
    frame_objects,
    pixel_codes,
)

__all__ = ["Detection", "Recogniser", "cut_half_width", "obstacle_height"]

MAX_BOX_LEVELS = 2
NEAR_FRACTION = 0.75
"""Where the frame cuts an object's top and base, its depth is taken as this fraction of the
largest depth at which that happens (chosen on seeds 0-49)."""
CUT_HALF_WIDTH = {"cylinder": 0.2, "box": 0.28}
"""Metres from an object's axis to its silhouette's edge assumed where the frame cuts it and its
shading cannot tell; chosen on seeds 0-49 for the env's default obstacle sizes (radius or half
side 0.08-0.25 m; a box's silhouette is wider than its side); :func:`cut_half_width` scales
them to another robot's arena."""


@dataclass(frozen=True)
class Detection:
    """One recognised object; fields as in :class:`.ground_truth.LabelledObject`.

    ``colour`` is the palette name (``None`` for walls); ``truncated``: the box touches the frame's
    left or right edge, so part of the object may be outside the view: a cylinder's bearing then
    comes from its one edge and its shading, a box's is the visible part's.
    """

    kind: str
    colour: str | None
    box: tuple[int, int, int, int]
    pixels: int
    bearing: float
    distance: float
    truncated: bool

    @property
    def bearing_deg(self) -> float:
        """``bearing`` in degrees."""
        return math.degrees(self.bearing)


def _hue_of(rgb: tuple[float, float, float]) -> float:
    r, g, b = rgb
    high, low = max(rgb), min(rgb)
    spread = high - low
    if high == r:
        hue = 60.0 * ((g - b) / spread)
    elif high == g:
        hue = 60.0 * ((b - r) / spread + 2.0)
    else:
        hue = 60.0 * ((r - g) / spread + 4.0)
    return hue % 360.0


class Recogniser:
    """Finds obstacles and walls in frames of a level camera ``spec`` at ``camera_height`` metres.

    ``obstacle_height`` (m) is used where a frame cuts an obstacle's base off.
    ``min_pixels`` drops smaller components.
    """

    def __init__(
        self,
        spec: CameraSpec,
        camera_height: float,
        obstacle_height: float,
        min_pixels: int = 8,
        cut_half_width: dict[str, float] | None = None,
    ) -> None:
        self.spec = spec
        self.camera_height = camera_height
        self.obstacle_height = obstacle_height
        self.min_pixels = min_pixels
        self.cut_half_width = dict(cut_half_width or CUT_HALF_WIDTH)
        self._colours = tuple(OBSTACLE_PALETTE)
        self._hues = np.array([_hue_of(OBSTACLE_PALETTE[c]) for c in self._colours])
        self._wall_code = len(self._colours) + 1

    @classmethod
    def for_env(cls, env: Any, min_pixels: int = 8) -> Recogniser:
        """One for the camera of ``env`` (a ``BubbleRobEnv``, unwrapped), any robot.

        The same for every episode of the env: the camera's height is that of the model's
        default pose (the robot stands on the floor in every pose, but a pose's own height may
        differ in the last bit, and replay must rebuild the recorder's recogniser exactly). The
        obstacles' height is the model's; :data:`CUT_HALF_WIDTH` scales with the robot's arena
        (:func:`cut_half_width`).
        """
        if env.camera_spec is None:
            raise ValueError("the env has no camera: make it with camera=True or a camera size")
        # The arena's floor is the plane z = 0.
        default_pose = mujoco.MjData(env.model)
        mujoco.mj_forward(env.model, default_pose)
        camera_height = CameraPose.of(env.model, default_pose).z
        return cls(
            env.camera_spec,
            camera_height,
            obstacle_height(env),
            min_pixels,
            cut_half_width(env.robot),
        )

    def __call__(self, frame: NDArray[np.uint8]) -> list[Detection]:
        """The objects in ``frame`` (``(height, width, 3)`` uint8 RGB), largest first."""
        if frame.shape != (self.spec.height, self.spec.width, 3):
            raise ValueError(
                f"frame shape {frame.shape} is not the camera's "
                f"({self.spec.height}, {self.spec.width}, 3)"
            )
        codes, value = pixel_codes(np.ascontiguousarray(frame), self._hues)
        labels, found, stats, levels = components(codes, value, self._wall_code)
        detections = []
        walls: dict[int, list[NDArray[np.int64]]] = {}
        for index, (code, stat, level) in enumerate(
            zip(found.tolist(), stats, levels, strict=True)
        ):
            if code == self._wall_code:
                # A wall broken up by an obstacle in front keeps its one brightness.
                walls.setdefault(int(np.argmax(level)), []).append(stat)
                continue
            if stat[0] < self.min_pixels:
                continue
            kind = "box" if int(level.sum()) <= MAX_BOX_LEVELS else "cylinder"
            bright = math.nan
            if kind == "cylinder" and (stat[1] == 0 or stat[3] == self.spec.width - 1):
                bright = _bright_column(labels, value, index)
            detections.append(self._detection(kind, self._colours[code - 1], stat, bright))
        for parts in walls.values():
            merged = np.array(
                [
                    sum(int(p[0]) for p in parts),
                    min(int(p[1]) for p in parts),
                    min(int(p[2]) for p in parts),
                    max(int(p[3]) for p in parts),
                    max(int(p[4]) for p in parts),
                ]
            )
            if merged[0] >= self.min_pixels:
                detections.append(self._detection("wall", None, merged, math.nan))
        detections.sort(key=lambda d: -d.pixels)
        return detections

    def many(self, frames: NDArray[np.uint8]) -> list[list[Detection]]:
        """The objects in each of ``frames`` ``(n, height, width, 3)``, as ``self`` finds them.

        ``[self(f) for f in frames]``, with the pixel work of every frame in one compiled call.
        Frame by frame, the loop over components and their brightness levels costs more than the
        pixels; :func:`~bubblerob_env.vision.segment.frame_objects` does it in the same call,
        and only the geometry of what it keeps runs here (the same code, so the same numbers:
        ``tests/ros/test_batched_detections.py`` checks on recorded frames).
        """
        height, width = self.spec.height, self.spec.width
        if frames.ndim != 4 or frames.shape[1:] != (height, width, 3):
            raise ValueError(
                f"frames shape {frames.shape} is not (n, {height}, {width}, 3), the camera's"
            )
        offsets, rows, bright = frame_objects(
            np.ascontiguousarray(frames, dtype=np.uint8), self._hues, self.min_pixels,
            MAX_BOX_LEVELS,
        )  # fmt: skip
        found = [
            self._detection(_KINDS[kind], None if kind == KIND_WALL else self._colours[colour],
                            stat, column)
            for (kind, colour, *stat), column in zip(rows.tolist(), bright.tolist(), strict=True)
        ]  # fmt: skip
        by_frame = []
        for start, end in itertools.pairwise(offsets.tolist()):
            detections = found[start:end]
            detections.sort(key=_by_pixels)
            by_frame.append(detections)
        return by_frame

    def _near_depth(self, v_min: int, v_max: int) -> float:
        """Depth of the nearest point of an object's base from its rows.

        From the bottom row, or the top one where the frame cuts the base off. Where it cuts
        both, the object is nearer than the depth at which its base and top meet the frame's
        edges: that bound, scaled by :data:`NEAR_FRACTION`.
        """
        height, focal = self.spec.height, self.spec.focal_length
        centre_row = (height - 1) / 2.0
        rise = self.obstacle_height - self.camera_height
        if v_max < height - 1 and v_max + 0.5 > centre_row:
            return focal * self.camera_height / (v_max + 0.5 - centre_row)
        if v_min > 0 and centre_row > v_min - 0.5:
            return focal * rise / (centre_row - (v_min - 0.5))
        bound = min(self.camera_height, rise) * focal / (centre_row + 0.5)
        return NEAR_FRACTION * bound

    def _detection(
        self,
        kind: str,
        colour: str | None,
        stat: Sequence[int] | NDArray[np.int64],
        bright_column: float,
    ) -> Detection:
        pixels, u_min, v_min, u_max, v_max = (int(s) for s in stat)
        width, focal = self.spec.width, self.spec.focal_length
        # A pixel is drawn when its centre is inside: the edges lie half a pixel outside.
        left = column_to_bearing(u_min - 0.5, width, focal)
        right = column_to_bearing(u_max + 0.5, width, focal)
        truncated = u_min == 0 or u_max == width - 1
        depth = self._near_depth(v_min, v_max)
        if kind == "wall":
            bearing = (left + right) / 2.0
            return Detection(
                kind, colour, (u_min, v_min, u_max, v_max), pixels, bearing,
                depth / math.cos(bearing), truncated,
            )  # fmt: skip
        cut_left, cut_right = u_min == 0, u_max == width - 1
        if cut_left != cut_right:
            inner = right if cut_left else left  # the silhouette's edge inside the frame
            border = 0 if cut_left else width - 1
            if kind == "cylinder" and round(bright_column) != border:
                bright = column_to_bearing(bright_column, width, focal)
                bearing, distance = _cylinder_from_edge(depth, bright, inner, not cut_left)
            else:
                bearing, distance = _beyond_edge(depth, inner, cut_left, self.cut_half_width[kind])
                middle = (left + right) / 2.0
                if bearing < middle if cut_left else bearing > middle:
                    bearing, distance = middle, depth / math.cos(middle)
        else:
            bearing = (left + right) / 2.0
            # Depth of the axis: the nearest point plus half the width seen at that depth.
            depth += (math.tan(left) - math.tan(right)) * depth / 2.0
            distance = depth / math.cos(bearing)
        return Detection(
            kind, colour, (u_min, v_min, u_max, v_max), pixels, bearing, distance, truncated
        )


_KINDS = {KIND_BOX: "box", KIND_CYLINDER: "cylinder", KIND_WALL: "wall"}


def _by_pixels(detection: Detection) -> int:
    """Sort key: largest first."""
    return -detection.pixels


def obstacle_height(env: Any) -> float:
    """The height (m) of ``env``'s obstacles: every obstacle slot has it.

    An env made without obstacles (``num_obstacles=(0, 0)``) has no slots: the height they would
    have, the robot's arena's or else the scene's ``obstacle`` class's (as ``arena.build_model``
    decides it), so that its recogniser is the one an env with obstacles gets.
    """
    try:
        box_slot = env.model.geom(f"{names.BOX_SLOT_PREFIX}0").id
    except KeyError:
        height = env.robot.arena.obstacle_height
        if height is not None:
            return float(height)
        spec = mujoco.MjSpec.from_file(str(env.xml_file))
        return 2.0 * float(spec.find_default(names.OBSTACLE_CLASS).geom.size[2])
    return 2.0 * float(env.model.geom_size[box_slot][2])


def cut_half_width(robot: RobotDescription) -> dict[str, float]:
    """:data:`CUT_HALF_WIDTH` for ``robot``'s arena: scaled by its obstacles' mean size.

    The prior was chosen for BubbleRob's obstacles (0.08-0.25 m), which it keeps exactly; the
    Pioneer's (0.2-0.6 m) scale it by 2.42 (mean bearing error 2.56 -> 1.40 degrees on held-out
    seeds 100-149; not tuned). The robot's defaults, not the env's ``obstacle_size``, so that
    bags recorded before the scaling re-simulate the same ``/detections``.
    """
    scale = sum(robot.arena.obstacle_size) / sum(BUBBLEROB.arena.obstacle_size)
    return {kind: width * scale for kind, width in CUT_HALF_WIDTH.items()}


def _bright_column(labels: NDArray[np.int32], value: NDArray[np.uint8], label: int) -> float:
    """Mean column of a component's brightest pixels."""
    rows, cols = np.nonzero(labels == label)
    levels = value[rows, cols]
    return float(cols[levels == levels.max()].mean())


def _beyond_edge(
    near_depth: float, edge: float, cut_left: bool, half_width: float
) -> tuple[float, float]:
    """Bearing and distance of an object cut by the frame's edge, from its edge inside the frame.

    Its axis is taken ``half_width`` metres beyond the edge's ray, towards the cut side, at the
    depth of its nearest visible point plus ``half_width``: a prior, for the part not seen.
    """
    depth = near_depth + half_width
    offset = half_width if cut_left else -half_width
    lateral = (depth * math.sin(edge) + offset) / math.cos(edge)
    return math.atan2(lateral, depth), math.hypot(lateral, depth)


def _cylinder_from_edge(
    near_depth: float, bright: float, edge: float, left_edge: bool
) -> tuple[float, float]:
    """Bearing and distance of a cylinder's axis from one silhouette edge and its brightest column.

    The headlight shines along the optical axis, so the brightest point of the side is the one
    whose normal faces straight back: it has the axis's lateral offset and the base's nearest
    depth. The axis ``(near_depth + r, lateral)`` is then ``r`` from the edge's tangent ray.
    """
    lateral = near_depth * math.tan(bright)
    # Signed distance of the centre from the ray (positive when the ray passes to its left).
    side = -1.0 if left_edge else 1.0
    radius = (lateral * math.cos(edge) - near_depth * math.sin(edge)) / (math.sin(edge) + side)
    if not math.isfinite(radius) or radius <= 0.0:
        return bright, near_depth / math.cos(bright)
    depth = near_depth + radius
    return math.atan2(lateral, depth), math.hypot(lateral, depth)
