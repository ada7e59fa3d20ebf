"""Scene building and the seeded arena layout: obstacle slots, random obstacles, a free start pose.

The model is compiled once per env. Every reset draws a new layout and writes it into
pre-allocated obstacle slots, so a reset never recompiles and renderers keep working on the same
model. Each slot is a mocap body holding one geom: the pose goes into ``data.mocap_pos`` /
``mocap_quat`` and the size into the model's geom and bounding-volume arrays.

Why one body per slot: MuJoCo's midphase keeps a bounding-volume hierarchy (BVH) per body, built
in the body's frame when the model is compiled. The slots used to be geoms of the world body,
compiled parked at z=-10 and moved at reset by writing ``model.geom_pos``; the world body's BVH
still held the parked boxes, so the midphase discarded most robot-obstacle pairs before the
narrowphase ever saw them, and 17 of the 20 slots let the robot drive through (all 20 collided
with ``mjDSBL_MIDPHASE``). A body with one geom has a one-node BVH centred on the body, which stays
right wherever the body moves; only a size change has to be written into it.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace
from pathlib import Path

import mujoco
import numpy as np

from bubblerob_env import names
from bubblerob_env.robots import ASSETS_DIR, BUBBLEROB

__all__ = [
    "ASSETS_DIR",
    "DEFAULT_SCENE",
    "ROBOT_RADIUS",
    "ArenaLayout",
    "CrowdedArenaWarning",
    "Obstacle",
    "OBSTACLE_PALETTE",
    "ObstacleSlots",
    "build_model",
    "colour_obstacles",
    "sample_layout",
]

DEFAULT_SCENE = BUBBLEROB.scene_file
"""BubbleRob's scene (each robot's is its description's ``scene_file``)."""

ROBOT_RADIUS = BUBBLEROB.radius
"""BubbleRob's bounding radius about base_link (m); each robot's is its description's
``radius``, which :func:`sample_layout` takes."""
_CAMERA_NEAR_CLIP = 0.005  # metres
_PARKED_Z = -10.0  # unused obstacle slots wait below the floor, out of every ray's reach
_MAX_TRIES = 200

OBSTACLE_PALETTE: dict[str, tuple[float, float, float]] = {
    "red": (0.85, 0.12, 0.12),
    "yellow": (0.85, 0.8, 0.1),
    "green": (0.15, 0.7, 0.2),
    "cyan": (0.1, 0.7, 0.8),
    "blue": (0.15, 0.25, 0.85),
    "magenta": (0.8, 0.15, 0.75),
}
"""The colours :func:`colour_obstacles` draws from (RGB in [0, 1]), one per hue sextant: each is
saturated (the walls' brown and the grey floor are not) and 60 degrees of hue from the next, so a
camera pixel's hue names its colour under any shading the headlight gives."""


@dataclass(frozen=True)
class Obstacle:
    """One obstacle. ``size`` is (radius,) for a cylinder, (half x, half y) for a box.

    ``colour`` is a name in :data:`OBSTACLE_PALETTE`, or ``None``: the scene's obstacle material.
    """

    kind: str
    x: float
    y: float
    yaw: float
    size: tuple[float, ...]
    colour: str | None = None

    @property
    def bounding_radius(self) -> float:
        """Radius of the smallest vertical cylinder around it."""
        return self.size[0] if self.kind == "cylinder" else math.hypot(*self.size)


@dataclass(frozen=True)
class ArenaLayout:
    """Obstacles and the robot's start pose ``(x, y, yaw)`` drawn for one episode."""

    obstacles: tuple[Obstacle, ...]
    start_pose: tuple[float, float, float]


def build_model(
    xml_file: str | Path,
    arena_size: float,
    max_obstacles: int,
    memory: int | None = None,
    obstacle_height: float | None = None,
) -> tuple[mujoco.MjModel, bool]:
    """Compile a scene with ``max_obstacles`` cylinder and box slots added.

    If the scene has the default arena's walls they are moved and resized to enclose a square of
    side ``arena_size`` (keeping each wall's thickness and height from the scene), and the floor is
    resized to match. The slots take their height from the scene's ``obstacle`` class, or are
    ``obstacle_height`` tall (m) when given (the robot's arena: a tall robot's laser must see
    them).

    ``memory`` (bytes) sizes each ``MjData``'s arena (contacts, constraints, stack) unless the
    scene sets ``<size memory=...>`` itself; by default MuJoCo's.

    Returns:
        The compiled model and whether the scene has the resizable arena walls.
    """
    spec = mujoco.MjSpec.from_file(str(xml_file))
    if memory is not None and spec.memory < 0:
        spec.memory = memory
    walls = [spec.geom(name) for name in names.ARENA_WALLS]
    has_arena = all(wall is not None for wall in walls)
    if has_arena:
        half = arena_size / 2.0
        outer = half
        for wall, (x, y) in zip(walls, ((0, 1), (0, -1), (1, 0), (-1, 0)), strict=True):
            thickness = float(min(wall.size[0], wall.size[1]))  # half-thickness
            height = float(wall.size[2])  # half-height; walls stand on the floor
            wall.pos = [x * (half + thickness), y * (half + thickness), height]
            wall.size = [
                half + 2 * thickness if x == 0 else thickness,
                half + 2 * thickness if y == 0 else thickness,
                height,
            ]
            outer = max(outer, half + 2 * thickness)
        floor = spec.geom(names.FLOOR_GEOM)
        floor.size = [outer + 0.5, outer + 0.5, floor.size[2]]
    obstacle_class = spec.find_default(names.OBSTACLE_CLASS)
    half_height = float(obstacle_class.geom.size[2])
    if obstacle_height is not None:
        half_height = obstacle_height / 2.0
    for i in range(max_obstacles):
        for prefix, geom_type in (
            (names.CYLINDER_SLOT_PREFIX, mujoco.mjtGeom.mjGEOM_CYLINDER),
            (names.BOX_SLOT_PREFIX, mujoco.mjtGeom.mjGEOM_BOX),
        ):
            body = spec.worldbody.add_body(
                name=f"{prefix}{i}", mocap=True, pos=[0.0, 0.0, _PARKED_Z]
            )
            body.add_geom(
                default=obstacle_class,
                name=f"{prefix}{i}",
                type=geom_type,
                size=[0.1, 0.1, half_height]
                if geom_type == mujoco.mjtGeom.mjGEOM_BOX
                else [0.1, half_height, 0.0],
            )
    model = spec.compile()
    # MuJoCo's near clipping plane is a fraction of the model's extent (12 m for the default
    # arena, so 12 cm): the camera, 4 cm behind the nose, lost obstacles right in front of it.
    model.vis.map.znear = _CAMERA_NEAR_CLIP / model.stat.extent
    return model, has_arena


class ObstacleSlots:
    """Writes layouts into the obstacle slots of a model built by :func:`build_model`."""

    def __init__(self, model: mujoco.MjModel, max_obstacles: int) -> None:
        self._free: dict[str, list[tuple[int, int, int]]] = {}
        for kind, prefix in (
            ("cylinder", names.CYLINDER_SLOT_PREFIX),
            ("box", names.BOX_SLOT_PREFIX),
        ):
            slots = []
            for i in range(max_obstacles):
                body = model.body(f"{prefix}{i}")
                slots.append(
                    (
                        model.geom(f"{prefix}{i}").id,
                        int(model.body_mocapid[body.id]),
                        int(model.body_bvhadr[body.id]),
                    )
                )
            self._free[kind] = slots
        # Half the obstacles' height: the scene's obstacle class, kept in the box slots' size[2].
        self.half_height = 0.0
        self.placed: tuple[int, ...] = ()
        """The geom id of each obstacle of the last :meth:`apply`, in the layout's order."""
        if max_obstacles:
            self.half_height = float(model.geom_size[self._free["box"][0][0]][2])

    @property
    def geom_ids(self) -> list[int]:
        """Every slot's geom id."""
        return [gid for slots in self._free.values() for gid, _, _ in slots]

    @property
    def slots(self) -> list[tuple[int, int, int]]:
        """Every slot's geom id, mocap id and BVH node, cylinders first, as ``geom_ids``."""
        return [slot for slots in self._free.values() for slot in slots]

    def apply(
        self, model: mujoco.MjModel, data: mujoco.MjData, obstacles: tuple[Obstacle, ...]
    ) -> None:
        """Place ``obstacles`` in the slots and park the unused slots below the floor.

        Call after ``mj_resetData`` (which moves mocap bodies back to their compiled pose) and
        before ``mj_forward``.
        """
        half_height = self.half_height
        free = {kind: iter(slots) for kind, slots in self._free.items()}
        used = []
        quat = np.empty(4)
        for obstacle in obstacles:
            gid, mocap, bvh = next(free[obstacle.kind])
            used.append(gid)
            data.mocap_pos[mocap] = (obstacle.x, obstacle.y, half_height)
            mujoco.mju_axisAngle2Quat(quat, np.array([0.0, 0.0, 1.0]), obstacle.yaw)
            data.mocap_quat[mocap] = quat
            if obstacle.kind == "cylinder":
                half_extents = (obstacle.size[0], obstacle.size[0], half_height)
                model.geom_size[gid] = (obstacle.size[0], half_height, 0.0)
                model.geom_rbound[gid] = math.hypot(obstacle.size[0], half_height)
            else:
                half_extents = (obstacle.size[0], obstacle.size[1], half_height)
                model.geom_size[gid] = half_extents
                model.geom_rbound[gid] = math.sqrt(sum(h * h for h in half_extents))
            # The geom sits at its body's origin, so its box and the body's one BVH node agree.
            model.geom_aabb[gid] = (0.0, 0.0, 0.0, *half_extents)
            model.bvh_aabb[bvh] = (0.0, 0.0, 0.0, *half_extents)
            # A geom rgba other than MuJoCo's default grey overrides its material's colour;
            # uncoloured obstacles leave it alone (the material shows, as before colours).
            if obstacle.colour is not None:
                model.geom_rgba[gid, :3] = OBSTACLE_PALETTE[obstacle.colour]
        for slots in free.values():
            for _, mocap, _ in slots:
                data.mocap_pos[mocap] = (0.0, 0.0, _PARKED_Z)
        self.placed = tuple(used)
        parked = sorted(set(self.geom_ids) - set(used))
        # Alpha 0 keeps parked slots out of every rendered scene (they cost ~40% of a camera
        # frame otherwise); rays test the obstacle material's alpha, so used slots stay visible.
        model.geom_rgba[used, 3] = 1.0
        model.geom_rgba[parked, 3] = 0.0


def sample_layout(
    rng: np.random.Generator,
    arena_size: float,
    num_obstacles: tuple[int, int],
    obstacle_size: tuple[float, float],
    start_clearance: float,
    start_pose: tuple[float, float, float] | None = None,
    robot_radius: float = ROBOT_RADIUS,
) -> ArenaLayout:
    """Draw a start pose and obstacles at free positions inside the arena.

    The start pose (or the given ``start_pose``) keeps ``start_clearance`` metres between the
    robot's bounding circle and the walls and every obstacle. Obstacles keep a gap of at least one
    robot diameter from each other and from the walls, so every obstacle can be driven around. An
    obstacle that finds no room after a bounded number of tries is dropped, so the result depends
    only on the generator's state and a crowded arena never fails to reset; a drop is said in a
    :class:`CrowdedArenaWarning` (an obstacle too large for any arena is refused earlier, by the
    env's config). ``robot_radius``: the robot's bounding circle about base_link (its
    description's ``radius``).
    """
    half = arena_size / 2.0
    keep_out = robot_radius + start_clearance
    if start_pose is None:
        # The start pose is drawn first and obstacles keep clear of it, so a crowded arena drops
        # obstacles instead of failing to find room for the robot.
        limit = half - keep_out
        if limit <= 0:
            raise ValueError(f"arena_size {arena_size} m is too small for the robot")
        x, y = (float(v) for v in rng.uniform(-limit, limit, size=2))
        start_pose = (x, y, float(rng.uniform(-math.pi, math.pi)))
    count = int(rng.integers(num_obstacles[0], num_obstacles[1] + 1))
    gap = 2 * robot_radius
    obstacles: list[Obstacle] = []
    for _ in range(count):
        kind = "cylinder" if rng.random() < 0.5 else "box"
        if kind == "cylinder":
            size: tuple[float, ...] = (float(rng.uniform(*obstacle_size)),)
        else:
            size = (float(rng.uniform(*obstacle_size)), float(rng.uniform(*obstacle_size)))
        yaw = float(rng.uniform(-math.pi, math.pi)) if kind == "box" else 0.0
        for _ in range(_MAX_TRIES):
            candidate = Obstacle(kind, 0.0, 0.0, yaw, size)
            limit = half - candidate.bounding_radius - gap
            if limit <= 0:
                break
            x, y = (float(v) for v in rng.uniform(-limit, limit, size=2))
            candidate = Obstacle(kind, x, y, yaw, size)
            clear_of_start = (
                math.hypot(x - start_pose[0], y - start_pose[1]) - candidate.bounding_radius
                >= keep_out
            )
            if clear_of_start and all(_distance(candidate, other) >= gap for other in obstacles):
                obstacles.append(candidate)
                break
    if len(obstacles) < count:
        warnings.warn(
            f"the arena had room for {len(obstacles)} of the {count} obstacles drawn "
            f"(arena_size {arena_size:g} m, obstacle_size {obstacle_size}): fewer "
            "num_obstacles, smaller obstacles or a larger arena place them all",
            CrowdedArenaWarning,
            stacklevel=2,
        )
    return ArenaLayout(tuple(obstacles), start_pose)


class CrowdedArenaWarning(UserWarning):
    """A layout holds fewer obstacles than were drawn: the arena had no room for the others."""


def colour_obstacles(rng: np.random.Generator, layout: ArenaLayout) -> ArenaLayout:
    """``layout`` with each obstacle given a colour drawn uniformly from :data:`OBSTACLE_PALETTE`.

    One draw per obstacle from ``rng``, made after :func:`sample_layout`'s, so the layout itself
    is the one the same generator gives without colours.
    """
    names_ = tuple(OBSTACLE_PALETTE)
    picks = rng.integers(len(names_), size=len(layout.obstacles))
    obstacles = tuple(
        replace(obstacle, colour=names_[int(pick)])
        for obstacle, pick in zip(layout.obstacles, picks, strict=True)
    )
    return replace(layout, obstacles=obstacles)


def _distance(a: Obstacle, b: Obstacle) -> float:
    return math.hypot(a.x - b.x, a.y - b.y) - a.bounding_radius - b.bounding_radius
