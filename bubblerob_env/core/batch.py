"""The Python side of the kernel: each robot's addresses, the shared settings, the buffers.

A :class:`RobotBatch` is built from an env config and one or more scenes of it
(:class:`~bubblerob_env.scene.Scene`; a single env is a batch of one). It owns the arrays
:func:`~bubblerob_env.core.kernel.step_robots` reads and writes; the env and the batches turn
the results into observations and ``info``. :func:`kernel_settings` are the kernel's settings
of a config and scene (the MuJoCo Warp backend reads them too).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from typing import Any, Protocol

import mujoco
import numpy as np
from numba.core.dispatcher import Dispatcher
from numpy.typing import NDArray

from bubblerob_env import names
from bubblerob_env.config import EnvConfig, SpeedLimits
from bubblerob_env.core.kernel import (
    CFG,
    CFG_SIZE,
    ICFG,
    ICFG_SIZE,
    OUT,
    OUT_SIZE,
    PACK,
    PACK_SIZE,
    PTR,
    PTR_SIZE,
    Outputs,
    RobotState,
    Settings,
    Tables,
    observe_robots,
    step_packed,
    step_robots,
)
from bubblerob_env.core.mjabi import data_layout, disableflags_address
from bubblerob_env.core.raycast import GEOM_BOX, GEOM_CYLINDER
from bubblerob_env.sensors import LaserSpec, ProximitySpec

__all__ = [
    "RobotBatch",
    "RobotScene",
    "analytic_unsupported",
    "kernel_settings",
    "laser_geoms",
    "step_table",
]

_UPRIGHT_TOLERANCE = 1e-9
_WARNINGS = mujoco.mjtWarning


def laser_geoms(model: mujoco.MjModel) -> NDArray[np.int32]:
    """Geoms the laser may see: those in the laser's group (as ``mj_multiRay`` clamps groups)."""
    groups = np.clip(model.geom_group, 0, mujoco.mjNGROUP - 1)
    return np.flatnonzero(groups == names.OBSTACLE_GROUP).astype(np.int32)


def analytic_unsupported(
    model: mujoco.MjModel, data: mujoco.MjData, slot_geoms: Sequence[int]
) -> list[str]:
    """Why the analytic caster cannot stand in for ``mj_multiRay`` here (empty: it can).

    It models boxes and cylinders that are vertical prisms (local z axis vertical) and never
    tilt: geoms of the world body or of static bodies, and the env's own obstacle slots, which
    only turn about z. ``data`` must hold a state after ``mj_forward``.
    """
    problems = []
    slots = set(slot_geoms)
    for geom in laser_geoms(model).tolist():
        name = model.geom(geom).name or f"geom {geom}"
        kind = int(model.geom_type[geom])
        if kind not in (GEOM_BOX, GEOM_CYLINDER):
            problems.append(f"{name} is a {mujoco.mjtGeom(kind).name[7:].lower()}")
        elif geom not in slots and model.body_weldid[model.geom_bodyid[geom]] != 0:
            problems.append(f"{name} is on a moving body")
        elif abs(abs(float(data.geom_xmat[geom][8])) - 1.0) > _UPRIGHT_TOLERANCE:
            problems.append(f"{name} is not upright")
    return problems


class RobotScene(Protocol):
    """What the kernel reads of a scene (:class:`~bubblerob_env.scene.Scene`)."""

    @property
    def model(self) -> mujoco.MjModel:
        """The compiled model."""

    @property
    def data(self) -> mujoco.MjData:
        """The robot's data."""

    @property
    def laser_spec(self) -> LaserSpec | None:
        """The laser (``None``: none)."""

    @property
    def proximity_spec(self) -> ProximitySpec:
        """The nose sensor."""

    @property
    def limits(self) -> SpeedLimits:
        """The drive and the twist limits."""

    @property
    def analytic(self) -> bool:
        """Whether the analytic caster runs the laser."""


class RobotBatch:
    """Kernel inputs and outputs for ``scenes`` of ``config``, robot ``i`` being ``scenes[i]``.

    ``tables``: the read-only tables of another batch of the same config, to share (default:
    made from the first scene).
    """

    def __init__(
        self,
        config: EnvConfig,
        scenes: Sequence[RobotScene],
        tables: Tables | None = None,
    ) -> None:
        first = scenes[0]
        n = len(scenes)
        spec = first.laser_spec
        nray = spec.num_rays if spec is not None else 0
        self.ptrs = np.zeros((n, PTR_SIZE), dtype=np.uint64)
        self.icfg, self.cfg = kernel_settings(config, first)
        model = first.model
        # Read-only tables of the model and the laser: robots with the same settings share them.
        self.tables = tables if tables is not None else _tables(model, spec)
        self._laser_geoms = laser_geoms(model)
        self.cast_geoms = np.full((n, max(1, self._laser_geoms.size)), -1, dtype=np.int32)
        self.noise = np.zeros((n, nray))
        self.actions = np.zeros((n, 2))
        self.laser = np.zeros((n, nray), dtype=np.float32)
        self.proximity = np.zeros((n, 1), dtype=np.float32)
        self.velocity = np.zeros((n, 2), dtype=np.float32)
        self.out = np.zeros((n, OUT_SIZE))
        self.settings: Settings = (self.icfg, self.cfg)
        self.state: RobotState = (
            self.cast_geoms,
            self.noise,
            np.zeros((n, nray, 3)),  # scratch: ray directions, distances, geom ids
            np.zeros((n, nray)),
            np.zeros((n, nray), np.int32),
        )
        self.outputs: Outputs = (self.laser, self.proximity, self.velocity, self.out)
        self.all_robots = np.arange(n, dtype=np.int64)
        for i, scene in enumerate(scenes):
            self.bind(i, scene.model, scene.data)

    def bind(self, i: int, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Point robot ``i`` at this model and data (after building or unpickling them)."""
        site = model.site(names.LASER_SITE).id
        root = int(model.joint(names.ROOT_JOINT).qposadr[0])
        row = self.ptrs[i]
        row[PTR.MODEL], row[PTR.DATA] = model._address, data._address
        row[PTR.DISABLEFLAGS] = disableflags_address(model)
        for column, array in (
            (PTR.CTRL, data.ctrl),
            (PTR.SENSORDATA, data.sensordata),
            (PTR.QPOS, data.qpos[root:]),
            (PTR.WARNINGS, data.warning.number),
            (PTR.SITE_XPOS, data.site_xpos[site]),
            (PTR.SITE_XMAT, data.site_xmat[site]),
            (PTR.GEOM_XPOS, data.geom_xpos),
            (PTR.GEOM_XMAT, data.geom_xmat),
            (PTR.GEOM_SIZE, model.geom_size),
            (PTR.GEOM_RBOUND, model.geom_rbound),
        ):
            row[column] = array.ctypes.data

    def refresh_geoms(self, i: int, model: mujoco.MjModel) -> None:
        """Robot ``i``'s laser-visible geoms, as ``mj_multiRay`` culls invisible ones (alpha 0)."""
        geoms = self._laser_geoms
        matid = model.geom_matid[geoms]
        material_alpha = model.mat_rgba[np.maximum(matid, 0), 3]
        alpha = np.where(matid >= 0, material_alpha, model.geom_rgba[geoms, 3])
        visible = geoms[alpha != 0]
        self.cast_geoms[i, :] = -1
        self.cast_geoms[i, : visible.size] = visible

    def start(self, i: int, model: mujoco.MjModel) -> None:
        """Robot ``i`` just reset (``model``: its model): its readings, no step's numbers.

        Its laser-visible geoms, then its sensors and ``info`` numbers as they are, with the
        columns only a step sets (collision, clipping, wheel command, reward parts) zeroed.
        """
        self.refresh_geoms(i, model)
        self.observe(np.array([i], dtype=np.int64))
        row = self.out[i]
        row[OUT.COLLISION] = row[OUT.CLIPPED] = 0.0
        row[OUT.WHEEL_COMMAND : OUT.WHEEL_COMMAND + 2] = 0.0
        row[OUT.REWARD : OUT.COLLISION_COST + 1] = 0.0

    def step(self, robots: NDArray[np.int64]) -> None:
        """One control step of ``robots`` with the actions in ``self.actions`` (GIL released)."""
        step_robots(
            robots, self.ptrs, self.actions, self.settings, self.tables, self.state, self.outputs
        )

    def stepper(self, robots: NDArray[np.int64]) -> Callable[[], None]:
        """:meth:`step` of ``robots`` as a call without arguments (the single env's step).

        For a caller that steps the same robots every time. Numba's dispatcher types every
        argument again on each call, and turns each of the 18 arrays into a native one: this
        binds the compiled step once (loaded from numba's cache, or compiled, now) to a table
        of the arrays' addresses (:func:`step_table`, :func:`.kernel.step_packed`). The call
        keeps this batch and ``robots`` alive; their arrays are written in place, never
        replaced.
        """
        table = step_table(
            robots, self.ptrs, self.actions, self.settings, self.tables, self.state, self.outputs
        )
        call = functools.partial(compiled(step_packed, (table,)), table)
        call.keepalive = (self, robots)  # type: ignore[attr-defined]
        return call

    def observe(self, robots: NDArray[np.int64]) -> None:
        """Sensors and ``info`` numbers of ``robots`` as they are (after a reset)."""
        observe_robots(robots, self.ptrs, self.settings, self.tables, self.state, self.outputs)


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


def compiled(function: Dispatcher, args: tuple[Any, ...]) -> Callable[..., Any]:
    """The machine code numba runs for ``function(*args)``, without its per-call type dispatch.

    Only for arguments of exactly these types (numba checks nothing when it is called).
    """
    signature = tuple(function.typeof_pyval(arg) for arg in args)
    function.compile(signature)  # nothing to do once compiled; else from numba's cache
    entry: Callable[..., Any] = function.overloads[signature].entry_point  # type: ignore[attr-defined]
    return entry


def _tables(model: mujoco.MjModel, spec: LaserSpec | None) -> Tables:
    """``is_obstacle`` and ``geom_type`` per geom, the rays' local directions, the group mask."""
    is_obstacle = (model.geom_group == names.OBSTACLE_GROUP).astype(np.uint8)
    geomgroup = np.zeros(mujoco.mjNGROUP, dtype=np.uint8)
    geomgroup[names.OBSTACLE_GROUP] = 1
    local_dirs = np.zeros((0, 3))
    if spec is not None:
        angles = spec.angles()
        local_dirs = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1)
    return (is_obstacle, model.geom_type.astype(np.int32), local_dirs, geomgroup)


def kernel_settings(
    config: EnvConfig, scene: RobotScene
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """The kernel's integer and float settings (``ICFG``, ``CFG``) of ``scene`` of ``config``.

    A ``ValueError`` if a speed or reward weight is not finite.
    """
    return _int_settings(config, scene), _float_settings(config, scene)


def _int_settings(config: EnvConfig, scene: RobotScene) -> NDArray[np.int64]:
    layout = data_layout()
    model = scene.model
    icfg = np.zeros(ICFG_SIZE, dtype=np.int64)
    icfg[ICFG.SUBSTEPS] = config.physics_substeps
    icfg[ICFG.TWIST] = config.action_type == "twist"
    icfg[ICFG.NCON], icfg[ICFG.TIME], icfg[ICFG.CONTACT] = layout.ncon, layout.time, layout.contact
    icfg[ICFG.CONTACT_SIZE], icfg[ICFG.CONTACT_GEOM] = layout.contact_size, layout.contact_geom
    icfg[ICFG.VELOCITY_ADR] = model.sensor(names.VELOCIMETER_SENSOR).adr[0]
    icfg[ICFG.GYRO_ADR] = model.sensor(names.GYRO_SENSOR).adr[0]
    icfg[ICFG.WHEEL_ADR] = model.sensor(names.LEFT_WHEEL_SPEED_SENSOR).adr[0]
    icfg[ICFG.WHEEL_ADR + 1] = model.sensor(names.RIGHT_WHEEL_SPEED_SENSOR).adr[0]
    icfg[ICFG.PROXIMITY_ADR] = model.sensor(names.PROXIMITY_SENSOR).adr[0]
    icfg[ICFG.NSENSORDATA] = model.nsensordata
    warnings = mujoco.MjData(model).warning.number
    icfg[ICFG.WARNING_STRIDE] = warnings.strides[0]
    icfg[ICFG.BADQACC] = _WARNINGS.mjWARN_BADQACC
    icfg[ICFG.BADQPOS] = _WARNINGS.mjWARN_BADQPOS
    icfg[ICFG.BADQVEL] = _WARNINGS.mjWARN_BADQVEL
    icfg[ICFG.CONTACTFULL] = _WARNINGS.mjWARN_CONTACTFULL
    icfg[ICFG.CNSTRFULL] = _WARNINGS.mjWARN_CNSTRFULL
    spec = scene.laser_spec
    icfg[ICFG.LASER] = spec is not None
    icfg[ICFG.ANALYTIC] = scene.analytic
    icfg[ICFG.NOISE] = spec is not None and spec.noise_std > 0.0
    return icfg


def _float_settings(config: EnvConfig, scene: RobotScene) -> NDArray[np.float64]:
    cfg = np.zeros(CFG_SIZE)
    limits = scene.limits
    drive = limits.drive
    cfg[CFG.MAX_WHEEL] = drive.max_wheel_speed
    cfg[CFG.MAX_LINEAR], cfg[CFG.MAX_ANGULAR] = limits.max_linear_speed, limits.max_angular_speed
    cfg[CFG.WHEEL_RADIUS], cfg[CFG.WHEEL_SEPARATION] = drive.wheel_radius, drive.wheel_separation
    spec = scene.laser_spec
    if spec is not None:
        cfg[CFG.RANGE_MAX] = spec.range_max
        cfg[CFG.ANGLE_MIN], cfg[CFG.ANGLE_INCREMENT] = spec.angle_min, spec.angle_increment
        cfg[CFG.FULL_CIRCLE] = spec.full_circle
        cfg[CFG.NOISY_CEILING] = np.nextafter(spec.range_max, 0)
    cfg[CFG.PROXIMITY_MAX] = scene.proximity_spec.range_max
    cfg[CFG.VELOCITY_LIMIT_LINEAR], cfg[CFG.VELOCITY_LIMIT_ANGULAR] = limits.velocity_limit
    cfg[CFG.FORWARD_WEIGHT] = config.forward_reward_weight
    cfg[CFG.SPIN_WEIGHT] = config.spin_cost_weight
    cfg[CFG.CLEARANCE_WEIGHT] = config.clearance_cost_weight
    cfg[CFG.CLEARANCE_DISTANCE] = config.clearance_distance
    cfg[CFG.HULL] = config.robot.radius
    cfg[CFG.COLLISION_PENALTY] = config.collision_penalty
    if not math.isfinite(float(cfg.sum())):
        raise ValueError("the env's speeds and reward weights must be finite numbers")
    return cfg
