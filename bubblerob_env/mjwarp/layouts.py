"""Arena layouts as device tables: one row per seed, drawn by the CPU env's own reset.

Row ``k`` of a :class:`LayoutTable` holds what ``gym.make("BubbleRob-v0")`` reset with seed
``seeds[k]`` puts into MuJoCo: every obstacle slot's mocap pose (used or parked), the slot geoms'
sizes and bounding spheres, and the free joint's start pose. The rows are made by the CPU env's
own layout placement (:meth:`~bubblerob_env.scene.Scene.place_layout`) on a scene of the same
config, with the generator a seeded reset makes, so a world reset from row ``k`` has the CPU
env's arena for that seed, in float32.

Resets on the device copy rows into the worlds being reset (:mod:`bubblerob_env.mjwarp.kernels`):
a seeded ``reset`` writes one row per world, and autoresets draw rows from a bank made once per
seeded reset (:class:`~bubblerob_env.mjwarp.vector.WarpVectorEnv`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import warp as wp
from gymnasium.utils import seeding
from numpy.typing import NDArray

from bubblerob_env.scene import Scene

__all__ = ["LayoutTable", "slot_geoms"]


def slot_geoms(scene: Scene) -> NDArray[np.int32]:
    """The geom ids of ``scene``'s obstacle slots, in the order a table's size columns hold them."""
    return np.array(scene.slots.geom_ids, dtype=np.int32)


class LayoutTable:
    """The layouts of ``seeds`` on ``device``, placed in ``scene`` (a CPU env's) for each."""

    def __init__(self, scene: Scene, seeds: Sequence[int], device: wp.Device) -> None:
        geoms = slot_geoms(scene)
        root = scene.root_qpos
        model, data = scene.model, scene.data
        n, nmocap = len(seeds), model.nmocap
        pos = np.zeros((n, nmocap, 3), dtype=np.float32)
        quat = np.zeros((n, nmocap, 4), dtype=np.float32)
        size = np.zeros((n, geoms.size, 3), dtype=np.float32)
        rbound = np.zeros((n, geoms.size), dtype=np.float32)
        start = np.zeros((n, 7), dtype=np.float32)
        for k, seed in enumerate(seeds):
            # The layout and state of a seeded reset, without the observation (5x faster).
            scene.place_layout(seeding.np_random(int(seed))[0])
            if scene.config.start_pose is not None:  # as the reset, check that it is free
                scene.forward()
            pos[k], quat[k] = data.mocap_pos, data.mocap_quat
            size[k], rbound[k] = model.geom_size[geoms], model.geom_rbound[geoms]
            start[k] = data.qpos[root : root + 7]
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
