"""Arena layouts as device tables: one row per seed, drawn by the CPU env's own reset.

Row ``k`` of a :class:`LayoutTable` holds what ``gym.make("BubbleRob-v0")`` reset with seed
``seeds[k]`` puts into MuJoCo: every obstacle slot's mocap pose (used or parked), the slot geoms'
sizes and bounding spheres, and the free joint's start pose. The rows are made by resetting a
CPU env of the same kwargs (its :func:`~bubblerob_env.arena.sample_layout`, its slot writer), so
a world reset from row ``k`` has the CPU env's arena for that seed, in float32.

Resets on the device copy rows into the worlds being reset (:mod:`bubblerob_env.mjwarp.kernels`):
a seeded ``reset`` writes one row per world, and autoresets draw rows from a bank made once per
seeded reset (:class:`~bubblerob_env.mjwarp.vector.WarpVectorEnv`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import warp as wp
from numpy.typing import NDArray

from bubblerob_env import names

if TYPE_CHECKING:
    from bubblerob_env.env import BubbleRobEnv

__all__ = ["LayoutTable", "slot_geoms"]


def slot_geoms(env: BubbleRobEnv) -> NDArray[np.int32]:
    """The geom ids of ``env``'s obstacle slots, in the order a table's size columns hold them."""
    return np.array(env._slots.geom_ids, dtype=np.int32)


class LayoutTable:
    """The layouts of ``seeds`` on ``device``, made by resetting ``env`` (a CPU env) with each."""

    def __init__(self, env: BubbleRobEnv, seeds: Sequence[int], device: wp.Device) -> None:
        geoms = slot_geoms(env)
        root = int(env.model.joint(names.ROOT_JOINT).qposadr[0])
        n, nmocap = len(seeds), env.model.nmocap
        pos = np.zeros((n, nmocap, 3), dtype=np.float32)
        quat = np.zeros((n, nmocap, 4), dtype=np.float32)
        size = np.zeros((n, geoms.size, 3), dtype=np.float32)
        rbound = np.zeros((n, geoms.size), dtype=np.float32)
        start = np.zeros((n, 7), dtype=np.float32)
        for k, seed in enumerate(seeds):
            if env.start_pose is not None:  # the full reset checks it is free
                env.reset(seed=int(seed))
            else:  # the same layout and state, without the observation (5x faster)
                env._place_layout(int(seed))
            pos[k], quat[k] = env.data.mocap_pos, env.data.mocap_quat
            size[k], rbound[k] = env.model.geom_size[geoms], env.model.geom_rbound[geoms]
            start[k] = env.data.qpos[root : root + 7]
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
