"""The kernel's step called with one argument: a table of its arrays' addresses and sizes.

Numba turns every array argument of a call into a native array on each call (a reference-count
record allocated and freed per array): :func:`~bubblerob_env.core.kernel.step_robots` takes 18
arrays, which cost the single env about as much per step as a quarter of its Python. Here the
arrays are given once, by address (:func:`step_table`), and :func:`step_packed` rebuilds them as
views (``numba.carray``) before calling :func:`~bubblerob_env.core.kernel.step_robots` itself:
the same compiled step, the same arithmetic, bit for bit.
"""

from __future__ import annotations

from enum import IntEnum

import numpy as np
from numba import njit
from numba.np.numpy_support import carray
from numpy.typing import NDArray

from bubblerob_env.core.kernel import (
    CFG_SIZE,
    ICFG_SIZE,
    OUT_SIZE,
    PTR_SIZE,
    Outputs,
    RobotState,
    Settings,
    Tables,
    step_robots,
)
from bubblerob_env.core.mjabi import as_pointer

__all__ = ["PACK", "PACK_SIZE", "step_packed", "step_table"]


class PACK(IntEnum):
    """Slots of :func:`step_packed`'s table (uint64): the arrays' addresses, then their sizes."""

    ROBOTS, PTRS, ACTIONS, ICFG, CFG, IS_OBSTACLE, GEOM_TYPE, LOCAL_DIRS, GEOMGROUP = range(9)
    CAST_GEOMS, NOISE, DIRS, DIST, GEOMID, LASER, PROXIMITY, VELOCITY, OUT = range(9, 18)
    NUM_STEPPED, NUM_ROBOTS, NGEOM, NRAY, NCAST, NGROUP = range(18, 24)


PACK_SIZE = 24


def step_table(
    robots: NDArray[np.int64],
    ptrs: NDArray[np.uint64],
    actions: NDArray[np.float64],
    settings: Settings,
    tables: Tables,
    state: RobotState,
    outputs: Outputs,
) -> NDArray[np.uint64]:
    """The table of :func:`~bubblerob_env.core.kernel.step_robots`'s arguments.

    The arrays must outlive the table and stay where they are (written in place, never
    replaced or resized); a ``ValueError`` if one is not C-contiguous or of the kernel's dtype.
    """
    n, nray = ptrs.shape[0], state[1].shape[1]
    arrays: list[tuple[PACK, NDArray[np.generic], type, tuple[int, ...]]] = [
        (PACK.ROBOTS, robots, np.int64, robots.shape),
        (PACK.PTRS, ptrs, np.uint64, (n, PTR_SIZE)),
        (PACK.ACTIONS, actions, np.float64, (n, 2)),
        (PACK.ICFG, settings[0], np.int64, (ICFG_SIZE,)),
        (PACK.CFG, settings[1], np.float64, (CFG_SIZE,)),
        (PACK.IS_OBSTACLE, tables[0], np.uint8, tables[0].shape),
        (PACK.GEOM_TYPE, tables[1], np.int32, tables[0].shape),
        (PACK.LOCAL_DIRS, tables[2], np.float64, (nray, 3)),
        (PACK.GEOMGROUP, tables[3], np.uint8, tables[3].shape),
        (PACK.CAST_GEOMS, state[0], np.int32, (n, state[0].shape[1])),
        (PACK.NOISE, state[1], np.float64, (n, nray)),
        (PACK.DIRS, state[2], np.float64, (n, nray, 3)),
        (PACK.DIST, state[3], np.float64, (n, nray)),
        (PACK.GEOMID, state[4], np.int32, (n, nray)),
        (PACK.LASER, outputs[0], np.float32, (n, nray)),
        (PACK.PROXIMITY, outputs[1], np.float32, (n, 1)),
        (PACK.VELOCITY, outputs[2], np.float32, (n, 2)),
        (PACK.OUT, outputs[3], np.float64, (n, OUT_SIZE)),
    ]
    table = np.zeros(PACK_SIZE, dtype=np.uint64)
    for slot, array, dtype, shape in arrays:
        if array.dtype != dtype or array.shape != shape or not array.flags.c_contiguous:
            raise ValueError(
                f"{slot.name.lower()}: expected a C-contiguous {np.dtype(dtype)} array of shape "
                f"{shape}, got {array.dtype} {array.shape}"
            )
        table[slot] = array.ctypes.data
    if robots.size and not 0 <= robots.min() <= robots.max() < n:
        raise ValueError(f"robots must be indices below {n}, got {robots.tolist()}")
    sizes = (robots.size, n, tables[0].shape[0], nray, state[0].shape[1], tables[3].shape[0])
    table[PACK.NUM_STEPPED :] = sizes
    return table


@njit(cache=True, nogil=True)
def step_packed(table: NDArray[np.uint64]) -> None:  # pragma: no cover - numba
    """:func:`~bubblerob_env.core.kernel.step_robots` of the arrays in ``table``."""
    n, ngeom = int(table[PACK.NUM_ROBOTS]), int(table[PACK.NGEOM])
    nray, ncast = int(table[PACK.NRAY]), int(table[PACK.NCAST])
    robots = carray(as_pointer(table[PACK.ROBOTS]), int(table[PACK.NUM_STEPPED]), np.int64)
    ptrs = carray(as_pointer(table[PACK.PTRS]), (n, PTR_SIZE), np.uint64)
    actions = carray(as_pointer(table[PACK.ACTIONS]), (n, 2), np.float64)
    settings = (
        carray(as_pointer(table[PACK.ICFG]), ICFG_SIZE, np.int64),
        carray(as_pointer(table[PACK.CFG]), CFG_SIZE, np.float64),
    )
    tables = (
        carray(as_pointer(table[PACK.IS_OBSTACLE]), ngeom, np.uint8),
        carray(as_pointer(table[PACK.GEOM_TYPE]), ngeom, np.int32),
        carray(as_pointer(table[PACK.LOCAL_DIRS]), (nray, 3), np.float64),
        carray(as_pointer(table[PACK.GEOMGROUP]), int(table[PACK.NGROUP]), np.uint8),
    )
    state = (
        carray(as_pointer(table[PACK.CAST_GEOMS]), (n, ncast), np.int32),
        carray(as_pointer(table[PACK.NOISE]), (n, nray), np.float64),
        carray(as_pointer(table[PACK.DIRS]), (n, nray, 3), np.float64),
        carray(as_pointer(table[PACK.DIST]), (n, nray), np.float64),
        carray(as_pointer(table[PACK.GEOMID]), (n, nray), np.int32),
    )
    outputs = (
        carray(as_pointer(table[PACK.LASER]), (n, nray), np.float32),
        carray(as_pointer(table[PACK.PROXIMITY]), (n, 1), np.float32),
        carray(as_pointer(table[PACK.VELOCITY]), (n, 2), np.float32),
        carray(as_pointer(table[PACK.OUT]), (n, OUT_SIZE), np.float64),
    )
    step_robots(robots, ptrs, actions, settings, tables, state, outputs)
