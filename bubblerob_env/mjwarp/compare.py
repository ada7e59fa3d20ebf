"""The MuJoCo Warp backend against independent references, on any device.

Three checks, each against a reference that shares no code with the backend: the laser against
CPU MuJoCo's ``mj_multiRay`` on the same states (:func:`cpu_laser`); scripted drives head-on into
walls, cylinders and boxes, picked by straight-line geometry of the layouts alone
(:func:`head_on_seeds`), against the CPU env's first contact; and episode outcomes over many
seeds against the CPU env's (:func:`first_contacts`, :func:`cpu_first_contact`). ``tests/warp``
asserts them on Warp's CPU device; ``python bench/warp_equivalence.py --device cuda:0`` reports
them on a GPU.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np
from numpy.typing import NDArray

from bubblerob_env import names
from bubblerob_env.arena import ArenaLayout, sample_layout
from bubblerob_env.mjwarp.vector import WarpVectorEnv
from bubblerob_env.robots import BUBBLEROB

__all__ = [
    "DRIVES",
    "Drives",
    "cpu_drives",
    "cpu_first_contact",
    "cpu_laser",
    "drive_actions",
    "first_contacts",
    "grazing",
    "head_on_seeds",
    "heading",
    "ray_on_state",
    "warp_drives",
]

DRIVES = ("straight", "curve", "random")
"""Open-loop drives: full speed ahead, a constant left curve, random wheel speeds."""


def cpu_laser(env: WarpVectorEnv, world: int) -> NDArray[np.float64]:
    """``mj_multiRay`` from the laser site, on world ``world``'s state copied into CPU MuJoCo."""
    scene = env.scene
    model = copy.deepcopy(scene.model)  # the backend's own scene stays as it was
    data = mujoco.MjData(model)
    worlds = env.worlds
    for geom, _, bvh in scene.slots.slots:  # sizes, and the bounding boxes mj_multiRay culls with
        model.geom_size[geom] = worlds.model.geom_size.numpy()[world, geom]
        model.geom_rbound[geom] = worlds.model.geom_rbound.numpy()[world, geom]
        aabb = worlds.model.geom_aabb.numpy()[world, geom]
        model.geom_aabb[geom] = model.bvh_aabb[bvh] = (*aabb[0], *aabb[1])
    data.qpos[:] = worlds.data.qpos.numpy()[world]
    data.mocap_pos[:] = worlds.data.mocap_pos.numpy()[world]
    data.mocap_quat[:] = worlds.data.mocap_quat.numpy()[world]
    mujoco.mj_kinematics(model, data)
    site = model.site(names.LASER_SITE).id
    spec = scene.laser_spec
    assert spec is not None
    angles = spec.angles()
    local = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1)
    dirs = local @ data.site_xmat[site].reshape(3, 3).T
    dist = np.zeros(spec.num_rays)
    geomid = np.zeros(spec.num_rays, dtype=np.int32)
    group = np.zeros(mujoco.mjNGROUP, dtype=np.uint8)
    group[names.OBSTACLE_GROUP] = 1
    mujoco.mj_multiRay(
        model, data, data.site_xpos[site], dirs.ravel(), group, 1, -1, geomid, dist, None,
        spec.num_rays, spec.range_max,
    )  # fmt: skip
    hit = (dist >= 0) & (dist < spec.range_max)
    return np.where(hit, dist, spec.range_max)


def _first_hit(layout: ArenaLayout, arena: float) -> tuple[str, float, float]:
    """What a straight drive from the start pose meets first.

    Returns its kind, how far off its centre the path runs (a fraction of its bounding radius;
    0 for a wall), and its yaw.
    """
    x, y, yaw = layout.start_pose
    ux, uy = math.cos(yaw), math.sin(yaw)
    to_wall = min((arena / 2 - abs(p)) / abs(u) for p, u in ((x, ux), (y, uy)) if abs(u) > 1e-9)
    best, kind, off, kind_yaw = to_wall, "wall", 0.0, 0.0
    for obstacle in layout.obstacles:
        along = (obstacle.x - x) * ux + (obstacle.y - y) * uy
        across = -(obstacle.x - x) * uy + (obstacle.y - y) * ux
        reach = obstacle.bounding_radius + BUBBLEROB.radius
        if 0 < along < best and abs(across) < reach:
            best, kind = along, obstacle.kind
            off, kind_yaw = abs(across) / obstacle.bounding_radius, obstacle.yaw
    return kind, off, kind_yaw


def head_on_seeds(per_kind: int, first_seed: int) -> list[int]:
    """Seeds whose straight drive from (0, 0) heading +x meets a wall, a cylinder, a box first.

    Near the middle of its face; ``per_kind`` of each, in that order, from ``first_seed`` on.
    """
    kinds: dict[str, list[int]] = {"wall": [], "cylinder": [], "box": []}
    arena = BUBBLEROB.arena
    seed = first_seed
    while any(len(found) < per_kind for found in kinds.values()):
        layout = sample_layout(
            np.random.default_rng(seed), arena.size, arena.num_obstacles, arena.obstacle_size,
            arena.start_clearance, (0.0, 0.0, 0.0), BUBBLEROB.radius,
        )  # fmt: skip
        kind, off, yaw = _first_hit(layout, arena.size)
        face_on = abs(math.sin(2 * yaw)) < 0.3  # a box's face across the path
        if off < 0.3 and face_on and len(kinds[kind]) < per_kind:
            kinds[kind].append(seed)
        seed += 1
    return [seed for found in kinds.values() for seed in found]


def drive_actions(drive: str, n: int, steps: int, seed: int) -> NDArray[np.float32]:
    """``(steps, n, 2)`` wheel actions of one of :data:`DRIVES`."""
    if drive == "random":
        rng = np.random.default_rng(seed)
        return rng.uniform(-0.2, 1.0, (steps, n, 2)).astype(np.float32)
    turn = 1.0 if drive == "straight" else 0.7
    return np.tile(np.array([[1.0, turn]], dtype=np.float32), (steps, n, 1))


def cpu_first_contact(seed: int, actions: NDArray[np.float32], **kwargs: Any) -> int:
    """The step on which ``gym.make``'s env, reset with ``seed``, first touches (-1: never)."""
    env = gym.make("BubbleRob-v0", **kwargs)
    env.reset(seed=seed)
    for step, action in enumerate(actions):
        _, _, terminated, truncated, _ = env.step(action)
        if terminated:
            return step
        if truncated:
            break
    return -1


def first_contacts(
    env: WarpVectorEnv, seeds: list[int], actions: NDArray[np.float32]
) -> NDArray[np.int64]:
    """Each world's first-contact step (-1: none) over ``actions`` from ``reset(seed=seeds)``."""
    env.reset(seed=seeds)
    first = np.full(len(seeds), -1, dtype=np.int64)
    for step, action in enumerate(actions):
        _, _, terminated, truncated, _ = env.step(action)
        first[(first < 0) & terminated] = step
        if ((first >= 0) | truncated).all():
            break
    return first


@dataclass(frozen=True)
class Drives:
    """Open-loop drives from seeded resets: first contacts, and the scans and poses early on.

    ``first``: each world's first-contact step (-1: none); ``laser`` and ``root``: its scans and
    free-joint poses on the reset and the ``laser_steps`` steps after it (``(laser_steps + 1, n,
    rays)`` and ``(laser_steps + 1, n, 7)``); rows after a world's first contact are not its
    episode's, and comparisons leave them out.
    """

    first: NDArray[np.int64]
    laser: NDArray[np.float32]
    root: NDArray[np.float64]


def warp_drives(
    env: WarpVectorEnv, seeds: list[int], actions: NDArray[np.float32], laser_steps: int
) -> Drives:
    """:func:`first_contacts`, keeping the scans and poses of the first ``laser_steps`` steps."""
    obs, _ = env.reset(seed=seeds)
    adr = env.scene.root_qpos
    lasers, roots = [obs["laser"]], [env.worlds.data.qpos.numpy()[:, adr : adr + 7].copy()]
    first = np.full(len(seeds), -1, dtype=np.int64)
    for step, action in enumerate(actions):
        obs, _, terminated, truncated, _ = env.step(action)
        if step < laser_steps:
            lasers.append(obs["laser"])
            roots.append(env.worlds.data.qpos.numpy()[:, adr : adr + 7].copy())
        first[(first < 0) & terminated] = step
        if step >= laser_steps and ((first >= 0) | truncated).all():
            break
    return Drives(first, np.stack(lasers), np.stack(roots).astype(np.float64))


def cpu_drives(
    seeds: list[int], actions: NDArray[np.float32], laser_steps: int, **kwargs: Any
) -> Drives:
    """The same drives in ``gym.make``'s env, one env per world (the CPU batch's episodes)."""
    n = len(seeds)
    first = np.full(n, -1, dtype=np.int64)
    lasers = np.zeros((laser_steps + 1, n, 0), dtype=np.float32)
    roots = np.zeros((laser_steps + 1, n, 7))
    for i, seed in enumerate(seeds):
        env = gym.make("BubbleRob-v0", **kwargs)
        obs, _ = env.reset(seed=seed)
        if lasers.shape[2] == 0:
            lasers = np.zeros((laser_steps + 1, n, obs["laser"].size), dtype=np.float32)
        scene = env.unwrapped.scene  # type: ignore[attr-defined]
        adr = scene.root_qpos
        lasers[0, i], roots[0, i] = obs["laser"], scene.data.qpos[adr : adr + 7]
        for step in range(actions.shape[0]):
            obs, _, terminated, truncated, _ = env.step(actions[step, i])
            if step < laser_steps:
                lasers[step + 1, i], roots[step + 1, i] = (
                    obs["laser"],
                    scene.data.qpos[adr : adr + 7],
                )
            if terminated:
                first[i] = step
            if terminated or truncated:
                break
        env.close()
    return Drives(first, lasers, roots)


def ray_on_state(scene: Any, root: NDArray[np.float64], ray: int, turn: float = 0.0) -> float:
    """``mj_ray`` of laser ray ``ray`` (turned by ``turn`` rad) with the robot at ``root``.

    ``scene``: a CPU env's scene reset with the world's seed (its obstacles); ``root``: the
    free joint's seven numbers. The reading as the env reports it (``range_max`` for a miss).
    """
    model = scene.model
    data = mujoco.MjData(model)
    data.qpos[:] = scene.data.qpos
    data.mocap_pos[:], data.mocap_quat[:] = scene.data.mocap_pos, scene.data.mocap_quat
    adr = scene.root_qpos
    data.qpos[adr : adr + 7] = root
    mujoco.mj_kinematics(model, data)
    site = model.site(names.LASER_SITE).id
    spec = scene.laser_spec
    angle = float(spec.angles()[ray]) + turn
    direction = data.site_xmat[site].reshape(3, 3) @ np.array([math.cos(angle), math.sin(angle), 0])
    group = np.zeros(mujoco.mjNGROUP, dtype=np.uint8)
    group[names.OBSTACLE_GROUP] = 1
    geomid = np.zeros(1, dtype=np.int32)
    dist = mujoco.mj_ray(model, data, data.site_xpos[site], direction, group, 1, -1, geomid)
    return float(dist) if 0 <= dist < spec.range_max else float(spec.range_max)


def heading(root: NDArray[np.float64]) -> NDArray[np.float64]:
    """The yaw of free-joint poses (x, y, z, w, qx, qy, qz), any leading shape."""
    w, x, y, z = root[..., 3], root[..., 4], root[..., 5], root[..., 6]
    return np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def grazing(
    scene: Any,
    warp_root: NDArray[np.float64],
    cpu_root: NDArray[np.float64],
    ray: int,
    warp_reading: float,
    tolerance: float = 0.01,
) -> bool:
    """Whether a ray the backends read apart grazes an edge, within the two poses' difference.

    True when turning the ray on the CPU env's state by at most twice the backends' heading
    difference (and at least 1e-5 rad) gives the warp reading within ``tolerance``: the two
    readings lie on either side of an edge (or along a surface the ray runs nearly parallel
    to), which the backends' pose drift and float32 ray arithmetic decide either way.
    """
    gap = float(np.abs(np.angle(np.exp(1j * (heading(warp_root) - heading(cpu_root))))))
    turn = max(1e-5, 2 * gap)
    turns = (-turn, -turn / 10, -turn / 100, turn / 100, turn / 10, turn)
    return any(
        abs(ray_on_state(scene, cpu_root, ray, t) - warp_reading) <= tolerance for t in turns
    )
