"""One control step of many robots in one GIL-free call: physics, contacts, sensors, reward.

:func:`step_robots` does for each robot what ``BubbleRobEnv.step`` did in Python: the wheel
commands from the action, ``physics_substeps`` times ``mj_step2`` + ``mj_step1`` (so kinematics,
contacts and sensors are those of the final state) with a contact check after every substep, the
laser (the analytic caster, or ``mj_multiRay``), proximity, velocity, the reward and its parts,
and the numbers ``info`` holds. It reads and writes each robot's ``mjData`` through addresses
(:mod:`bubblerob_env.core.mjabi`), so a thread share of robots costs one call and one release of
the GIL. Every number is computed with the same IEEE operations, in the same order, as the Python
step it replaces, so results are bit-for-bit those of that code. :func:`step_packed` is the
same step with its arrays given by address, for callers that step the same robots every call
(the single env).
"""

from __future__ import annotations

import math
from enum import IntEnum

import mujoco
import numpy as np
from numba import njit
from numba.np.numpy_support import carray
from numpy.typing import NDArray

from bubblerob_env.core.mjabi import (
    MJ_MULTIRAY,
    MJ_STEP1,
    MJ_STEP2,
    as_pointer,
    set_timer_callback,
    timer_callback,
)
from bubblerob_env.core.raycast import cast_prisms, world_rays

# numba caches this file's functions by this file's text alone, and they contain the raycast
# and mjabi functions they call: edit this line whenever those change, or a cache made before
# keeps the old code (last: raycast's nearest geoms first, 2026-11-28).

__all__ = [
    "CFG",
    "CFG_SIZE",
    "ICFG",
    "ICFG_SIZE",
    "OUT",
    "OUT_SIZE",
    "PACK",
    "PACK_SIZE",
    "PTR",
    "PTR_SIZE",
    "Outputs",
    "RobotState",
    "Settings",
    "Tables",
    "observe",
    "observe_robots",
    "readings",
    "reward",
    "step_packed",
    "step_robots",
    "wheel_command",
]


class PTR(IntEnum):
    """Columns of the per-robot address table (uint64)."""

    MODEL, DATA, CTRL, SENSORDATA, QPOS, WARNINGS = 0, 1, 2, 3, 4, 5
    SITE_XPOS, SITE_XMAT, GEOM_XPOS, GEOM_XMAT, GEOM_SIZE, GEOM_RBOUND = 6, 7, 8, 9, 10, 11
    DISABLEFLAGS = 12  # the model's opt.disableflags (0: leave them alone)


PTR_SIZE = 13
_SENSORS_OFF = int(mujoco.mjtDisableBit.mjDSBL_SENSOR)


class ICFG(IntEnum):
    """Integer settings shared by every robot of a batch (int64)."""

    SUBSTEPS, TWIST, NCON, TIME, CONTACT, CONTACT_SIZE, CONTACT_GEOM = 0, 1, 2, 3, 4, 5, 6
    VELOCITY_ADR, GYRO_ADR, WHEEL_ADR, PROXIMITY_ADR, WARNING_STRIDE = 7, 8, 9, 11, 12
    BADQACC, BADQPOS, BADQVEL, CONTACTFULL, CNSTRFULL = 13, 14, 15, 16, 17
    LASER, ANALYTIC, NOISE, NSENSORDATA = 18, 19, 20, 21


ICFG_SIZE = 22


class CFG(IntEnum):
    """Float settings shared by every robot of a batch (float64)."""

    MAX_WHEEL, MAX_LINEAR, MAX_ANGULAR, WHEEL_RADIUS, WHEEL_SEPARATION = 0, 1, 2, 3, 4
    RANGE_MAX, ANGLE_MIN, ANGLE_INCREMENT, FULL_CIRCLE, PROXIMITY_MAX = 5, 6, 7, 8, 9
    VELOCITY_LIMIT_LINEAR, VELOCITY_LIMIT_ANGULAR = 10, 11
    FORWARD_WEIGHT, SPIN_WEIGHT, CLEARANCE_WEIGHT, CLEARANCE_DISTANCE, HULL = 12, 13, 14, 15, 16
    COLLISION_PENALTY, NOISY_CEILING = 17, 18


CFG_SIZE = 19


class OUT(IntEnum):
    """Columns of the per-robot float64 results."""

    REWARD, FORWARD, SPIN, CLEARANCE, COLLISION_COST = 0, 1, 2, 3, 4
    COLLISION, DIVERGED, ARENA_FULL, CLIPPED, SIM_TIME = 5, 6, 7, 8, 9
    POSITION, QUATERNION, YAW, TWIST, WHEEL_SPEEDS, WHEEL_COMMAND = 10, 13, 17, 18, 24, 26


OUT_SIZE = 28


class PACK(IntEnum):
    """Slots of :func:`step_packed`'s table (uint64): the arrays' addresses, then their sizes."""

    ROBOTS, PTRS, ACTIONS, ICFG, CFG, IS_OBSTACLE, GEOM_TYPE, LOCAL_DIRS, GEOMGROUP = range(9)
    CAST_GEOMS, NOISE, DIRS, DIST, GEOMID, LASER, PROXIMITY, VELOCITY, OUT = range(9, 18)
    NUM_STEPPED, NUM_ROBOTS, NGEOM, NRAY, NCAST, NGROUP = range(18, 24)


PACK_SIZE = 24


@njit(cache=True, nogil=True)
def _f64(address: int, n: int) -> NDArray[np.float64]:  # pragma: no cover - numba
    return carray(as_pointer(address), n, np.float64)


@njit(cache=True, nogil=True)
def _i32(address: int, n: int) -> NDArray[np.int32]:  # pragma: no cover - numba
    return carray(as_pointer(address), n, np.int32)


@njit(cache=True, nogil=True)
def _u64(address: int) -> int:  # pragma: no cover - numba
    return int(carray(as_pointer(address), 1, np.uint64)[0])


@njit(cache=True, nogil=True)
def _wheel_command(
    action: NDArray[np.float64], cfg: NDArray[np.float64], twist: bool, out: NDArray[np.float64]
) -> None:  # pragma: no cover - numba
    """Clip the action to [-1, 1] and scale it into wheel speed targets (``env._command``)."""
    a0, a1 = action[0], action[1]
    c0, c1 = min(1.0, max(-1.0, a0)), min(1.0, max(-1.0, a1))
    out[OUT.CLIPPED] = 1.0 if (c0 != a0 or c1 != a1) else 0.0
    if not twist:
        limit = cfg[CFG.MAX_WHEEL]
        out[OUT.WHEEL_COMMAND], out[OUT.WHEEL_COMMAND + 1] = c0 * limit, c1 * limit
        return
    # DiffDrive.wheel_speeds
    linear, angular = c0 * cfg[CFG.MAX_LINEAR], c1 * cfg[CFG.MAX_ANGULAR]
    half_track = cfg[CFG.WHEEL_SEPARATION] / 2.0
    left = (linear - angular * half_track) / cfg[CFG.WHEEL_RADIUS]
    right = (linear + angular * half_track) / cfg[CFG.WHEEL_RADIUS]
    peak = max(abs(left), abs(right))
    if peak > cfg[CFG.MAX_WHEEL]:
        scale = cfg[CFG.MAX_WHEEL] / peak
        left, right = left * scale, right * scale
    out[OUT.WHEEL_COMMAND], out[OUT.WHEEL_COMMAND + 1] = left, right


@njit(cache=True, nogil=True)
def _touching(
    data: int, icfg: NDArray[np.int64], is_obstacle: NDArray[np.uint8]
) -> bool:  # pragma: no cover - numba
    """Whether any current contact involves a wall or obstacle geom (``env._in_collision``)."""
    ncon = _i32(data + icfg[ICFG.NCON], 1)[0]
    if ncon == 0:
        return False
    base = _u64(data + icfg[ICFG.CONTACT]) + icfg[ICFG.CONTACT_GEOM]
    stride = icfg[ICFG.CONTACT_SIZE]
    for k in range(ncon):
        geoms = _i32(base + k * stride, 2)
        if is_obstacle[geoms[0]] or is_obstacle[geoms[1]]:
            return True
    return False


@njit(cache=True, nogil=True)
def _warned(warnings: int, stride: int, index: int) -> bool:  # pragma: no cover - numba
    return bool(_i32(warnings + index * stride, 1)[0] != 0)


@njit(cache=True, nogil=True)
def _physics(
    ptrs: NDArray[np.uint64],
    icfg: NDArray[np.int64],
    is_obstacle: NDArray[np.uint8],
    out: NDArray[np.float64],
) -> None:  # pragma: no cover - numba
    """Substeps with a contact check after each; divergence and arena warnings.

    Only the final state's sensors are read, and nothing in MuJoCo's dynamics reads sensors, so
    the substeps before the last run with the model's sensors off (its ``disableflags`` as
    they were, plus ``mjDSBL_SENSOR``; restored for the last substep): the same states, and
    the same sensor values at the end.
    """
    model, data = as_pointer(ptrs[PTR.MODEL]), as_pointer(ptrs[PTR.DATA])
    flags = _i32(ptrs[PTR.DISABLEFLAGS], 1) if ptrs[PTR.DISABLEFLAGS] else np.zeros(1, np.int32)
    kept = flags[0]
    collision = False
    substeps = icfg[ICFG.SUBSTEPS]
    for k in range(substeps):
        flags[0] = kept | _SENSORS_OFF if k < substeps - 1 else kept
        MJ_STEP2(model, data)
        MJ_STEP1(model, data)
        collision = collision or _touching(ptrs[PTR.DATA], icfg, is_obstacle)
    flags[0] = kept
    out[OUT.COLLISION] = 1.0 if collision else 0.0
    warnings, stride = ptrs[PTR.WARNINGS], icfg[ICFG.WARNING_STRIDE]
    diverged = 0.0  # 1 + the index of the first of BADQACC, BADQPOS, BADQVEL raised
    for code, index in enumerate((icfg[ICFG.BADQACC], icfg[ICFG.BADQPOS], icfg[ICFG.BADQVEL])):
        if diverged == 0.0 and _warned(warnings, stride, index):
            diverged = code + 1.0
    out[OUT.DIVERGED] = diverged
    full = _warned(warnings, stride, icfg[ICFG.CONTACTFULL]) or _warned(
        warnings, stride, icfg[ICFG.CNSTRFULL]
    )
    out[OUT.ARENA_FULL] = 1.0 if full else 0.0
    out[OUT.SIM_TIME] = _f64(ptrs[PTR.DATA] + icfg[ICFG.TIME], 1)[0]


@njit(cache=True, nogil=True)
def _scan(
    ptrs: NDArray[np.uint64],
    icfg: NDArray[np.int64],
    cfg: NDArray[np.float64],
    geoms: NDArray[np.int32],
    geom_type: NDArray[np.int32],
    ngeom: int,
    local_dirs: NDArray[np.float64],
    geomgroup: NDArray[np.uint8],
    dirs: NDArray[np.float64],
    dist: NDArray[np.float64],
    geomid: NDArray[np.int32],
) -> None:  # pragma: no cover - numba
    """Raw ray distances (-1: no hit) from the laser site, analytic or by ``mj_multiRay``."""
    nray = local_dirs.shape[0]
    pnt = _f64(ptrs[PTR.SITE_XPOS], 3)
    xmat = _f64(ptrs[PTR.SITE_XMAT], 9)
    world_rays(local_dirs, xmat, dirs)
    if icfg[ICFG.ANALYTIC]:
        cast_prisms(
            pnt,
            xmat,
            dirs,
            cfg[CFG.ANGLE_MIN],
            cfg[CFG.ANGLE_INCREMENT],
            cfg[CFG.FULL_CIRCLE] != 0.0,
            cfg[CFG.RANGE_MAX],
            geoms,
            geom_type,
            _f64(ptrs[PTR.GEOM_XPOS], 3 * ngeom).reshape((ngeom, 3)),
            _f64(ptrs[PTR.GEOM_XMAT], 9 * ngeom).reshape((ngeom, 9)),
            _f64(ptrs[PTR.GEOM_SIZE], 3 * ngeom).reshape((ngeom, 3)),
            _f64(ptrs[PTR.GEOM_RBOUND], ngeom),
            dist,
        )
        return
    MJ_MULTIRAY(
        as_pointer(ptrs[PTR.MODEL]),
        as_pointer(ptrs[PTR.DATA]),
        as_pointer(pnt.ctypes.data),
        as_pointer(dirs.ctypes.data),
        as_pointer(geomgroup.ctypes.data),
        np.uint8(1),
        np.int32(-1),
        as_pointer(geomid.ctypes.data),
        as_pointer(dist.ctypes.data),
        as_pointer(0),
        np.int32(nray),
        cfg[CFG.RANGE_MAX],
    )


@njit(cache=True, nogil=True)
def _readings(
    dist: NDArray[np.float64],
    noise: NDArray[np.float64],
    noisy: bool,
    cfg: NDArray[np.float64],
    laser: NDArray[np.float32],
) -> float:  # pragma: no cover
    """``Laser.finish``: no hit reads range_max, noise on hits; returns the nearest reading."""
    range_max = cfg[CFG.RANGE_MAX]
    nearest = np.inf
    for r in range(dist.shape[0]):
        d = dist[r]
        hit = d >= 0.0 and d < range_max
        reading = d if hit else range_max
        if noisy and hit:
            reading = min(max(reading + noise[r], 0.0), cfg[CFG.NOISY_CEILING])
        value = np.float32(reading)
        laser[r] = value
        nearest = min(nearest, float(value))
    return nearest


@njit(cache=True, nogil=True)
def _observe(
    ptrs: NDArray[np.uint64],
    icfg: NDArray[np.int64],
    cfg: NDArray[np.float64],
    proximity: NDArray[np.float32],
    velocity: NDArray[np.float32],
    out: NDArray[np.float64],
) -> None:  # pragma: no cover - numba
    """Proximity, velocity and the pose, twist and wheel numbers of ``info``."""
    sensordata = _f64(ptrs[PTR.SENSORDATA], icfg[ICFG.NSENSORDATA])
    reach = sensordata[icfg[ICFG.PROXIMITY_ADR]]
    if reach < 0.0 or reach > cfg[CFG.PROXIMITY_MAX]:
        reach = cfg[CFG.PROXIMITY_MAX]
    proximity[0] = np.float32(reach)
    limit_v, limit_w = cfg[CFG.VELOCITY_LIMIT_LINEAR], cfg[CFG.VELOCITY_LIMIT_ANGULAR]
    forward = sensordata[icfg[ICFG.VELOCITY_ADR]]
    yaw_rate = sensordata[icfg[ICFG.GYRO_ADR] + 2]
    velocity[0] = np.float32(min(max(forward, -limit_v), limit_v))
    velocity[1] = np.float32(min(max(yaw_rate, -limit_w), limit_w))
    for j in range(3):
        out[OUT.TWIST + j] = sensordata[icfg[ICFG.VELOCITY_ADR] + j]
        out[OUT.TWIST + 3 + j] = sensordata[icfg[ICFG.GYRO_ADR] + j]
    out[OUT.WHEEL_SPEEDS] = sensordata[icfg[ICFG.WHEEL_ADR]]
    out[OUT.WHEEL_SPEEDS + 1] = sensordata[icfg[ICFG.WHEEL_ADR + 1]]
    pose = _f64(ptrs[PTR.QPOS], 7)
    for j in range(7):
        out[OUT.POSITION + j] = pose[j]
    w, x, y, z = pose[3], pose[4], pose[5], pose[6]
    out[OUT.YAW] = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


@njit(cache=True, nogil=True)
def _reward(
    nearest: float,
    velocity: NDArray[np.float32],
    cfg: NDArray[np.float64],
    out: NDArray[np.float64],
) -> None:  # pragma: no cover - numba
    """The reward parts and their sum, as ``env.step`` adds them."""
    forward = cfg[CFG.FORWARD_WEIGHT] * float(velocity[0]) / cfg[CFG.MAX_LINEAR]
    spin = -cfg[CFG.SPIN_WEIGHT] * abs(float(velocity[1])) / cfg[CFG.MAX_ANGULAR]
    distance = cfg[CFG.CLEARANCE_DISTANCE]
    closeness = min(1.0, max(0.0, (distance - nearest) / (distance - cfg[CFG.HULL])))
    clearance = -cfg[CFG.CLEARANCE_WEIGHT] * closeness
    collision = -cfg[CFG.COLLISION_PENALTY] if out[OUT.COLLISION] != 0.0 else 0.0
    out[OUT.FORWARD], out[OUT.SPIN], out[OUT.CLEARANCE] = forward, spin, clearance
    out[OUT.COLLISION_COST] = collision
    out[OUT.REWARD] = 0.0 + forward + spin + clearance + collision


Tables = tuple[NDArray[np.uint8], NDArray[np.int32], NDArray[np.float64], NDArray[np.uint8]]
"""Per geom: is it a wall or obstacle, its type; the rays' local directions; the group mask."""
Settings = tuple[NDArray[np.int64], NDArray[np.float64]]
"""The integer and float settings (:class:`ICFG`, :class:`CFG`)."""
RobotState = tuple[
    NDArray[np.int32],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.int32],
]
"""Per robot: its laser-visible geoms (padded with -1), its laser noise for this scan, and
scratch rows of ray directions, distances and geom ids."""
Outputs = tuple[NDArray[np.float32], NDArray[np.float32], NDArray[np.float32], NDArray[np.float64]]
"""Per robot: laser, proximity and velocity readings, and the :class:`OUT` columns."""


@njit(cache=True, nogil=True)
def step_robots(
    robots: NDArray[np.int64],
    ptrs: NDArray[np.uint64],
    actions: NDArray[np.float64],
    settings: Settings,
    tables: Tables,
    state: RobotState,
    outputs: Outputs,
) -> None:  # pragma: no cover - numba
    """Step ``robots`` (indices into every per-robot array) by one control step each.

    MuJoCo's profiling timers are off meanwhile: its clock callback (``mjcb_time``, which the
    Python bindings set to a steady clock) is read about 15 times a substep, 5% of the single
    env's step, and only ``mjData.timer`` holds what it measures, which nothing here reads; no
    state, sensor or contact depends on it. The callback is put back after the step. A call
    that finds it already off (another thread's step, or the user's choice) leaves it off, so
    concurrent steps never leave it off for good; while a step runs, MuJoCo called from other
    threads is not timed.
    """
    icfg, cfg = settings
    out, velocity = outputs[3], outputs[2]
    timer = timer_callback()
    if timer:
        set_timer_callback(0)
    for i in robots:
        row = out[i]
        _wheel_command(actions[i], cfg, icfg[ICFG.TWIST] != 0, row)
        ctrl = _f64(ptrs[i, PTR.CTRL], 2)
        ctrl[0], ctrl[1] = row[OUT.WHEEL_COMMAND], row[OUT.WHEEL_COMMAND + 1]
        _physics(ptrs[i], icfg, tables[0], row)
        nearest = _sense(i, ptrs, settings, tables, state, outputs)
        _reward(nearest, velocity[i], cfg, row)
    if timer:
        set_timer_callback(timer)


@njit(cache=True, nogil=True)
def observe_robots(
    robots: NDArray[np.int64],
    ptrs: NDArray[np.uint64],
    settings: Settings,
    tables: Tables,
    state: RobotState,
    outputs: Outputs,
) -> None:  # pragma: no cover - numba
    """The sensors and ``info`` numbers of ``robots`` in their current state (after a reset)."""
    icfg = settings[0]
    for i in robots:
        outputs[3][i, OUT.SIM_TIME] = _f64(ptrs[i, PTR.DATA] + icfg[ICFG.TIME], 1)[0]
        _sense(i, ptrs, settings, tables, state, outputs)


@njit(cache=True, nogil=True)
def _sense(
    i: int,
    ptrs: NDArray[np.uint64],
    settings: Settings,
    tables: Tables,
    state: RobotState,
    outputs: Outputs,
) -> float:  # pragma: no cover - numba
    """Robot ``i``'s observation; returns the reading the clearance cost uses."""
    icfg, cfg = settings
    is_obstacle, geom_type, local_dirs, geomgroup = tables
    cast_geoms, noise, dirs, dist, geomid = state
    laser, proximity, velocity, out = outputs
    _observe(ptrs[i], icfg, cfg, proximity[i], velocity[i], out[i])
    if not icfg[ICFG.LASER]:
        return float(proximity[i, 0])
    count = 0
    while count < cast_geoms.shape[1] and cast_geoms[i, count] >= 0:
        count += 1
    _scan(
        ptrs[i],
        icfg,
        cfg,
        cast_geoms[i, :count],
        geom_type,
        is_obstacle.shape[0],
        local_dirs,
        geomgroup,
        dirs[i],
        dist[i],
        geomid[i],
    )
    return _readings(dist[i], noise[i], icfg[ICFG.NOISE] != 0, cfg, laser[i])


@njit(cache=True, nogil=True)
def step_packed(table: NDArray[np.uint64]) -> None:  # pragma: no cover - numba
    """:func:`step_robots` of the arrays whose addresses and sizes are in ``table`` (:class:`PACK`).

    Numba turns every array argument into a native array on each call (a reference-count
    record allocated and freed per array): 18 for :func:`step_robots`, which cost the single
    env as much as a quarter of its Python. Here they are views (``carray``) of the addresses in
    one table (``core.batch.step_table``), and the step is :func:`step_robots` itself: the same
    arithmetic, bit for bit. It lives in this file because numba's cache of a function goes
    stale only when the function's own file changes.
    """
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


# The parts of one robot's step that robots sharing a world reuse (core/worlds.py): the same
# compiled functions, so a world of one robot steps bit for bit as the single env.
wheel_command = _wheel_command
observe = _observe
readings = _readings
reward = _reward
