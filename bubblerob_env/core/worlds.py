"""Worlds of several robots: one control step of M worlds x N robots in one GIL-free call.

In a world every robot drives in the same ``mjData``: each robot's wheel commands go in, the
physics substeps run once for the world, a contact check after each substep flags every robot
that touches a wall, an obstacle or another robot (and which), then each robot senses and gets
its reward. A robot's row of the address table (:class:`~bubblerob_env.core.kernel.PTR`) points
at its own slices of ``ctrl``, ``sensordata`` and ``qpos`` and its own laser site, so the single
robot's compiled pieces (:func:`~bubblerob_env.core.kernel.observe`, ``readings``, ``reward``,
``wheel_command``) run unchanged: a world of one robot steps bit for bit as the single env.

The laser sees walls, obstacles and the other robots' laser windows (cylinders on their base
bodies): the analytic caster casts the static prisms as the single env does and the windows with
MuJoCo's exact ``ray_cylinder`` (:func:`~bubblerob_env.core.raycast.cast_cylinders`);
``mj_multiRay`` excludes the robot's own body. Robot ``k`` of world ``w`` is row ``w * N + k`` of
every per-robot array.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple

import mujoco
import numpy as np
from numba import njit
from numba.np.numpy_support import carray
from numpy.typing import NDArray

from bubblerob_env.config import EnvConfig
from bubblerob_env.core.batch import RobotBatch, RobotScene
from bubblerob_env.core.kernel import (
    CFG,
    ICFG,
    OUT,
    PTR,
    Outputs,
    RobotState,
    Settings,
    Tables,
    observe,
    readings,
    reward,
    wheel_command,
)
from bubblerob_env.core.mjabi import MJ_MULTIRAY, MJ_STEP1, MJ_STEP2, as_pointer
from bubblerob_env.core.raycast import cast_cylinders, cast_prisms, world_rays

# numba caches this file's functions by this file's text alone, and they contain the raycast
# and mjabi functions they call: edit this line whenever those change, or a cache made before
# keeps the old code (last: raycast's nearest geoms first, 2026-11-28).

__all__ = ["NO_CONTACT", "OBSTACLE_CONTACT", "RobotIds", "WorldBatch", "WorldTables"]

NO_CONTACT = -1
"""``partner``: the robot touched nothing this step."""
OBSTACLE_CONTACT = -2
"""``partner``: the robot touched a wall or an obstacle (else: the other robot's index)."""

_BUFFERS = ("actions", "noise", "cast_geoms", "laser", "proximity", "velocity", "out")
WorldTables = tuple[NDArray[np.int32], NDArray[np.int32], NDArray[np.int32], NDArray[np.uint8]]
"""Per geom its robot (-1: the world's); per robot its base body and the other robots' laser
windows (-1 padded); the laser's geom group mask for ``mj_multiRay``."""


class RobotIds(NamedTuple):
    """Where robot ``k`` of a world is in the model (the same in every world)."""

    base_body: int
    root_qpos: int
    """Address of its free joint in ``qpos``."""
    laser_site: int
    actuator: int
    """Its left motor's index in ``ctrl`` (the right motor's is the next)."""
    sensor_shift: int
    """Its sensors' offset in ``sensordata`` from robot 0's (same sensors, same order)."""
    window: int
    """Its laser window geom (-1: none)."""


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
def _touch(k: int, other: int, alive: NDArray[np.uint8], partner: NDArray[np.int32]) -> None:
    # pragma: no cover - numba; the first thing a live robot touches this step is its partner
    if other != NO_CONTACT and other != k and alive[k] and partner[k] == NO_CONTACT:
        partner[k] = other


@njit(cache=True, nogil=True)
def _contacts(
    data: int,
    icfg: NDArray[np.int64],
    is_obstacle: NDArray[np.uint8],
    geom_robot: NDArray[np.int32],
    alive: NDArray[np.uint8],
    partner: NDArray[np.int32],
) -> None:  # pragma: no cover - numba
    """Flag each live robot in a contact with a wall, an obstacle or another robot."""
    ncon = _i32(data + icfg[ICFG.NCON], 1)[0]
    if ncon == 0:
        return
    base = _u64(data + icfg[ICFG.CONTACT]) + icfg[ICFG.CONTACT_GEOM]
    stride = icfg[ICFG.CONTACT_SIZE]
    for c in range(ncon):
        geoms = _i32(base + c * stride, 2)
        g1, g2 = geoms[0], geoms[1]
        r1, r2 = geom_robot[g1], geom_robot[g2]
        if r1 >= 0:
            _touch(
                r1, r2 if r2 >= 0 else (OBSTACLE_CONTACT if is_obstacle[g2] else -1), alive, partner
            )
        if r2 >= 0:
            _touch(
                r2, r1 if r1 >= 0 else (OBSTACLE_CONTACT if is_obstacle[g1] else -1), alive, partner
            )


@njit(cache=True, nogil=True)
def _warned(warnings: int, stride: int, index: int) -> bool:  # pragma: no cover - numba
    return bool(_i32(warnings + index * stride, 1)[0] != 0)


@njit(cache=True, nogil=True)
def _world_physics(
    ptrs: NDArray[np.uint64],
    icfg: NDArray[np.int64],
    is_obstacle: NDArray[np.uint8],
    geom_robot: NDArray[np.int32],
    alive: NDArray[np.uint8],
    partner: NDArray[np.int32],
    out: NDArray[np.float64],
) -> None:  # pragma: no cover - numba
    """The world's substeps, each followed by the contact check; its warnings into every row."""
    model, data = as_pointer(ptrs[0, PTR.MODEL]), as_pointer(ptrs[0, PTR.DATA])
    for _ in range(icfg[ICFG.SUBSTEPS]):
        MJ_STEP2(model, data)
        MJ_STEP1(model, data)
        _contacts(ptrs[0, PTR.DATA], icfg, is_obstacle, geom_robot, alive, partner)
    warnings, stride = ptrs[0, PTR.WARNINGS], icfg[ICFG.WARNING_STRIDE]
    diverged = 0.0  # 1 + the index of the first of BADQACC, BADQPOS, BADQVEL raised
    for code, index in enumerate((icfg[ICFG.BADQACC], icfg[ICFG.BADQPOS], icfg[ICFG.BADQVEL])):
        if diverged == 0.0 and _warned(warnings, stride, index):
            diverged = code + 1.0
    full = _warned(warnings, stride, icfg[ICFG.CONTACTFULL]) or _warned(
        warnings, stride, icfg[ICFG.CNSTRFULL]
    )
    time = _f64(ptrs[0, PTR.DATA] + icfg[ICFG.TIME], 1)[0]
    for k in range(partner.shape[0]):
        row = out[k]
        row[OUT.COLLISION] = 1.0 if partner[k] != NO_CONTACT else 0.0
        row[OUT.DIVERGED] = diverged
        row[OUT.ARENA_FULL] = 1.0 if full else 0.0
        row[OUT.SIM_TIME] = time


@njit(cache=True, nogil=True)
def _cast_analytic(
    row: NDArray[np.uint64],
    pnt: NDArray[np.float64],
    xmat: NDArray[np.float64],
    dirs: NDArray[np.float64],
    cfg: NDArray[np.float64],
    prisms: NDArray[np.int32],
    windows: NDArray[np.int32],
    geom_type: NDArray[np.int32],
    dist: NDArray[np.float64],
) -> None:  # pragma: no cover - numba
    """The static prisms as the single env casts them, then the other robots' windows."""
    ngeom = geom_type.shape[0]
    geom_xpos = _f64(row[PTR.GEOM_XPOS], 3 * ngeom).reshape((ngeom, 3))
    geom_xmat = _f64(row[PTR.GEOM_XMAT], 9 * ngeom).reshape((ngeom, 9))
    geom_size = _f64(row[PTR.GEOM_SIZE], 3 * ngeom).reshape((ngeom, 3))
    geom_rbound = _f64(row[PTR.GEOM_RBOUND], ngeom)
    fan = (cfg[CFG.ANGLE_MIN], cfg[CFG.ANGLE_INCREMENT], cfg[CFG.FULL_CIRCLE] != 0.0)
    cast_prisms(
        pnt, xmat, dirs, fan[0], fan[1], fan[2], cfg[CFG.RANGE_MAX], prisms, geom_type,
        geom_xpos, geom_xmat, geom_size, geom_rbound, dist,
    )  # fmt: skip
    cast_cylinders(
        pnt, xmat, dirs, fan[0], fan[1], fan[2], cfg[CFG.RANGE_MAX], windows,
        geom_xpos, geom_xmat, geom_size, geom_rbound, dist,
    )  # fmt: skip


@njit(cache=True, nogil=True)
def _sense(
    i: int,
    k: int,
    ptrs: NDArray[np.uint64],
    settings: Settings,
    tables: Tables,
    world_tables: WorldTables,
    state: RobotState,
    outputs: Outputs,
) -> float:  # pragma: no cover - numba
    """Robot ``i`` (robot ``k`` of its world) senses; returns the clearance cost's reading."""
    icfg, cfg = settings
    _, geom_type, local_dirs, _ = tables
    _, bodies, windows, geomgroup = world_tables
    cast_geoms, noise, dirs, dist, geomid = state
    laser, proximity, velocity, out = outputs
    row = ptrs[i]
    observe(row, icfg, cfg, proximity[i], velocity[i], out[i])
    if not icfg[ICFG.LASER]:
        return float(proximity[i, 0])
    pnt = _f64(row[PTR.SITE_XPOS], 3)
    xmat = _f64(row[PTR.SITE_XMAT], 9)
    world_rays(local_dirs, xmat, dirs[i])
    if icfg[ICFG.ANALYTIC]:
        count = 0
        while count < cast_geoms.shape[1] and cast_geoms[i, count] >= 0:
            count += 1
        _cast_analytic(
            row, pnt, xmat, dirs[i], cfg, cast_geoms[i, :count], windows[k], geom_type, dist[i]
        )
    else:
        MJ_MULTIRAY(
            as_pointer(row[PTR.MODEL]),
            as_pointer(row[PTR.DATA]),
            as_pointer(pnt.ctypes.data),
            as_pointer(dirs[i].ctypes.data),
            as_pointer(geomgroup.ctypes.data),
            np.uint8(1),
            np.int32(bodies[k]),
            as_pointer(geomid[i].ctypes.data),
            as_pointer(dist[i].ctypes.data),
            as_pointer(0),
            np.int32(local_dirs.shape[0]),
            cfg[CFG.RANGE_MAX],
        )
    return readings(dist[i], noise[i], icfg[ICFG.NOISE] != 0, cfg, laser[i])


@njit(cache=True, nogil=True)
def step_worlds(
    worlds: NDArray[np.int64],
    ptrs: NDArray[np.uint64],
    actions: NDArray[np.float64],
    alive: NDArray[np.uint8],
    partner: NDArray[np.int32],
    settings: Settings,
    tables: Tables,
    world_tables: WorldTables,
    state: RobotState,
    outputs: Outputs,
) -> None:  # pragma: no cover - numba
    """One control step of ``worlds``: stopped robots (``alive`` 0) get wheel commands 0."""
    icfg, cfg = settings
    out, velocity = outputs[3], outputs[2]
    n = world_tables[1].shape[0]
    for w in worlds:
        first = w * n
        for i in range(first, first + n):
            row = out[i]
            ctrl = _f64(ptrs[i, PTR.CTRL], 2)
            if alive[i]:
                wheel_command(actions[i], cfg, icfg[ICFG.TWIST] != 0, row)
                ctrl[0], ctrl[1] = row[OUT.WHEEL_COMMAND], row[OUT.WHEEL_COMMAND + 1]
            else:
                ctrl[0] = ctrl[1] = 0.0
            partner[i] = NO_CONTACT
        last = first + n
        _world_physics(
            ptrs[first:last],
            icfg,
            tables[0],
            world_tables[0],
            alive[first:last],
            partner[first:last],
            out[first:last],
        )
        for k in range(n):
            i = first + k
            if alive[i]:
                nearest = _sense(i, k, ptrs, settings, tables, world_tables, state, outputs)
                reward(nearest, velocity[i], cfg, out[i])


@njit(cache=True, nogil=True)
def observe_worlds(
    robots: NDArray[np.int64],
    ptrs: NDArray[np.uint64],
    settings: Settings,
    tables: Tables,
    world_tables: WorldTables,
    state: RobotState,
    outputs: Outputs,
) -> None:  # pragma: no cover - numba
    """The sensors and ``info`` numbers of ``robots`` (rows) as they are, after a reset."""
    icfg = settings[0]
    n = world_tables[1].shape[0]
    for i in robots:
        outputs[3][i, OUT.SIM_TIME] = _f64(ptrs[i, PTR.DATA] + icfg[ICFG.TIME], 1)[0]
        _sense(i, i % n, ptrs, settings, tables, world_tables, state, outputs)


class WorldBatch:
    """Kernel inputs and outputs of ``scenes`` (worlds) of ``config`` with ``robots`` each.

    ``geom_robot``: each geom's robot index in its world (-1: the world's); ``window_group``:
    the laser windows' geom group (``None``: no windows, one robot a world).
    ``core``: the :class:`RobotBatch` whose buffers hold every robot's row (``laser``,
    ``proximity``, ``velocity``, ``out``, ``noise``, ``actions``).
    """

    def __init__(
        self,
        config: EnvConfig,
        scenes: Sequence[RobotScene],
        robots: Sequence[RobotIds],
        geom_robot: NDArray[np.int32],
        window_group: int | None,
    ) -> None:
        n = len(robots)
        self.robots_per_world = n
        self.core = RobotBatch(config, [scene for scene in scenes for _ in range(n)])
        self.alive = np.ones(len(scenes) * n, dtype=np.uint8)
        self.partner = np.full(len(scenes) * n, NO_CONTACT, dtype=np.int32)
        windows = np.full((n, max(1, n - 1)), -1, dtype=np.int32)
        for k in range(n):
            others = [robot.window for j, robot in enumerate(robots) if j != k]
            windows[k, : len(others)] = others
        geomgroup = self.core.tables[3].copy()
        if window_group is not None:
            geomgroup[window_group] = 1
        self.world_tables: WorldTables = (
            geom_robot.astype(np.int32),
            np.array([robot.base_body for robot in robots], dtype=np.int32),
            windows,
            geomgroup,
        )
        for w, scene in enumerate(scenes):
            for k, robot in enumerate(robots):
                self.bind(w * n + k, scene.model, scene.data, robot)

    def bind(self, i: int, model: mujoco.MjModel, data: mujoco.MjData, robot: RobotIds) -> None:
        """Point row ``i`` at ``robot``'s slices of this model and data."""
        row = self.core.ptrs[i]
        row[PTR.MODEL], row[PTR.DATA] = model._address, data._address
        for column, array in (
            (PTR.CTRL, data.ctrl[robot.actuator :]),
            (PTR.SENSORDATA, data.sensordata[robot.sensor_shift :]),
            (PTR.QPOS, data.qpos[robot.root_qpos :]),
            (PTR.WARNINGS, data.warning.number),
            (PTR.SITE_XPOS, data.site_xpos[robot.laser_site]),
            (PTR.SITE_XMAT, data.site_xmat[robot.laser_site]),
            (PTR.GEOM_XPOS, data.geom_xpos),
            (PTR.GEOM_XMAT, data.geom_xmat),
            (PTR.GEOM_SIZE, model.geom_size),
            (PTR.GEOM_RBOUND, model.geom_rbound),
        ):
            row[column] = array.ctypes.data

    def buffers(self) -> dict[str, NDArray[Any]]:
        """Copies of the state a step reads and writes besides MuJoCo's (for pickling)."""
        arrays = {name: getattr(self.core, name) for name in _BUFFERS}
        arrays.update(alive=self.alive, partner=self.partner)
        return {name: array.copy() for name, array in arrays.items()}

    def restore(self, buffers: dict[str, NDArray[Any]]) -> None:
        """Write :meth:`buffers` of another batch of the same worlds into this one."""
        for name in _BUFFERS:
            getattr(self.core, name)[...] = buffers[name]
        self.alive[...] = buffers["alive"]
        self.partner[...] = buffers["partner"]

    def start(self, rows: NDArray[np.int64], model: mujoco.MjModel) -> None:
        """``rows`` just reset (in worlds of ``model``): readings, no step's numbers; alive."""
        core = self.core
        for i in rows.tolist():
            core.refresh_geoms(i, model)
        observe_worlds(
            rows, core.ptrs, core.settings, core.tables, self.world_tables, core.state, core.outputs
        )
        out = core.out
        out[rows, OUT.COLLISION] = out[rows, OUT.CLIPPED] = 0.0
        out[rows, OUT.WHEEL_COMMAND : OUT.WHEEL_COMMAND + 2] = 0.0
        out[rows, OUT.REWARD : OUT.COLLISION_COST + 1] = 0.0
        self.alive[rows] = 1
        self.partner[rows] = NO_CONTACT

    def step(self, worlds: NDArray[np.int64]) -> None:
        """One control step of ``worlds`` with the actions in ``core.actions`` (GIL released)."""
        core = self.core
        step_worlds(
            worlds,
            core.ptrs,
            core.actions,
            self.alive,
            self.partner,
            core.settings,
            core.tables,
            self.world_tables,
            core.state,
            core.outputs,
        )
