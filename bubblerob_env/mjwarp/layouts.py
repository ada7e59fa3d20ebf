"""Arena layouts as device tables: one row per seed, the CPU env's arena for that seed.

Row ``k`` of a :class:`LayoutTable` holds what ``gym.make("BubbleRob-v0")`` reset with seed
``seeds[k]`` puts into MuJoCo: every obstacle slot's mocap pose (used or parked), the slot geoms'
sizes and bounding spheres, and the free joint's start pose, in float32. The CPU env draws its
layout with numpy's seeded ``Generator`` (:func:`~bubblerob_env.arena.sample_layout`) and writes
it with :meth:`~bubblerob_env.scene.Scene.place_layout`; :mod:`~bubblerob_env.mjwarp.layout_draw`
does both for many seeds at once in numba, draw for draw (0.39 ms a seed in Python: 26 s for
65,536 worlds; a few microseconds in numba). tests/warp holds the rows to the CPU env's resets.

Parked slots (below the floor, out of every ray's and contact's reach) keep the scene's compiled
sizes; the CPU env's keep whatever sizes their last use left, which nothing can tell apart.

Resets on the device copy rows into the worlds being reset (:mod:`bubblerob_env.mjwarp.kernels`):
a seeded ``reset`` writes one row per world, and autoresets draw rows from a bank made once per
seeded reset (:class:`~bubblerob_env.mjwarp.vector.WarpVectorEnv`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import warp as wp
from numpy.typing import NDArray

from bubblerob_env.mjwarp.layout_draw import draw_layouts, fill_rows
from bubblerob_env.scene import Scene

__all__ = ["LayoutTable", "layout_rows", "slot_geoms"]


def slot_geoms(scene: Scene) -> NDArray[np.int32]:
    """The geom ids of ``scene``'s obstacle slots, in the order a table's size columns hold them."""
    return np.array(scene.slots.geom_ids, dtype=np.int32)


class LayoutTable:
    """The layouts of ``seeds`` on ``device``, placed in ``scene`` (a CPU env's) for each."""

    def __init__(
        self, scene: Scene, seeds: Sequence[int] | NDArray[np.int64], device: wp.Device
    ) -> None:
        pos, quat, size, rbound, start = layout_rows(scene, seeds)
        self.seeds = np.asarray(seeds, dtype=np.int64)
        self.start_poses = start
        """Each row's free-joint pose (x, y, z, quaternion w, x, y, z), float32."""
        self.pos: wp.array[Any] = wp.array(pos, dtype=wp.vec3, device=device)
        self.quat: wp.array[Any] = wp.array(quat, dtype=wp.quat, device=device)
        self.size: wp.array[Any] = wp.array(size, dtype=wp.vec3, device=device)
        self.rbound: wp.array[Any] = wp.array(rbound, dtype=float, device=device)
        self.root: wp.array[Any] = wp.array(start, dtype=float, device=device)

    def __len__(self) -> int:
        return int(self.seeds.size)


def layout_rows(
    scene: Scene, seeds: Sequence[int] | NDArray[np.int64]
) -> tuple[NDArray[np.float32], ...]:
    """The rows of ``seeds`` on the host, float32, as a :class:`LayoutTable` holds them.

    Mocap positions ``(n, nmocap, 3)`` and quaternions ``(n, nmocap, 4)``, slot sizes ``(n,
    slots, 3)`` and bounding radii ``(n, slots)``, start poses ``(n, 7)``.

    ``scene`` must never have been reset (its slots keep their compiled sizes: the parked ones').
    """
    config, model = scene.config, scene.model
    seeds = np.asarray(seeds, dtype=np.int64).reshape(-1)
    drawn = draw_layouts(
        seeds,
        config.arena_size,
        config.num_obstacles,
        config.obstacle_size,
        config.start_clearance,
        config.start_pose,
        config.robot.radius,
    )
    if config.start_pose is not None and seeds.size:  # the CPU env's reset checks it is free
        scene.place_robot(config.start_pose)
        scene.forward()
    n, geoms = seeds.size, slot_geoms(scene)
    mocap_bodies = np.flatnonzero(model.body_mocapid >= 0)
    order = model.body_mocapid[mocap_bodies]  # mj_resetData: each mocap at its body's pose
    rest_pos = np.zeros((model.nmocap, 3))
    rest_quat = np.zeros((model.nmocap, 4))
    rest_pos[order], rest_quat[order] = model.body_pos[mocap_bodies], model.body_quat[mocap_bodies]
    pos = np.repeat(rest_pos[None].astype(np.float32), n, axis=0)
    quat = np.repeat(rest_quat[None].astype(np.float32), n, axis=0)
    size = np.repeat(model.geom_size[geoms][None].astype(np.float32), n, axis=0)
    rbound = np.repeat(model.geom_rbound[geoms][None].astype(np.float32), n, axis=0)
    start = np.zeros((n, 7), dtype=np.float32)
    mocaps = np.array([mocap for _, mocap, _ in scene.slots.slots], dtype=np.int64)
    fill_rows(
        drawn.count,
        drawn.kind,
        drawn.pose,
        drawn.size,
        drawn.start,
        mocaps,
        scene.slots.half_height,
        *_start_height_and_tilt(scene),
        pos,
        quat,
        size,
        rbound,
        start,
    )
    return pos, quat, size, rbound, start


def _start_height_and_tilt(scene: Scene) -> tuple[float, NDArray[np.float64]]:
    """The free joint's height and tilt quaternion where ``place_robot`` puts the robot at yaw 0.

    At yaw ``a`` it puts it at the same height with the quaternion ``(cos a/2, 0, 0, sin a/2)``
    times this tilt, which :func:`~bubblerob_env.mjwarp.layout_draw.fill_rows` multiplies out.
    """
    scene.place_robot((0.0, 0.0, 0.0))
    adr = scene.root_qpos
    qpos = scene.data.qpos
    return float(qpos[adr + 2]), qpos[adr + 3 : adr + 7].astype(np.float64)
