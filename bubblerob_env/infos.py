"""``info`` from the kernel's numbers: one robot's dict, or a whole batch's dict of arrays.

The single env and the batch build ``info`` here, from the same columns of
:class:`~bubblerob_env.core.batch.RobotBatch`'s results, so a batch row equals the single env's
``info`` key for key and type for type (``tests/test_vector_env.py`` compares them).
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from bubblerob_env.core.kernel import OUT

__all__ = ["Results", "batched_step_info", "robot_info", "robot_step_info", "row_info"]


class Results(Protocol):
    """Where the numbers come from.

    The kernel's :class:`~bubblerob_env.core.batch.RobotBatch`, or the MuJoCo Warp backend's
    host copy of its device arrays (:class:`~bubblerob_env.mjwarp.device.HostCopy`).
    """

    @property
    def out(self) -> NDArray[np.float64]:
        """Per robot, the :class:`~bubblerob_env.core.kernel.OUT` columns."""

    @property
    def proximity(self) -> NDArray[np.float32]:
        """Per robot, the proximity reading ``(n, 1)``."""


# (key, first column, width): width 0 is a float scalar, a width an array of that many floats.
_FLOAT_COLUMNS = (
    ("sim_time", int(OUT.SIM_TIME), 0),
    ("x", int(OUT.POSITION), 0),
    ("y", int(OUT.POSITION + 1), 0),
    ("yaw", int(OUT.YAW), 0),
    ("position", int(OUT.POSITION), 3),
    ("quaternion_wxyz", int(OUT.QUATERNION), 4),
    ("body_twist", int(OUT.TWIST), 6),
    ("wheel_speeds", int(OUT.WHEEL_SPEEDS), 2),
    ("wheel_command", int(OUT.WHEEL_COMMAND), 2),
)
_COLLISION, _CLIPPED = int(OUT.COLLISION), int(OUT.CLIPPED)  # plain ints index faster
_REWARD_COLUMNS = (
    ("reward_forward", int(OUT.FORWARD)),
    ("reward_spin", int(OUT.SPIN)),
    ("reward_clearance", int(OUT.CLEARANCE)),
    ("reward_collision", int(OUT.COLLISION_COST)),
)


# The same columns as ints and slices, for the literal that builds one robot's dict (a dict
# display with constant keys is what CPython builds fastest; the single env builds one a step).
_SIM_TIME, _X, _Y, _YAW = (column for _, column, _ in _FLOAT_COLUMNS[:4])
_POSITION, _QUATERNION, _TWIST, _WHEELS, _COMMAND = (
    slice(column, column + width) for _, column, width in _FLOAT_COLUMNS[4:]
)
_FORWARD, _SPIN, _CLEARANCE, _COLLISION_COST = (column for _, column in _REWARD_COLUMNS)


def robot_info(
    core: Results,
    i: int,
    trigger_distance: float,
    clipped_actions: int,
    odometry: NDArray[np.float64],
) -> dict[str, Any]:
    """Robot ``i``'s ``info`` without ``is_success`` (what a reset returns, and a step's base).

    ``odometry``: every robot's odometry ``(x, y, yaw)`` (``Odometry.poses``).
    """
    row = core.out[i].copy()  # one copy: the array keys are views into it
    proximity = float(core.proximity[i, 0])
    return row_info(
        row, row.tolist(), odometry[i].tolist(), proximity, trigger_distance, clipped_actions
    )


def row_info(
    row: NDArray[np.float64],
    values: list[float],
    odometry: list[float],
    proximity: float,
    trigger_distance: float,
    clipped_actions: int,
) -> dict[str, Any]:
    """:func:`robot_info` from what the caller already has (the single env's step).

    ``row``: a copy of the robot's :class:`~bubblerob_env.core.kernel.OUT` columns (the array
    keys are views into it), ``values`` the same as a list; ``odometry`` its odometry
    ``[x, y, yaw]``, ``proximity`` its proximity reading.
    """
    return {
        "sim_time": values[_SIM_TIME],
        "x": values[_X],
        "y": values[_Y],
        "yaw": values[_YAW],
        "position": row[_POSITION],
        "quaternion_wxyz": row[_QUATERNION],
        "body_twist": row[_TWIST],
        "wheel_speeds": row[_WHEELS],
        "wheel_command": row[_COMMAND],
        "odom_x": odometry[0],
        "odom_y": odometry[1],
        "odom_yaw": odometry[2],
        "collision": values[_COLLISION] != 0.0,
        "proximity_triggered": bool(proximity < trigger_distance),
        "action_clipped": values[_CLIPPED] != 0.0,
        "clipped_actions": clipped_actions,
        "reward_forward": values[_FORWARD],
        "reward_spin": values[_SPIN],
        "reward_clearance": values[_CLEARANCE],
        "reward_collision": values[_COLLISION_COST],
    }


def robot_step_info(
    core: Results,
    i: int,
    trigger_distance: float,
    collided: bool,
    clipped_actions: int,
    diverged: dict[int, str],
    odometry: NDArray[np.float64],
) -> dict[str, Any]:
    """Robot ``i``'s ``info`` after a step: ``is_success`` so far, and a divergence's reason."""
    info = robot_info(core, i, trigger_distance, clipped_actions, odometry)
    info["is_success"] = not (collided or i in diverged)
    if i in diverged:
        info["physics_diverged"] = diverged[i]
    return info


def batched_step_info(
    core: Results,
    trigger_distance: float,
    collided: NDArray[np.bool_],
    clipped_actions: NDArray[np.int64],
    diverged: dict[int, str],
    resets: dict[int, dict[str, Any]],
    odometry: NDArray[np.float64],
) -> dict[str, Any]:
    """Every robot's step ``info`` as Gymnasium's dict of arrays with ``_key`` masks.

    Robots in ``resets`` (reset in this step) get their reset ``info`` instead, which has no
    ``is_success``: as :func:`~bubblerob_env.vector.collate_infos` collates it.
    """
    # One copy of the results; every float key is a view into it (cheaper than a copy a key).
    out = core.out.copy()
    n = out.shape[0]
    info: dict[str, Any] = {}
    for key, column, width in _FLOAT_COLUMNS:
        info[key] = out[:, column] if width == 0 else out[:, column : column + width]
    odometry = odometry.copy()
    info["odom_x"], info["odom_y"], info["odom_yaw"] = (
        odometry[:, 0],
        odometry[:, 1],
        odometry[:, 2],
    )
    info["collision"] = out[:, _COLLISION] != 0.0
    info["proximity_triggered"] = core.proximity[:, 0].astype(np.float64) < trigger_distance
    info["action_clipped"] = out[:, _CLIPPED] != 0.0
    info["clipped_actions"] = clipped_actions.copy()
    for key, column in _REWARD_COLUMNS:
        info[key] = out[:, column]
    success = ~collided
    for i, reset_info in resets.items():
        for key, value in reset_info.items():
            info[key][i] = value
    success_known = np.ones(n, dtype=bool)
    success_known[list(resets)] = False
    success_known_copy = success_known.copy()
    success &= success_known
    success[list(diverged)] = False
    info["is_success"] = success
    masks = {key: np.ones(n, dtype=bool) for key in info}
    masks["is_success"] = success_known_copy
    if diverged:
        reasons = np.full(n, "", dtype=object)
        present = np.zeros(n, dtype=bool)
        for i, reason in diverged.items():
            reasons[i], present[i] = reason, True
        info["physics_diverged"], masks["physics_diverged"] = reasons, present
    return {
        part: value for key in info for part, value in ((key, info[key]), (f"_{key}", masks[key]))
    }
