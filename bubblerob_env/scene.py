"""``Scene``: the MuJoCo model and data of one env, its obstacle slots, sensors and laser caster.

A scene is built from an :class:`~bubblerob_env.config.EnvConfig`: the compiled MJCF with the
arena resized and the obstacle slots added, the data, the laser (and which caster runs it), the
nose sensor and the camera, the robot's speed limits and the env's :class:`EnvSpecs`. It places
a seeded arena layout and the robot's start pose (:meth:`Scene.place_layout`, which the MuJoCo
Warp backend's layout tables use too), tells collisions and divergence, and clones itself for
batches (:meth:`Scene.spawn`). It knows no Gym class: :mod:`bubblerob_env.env` is the Gymnasium
face on top of it, and :class:`~bubblerob_env.core.batch.RobotBatch` steps scenes.

One robot per scene today. What belongs to the robot rather than to the world (its root joint,
base body, laser, nose sensor and camera, and :meth:`place_robot`) is kept apart, so that a
scene of several robots adds a set of these per robot.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import operator
from typing import Any, Generic, Protocol, TypeVar, cast, overload

import gymnasium as gym
import mujoco
import numpy as np
from numpy.typing import NDArray

from bubblerob_env import names
from bubblerob_env.arena import (
    ArenaLayout,
    ObstacleSlots,
    build_model,
    colour_obstacles,
    sample_layout,
)
from bubblerob_env.config import DEFAULT_CAMERA_SIZE, EnvConfig, SpeedLimits
from bubblerob_env.core.batch import analytic_unsupported
from bubblerob_env.kinematics import DiffDrive
from bubblerob_env.sensors import (
    CameraSensor,
    CameraSpec,
    Laser,
    LaserSpec,
    ProximitySpec,
    StaticTransform,
    static_transforms,
)
from bubblerob_env.specs import EnvSpecs

__all__ = ["DIVERGENCE_WARNINGS", "Scene", "SceneField"]

DIVERGENCE_WARNINGS = (
    mujoco.mjtWarning.mjWARN_BADQACC,
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADQVEL,
)
"""MuJoCo resets the state itself after these: the episode cannot go on."""
_BADQACC, _BADQPOS, _BADQVEL = (int(w) for w in DIVERGENCE_WARNINGS)
T = TypeVar("T")


_SETTLE_SECONDS = 3.0
"""Simulated time the robot rests on the floor, once per scene, to find its resting pose."""


class Scene:
    """The model, data, obstacle slots and sensors of an env built from ``config``.

    ``arena_memory``: bytes of the ``MjData`` arena (contacts, constraints, stack); ``None``:
    the scene file's (MuJoCo's default). Batches give their robots a small one.
    """

    laser_spec: LaserSpec | None
    """The laser's spec (``None``: no laser); ``caster`` says which caster runs."""
    proximity_spec: ProximitySpec
    camera_spec: CameraSpec | None
    laser: Laser | None
    """``mj_multiRay`` casting of the laser (the renderer draws the rays with it)."""
    camera: CameraSensor | None

    def __init__(self, config: EnvConfig, arena_memory: int | None = None) -> None:
        self.config = config
        self.model, _ = build_model(
            config.xml_file,
            config.arena_size,
            config.num_obstacles[1],
            arena_memory,
            config.robot.arena.obstacle_height,
        )
        self.model.opt.timestep = config.control_timestep / config.physics_substeps
        self.size_framebuffer(
            (config.render_width, config.render_height),
            (
                config.camera_width or DEFAULT_CAMERA_SIZE,
                config.camera_height or DEFAULT_CAMERA_SIZE,
            ),
        )
        max_wheel_speed = config.max_wheel_speed
        self.model.actuator_ctrlrange[:] = (-max_wheel_speed, max_wheel_speed)
        self.data = mujoco.MjData(self.model)
        self.slots = ObstacleSlots(self.model, config.num_obstacles[1])
        self.limits = SpeedLimits.of(config, DiffDrive.from_model(self.model, max_wheel_speed))
        """The drive and the twist limits of the robot in this scene."""
        self._build_sensors()
        if self.camera_spec is not None and config.obs_mode == "flat":
            raise ValueError(
                "obs_mode='flat' has no place for the camera image; use obs_mode='dict' with "
                "the camera, or drop camera/camera_width/camera_height"
            )
        self.analytic = self._choose_caster()
        """Whether the kernel casts the laser with the analytic caster (else ``mj_multiRay``)."""
        self.static_transforms: tuple[StaticTransform, ...] = static_transforms(
            self.model, config.robot.frames
        )
        self.specs = EnvSpecs(
            self.laser_spec,
            self.proximity_spec,
            self.camera_spec,
            self.static_transforms,
            self.limits.drive,
            config.action_type,
            self.limits.max_linear_speed,
            self.limits.max_angular_speed,
            config.odometry_noise,
            config.robot.name,
            config.robot.laser.publish_every,
        )
        """The env's own description as plain data (what the ROS layer and policies read)."""
        self._index_model()
        self._bind_views()

    def _build_sensors(self) -> None:
        """The laser (none with 0 rays), the nose sensor and the camera (when sized or asked)."""
        config = self.config
        self.laser_spec = None
        self.laser = None
        if config.laser_num_rays > 0:
            self.laser_spec = LaserSpec(
                config.laser_num_rays,
                config.laser_fov,
                config.laser_range_min,
                config.laser_range_max,
                config.laser_noise_std,
                scan_time=config.control_timestep,
            )
            self.laser = Laser(self.model, self.laser_spec)
        self.proximity_spec = ProximitySpec(
            config.proximity_range_max,
            config.proximity_trigger_distance,
            radiation_type=str(config.proximity_radiation_type),
        )
        self.camera_spec = None
        self.camera = None
        camera_size = config.camera_size
        if camera_size is not None:
            self.camera_spec = CameraSpec(
                camera_size[0] or DEFAULT_CAMERA_SIZE,
                camera_size[1] or DEFAULT_CAMERA_SIZE,
                float(self.model.cam_fovy[self.model.camera(names.FRONT_CAMERA).id]),
                shadows=config.camera_shadows,
                reflections=config.camera_shadows,
            )
            self.camera = CameraSensor(self.model, self.camera_spec)

    def _choose_caster(self) -> bool:
        """Whether the analytic caster runs (see ``laser_backend``); names it in the laser spec."""
        if self.laser_spec is None:
            return False
        laser_backend = self.config.laser_backend
        mujoco.mj_forward(self.model, self.data)
        problems = analytic_unsupported(self.model, self.data, self.slots.geom_ids)
        mujoco.mj_resetData(self.model, self.data)
        if laser_backend == "analytic" and problems:
            raise ValueError(
                f"laser_backend='analytic' cannot cast in the scene {self.config.xml_file.name}: "
                f"{'; '.join(problems[:5])} (it models upright boxes and cylinders); use "
                "laser_backend='auto' or 'mujoco'"
            )
        analytic = laser_backend != "mujoco" and not problems
        caster = "analytic" if analytic else "mujoco"
        self.laser_spec = dataclasses.replace(self.laser_spec, caster=caster)
        if self.laser is not None:
            self.laser.spec = self.laser_spec
        return analytic

    def _index_model(self) -> None:
        """Ids that resets read."""
        # A list: indexing it with a few contacts' geom ids is faster than numpy fancy indexing.
        self._is_obstacle: list[bool] = (self.model.geom_group == names.OBSTACLE_GROUP).tolist()
        self.base_body = self.model.body(names.BASE_BODY).id
        """The robot's base body id."""
        self.root_qpos = int(self.model.joint(names.ROOT_JOINT).qposadr[0])
        """Address of the robot's free joint in ``qpos`` (position, then quaternion w, x, y, z)."""
        self.rest_height, self.rest_tilt = self._resting_pose()
        """The free joint's height and yaw-free tilt (w, x, y, z) where the robot rests."""
        # The step's sensordata addresses are the kernel's settings (core/batch.py).

    def _resting_pose(self) -> tuple[float, NDArray[np.float64]]:
        return resting_pose(self.model, self.root_qpos)

    def _bind_views(self) -> None:
        # A view into self.data: rebuilt after unpickling and for a clone's new data.
        self._warnings = self.data.warning.number

    def size_framebuffer(self, *sizes: tuple[int, int]) -> None:
        """Make the offscreen buffer at least as large as each ``(width, height)`` image."""
        global_ = self.model.vis.global_
        global_.offwidth = max(global_.offwidth, *(width for width, _ in sizes))
        global_.offheight = max(global_.offheight, *(height for _, height in sizes))

    def place_layout(self, rng: np.random.Generator) -> ArenaLayout:
        """Draw a layout from ``rng``, write it and the start pose into MuJoCo (no ``mj_forward``).

        The part of a reset that MuJoCo Warp's layout tables share.
        """
        config = self.config
        layout = sample_layout(
            rng,
            config.arena_size,
            config.num_obstacles,
            config.obstacle_size,
            config.start_clearance,
            config.start_pose,
            config.robot.radius,
        )
        if config.obstacle_colours:
            layout = colour_obstacles(rng, layout)
        mujoco.mj_resetData(self.model, self.data)
        self.slots.apply(self.model, self.data, layout.obstacles)
        self.place_robot(layout.start_pose)
        return layout

    def place_robot(self, pose: tuple[float, float, float]) -> None:
        """Put the robot at ``pose`` (x, y, yaw), resting on the floor (its free joint's qpos)."""
        x, y, yaw = pose
        adr = self.root_qpos
        self.data.qpos[adr : adr + 3] = (x, y, self.rest_height)
        heading = np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])
        mujoco.mju_mulQuat(self.data.qpos[adr + 3 : adr + 7], heading, self.rest_tilt)

    def forward(self) -> None:
        """``mj_forward`` after :meth:`place_layout`; a fixed start pose must be free."""
        mujoco.mj_forward(self.model, self.data)
        if self.config.start_pose is not None and self.in_collision():
            raise ValueError(
                f"start_pose {self.config.start_pose} overlaps a wall or obstacle of the scene "
                f"{self.config.xml_file.name}; choose a free pose"
            )

    def in_collision(self) -> bool:
        """Whether the robot touches a wall or an obstacle (after ``mj_forward``)."""
        # Only robot geoms collide with walls and obstacles (contype/conaffinity in the MJCF).
        ncon = self.data.ncon
        if not ncon:
            return False
        is_obstacle = self._is_obstacle
        for geom1, geom2 in self.data.contact.geom[:ncon].tolist():
            if is_obstacle[geom1] or is_obstacle[geom2]:
                return True
        return False

    def diverged(self) -> str:
        """MuJoCo's divergence warning from this step, or ``""``.

        MuJoCo resets the state by itself when the accelerations blow up, so the episode is
        truncated with the reason in ``info["physics_diverged"]`` and a logged warning.
        """
        counts = self._warnings
        if not (counts[_BADQACC] or counts[_BADQPOS] or counts[_BADQVEL]):
            return ""
        for warning in DIVERGENCE_WARNINGS:
            if counts[warning]:
                message = (
                    f"MuJoCo reported {warning.name} (the simulation diverged and MuJoCo reset "
                    f"it) at sim time {self.data.time:.3f} s; the episode is truncated. Lower "
                    f"control_timestep / physics_substeps (now {self.model.opt.timestep} s)."
                )
                gym.logger.warn(message)
                return message
        return ""

    def spawn(self) -> Scene:
        """A new scene of the same config, sharing what steps never change (specs, slots, ids).

        For batches: cheaper in time and memory than building. Call it on a scene that was never
        reset: the clone copies the model (resets write obstacle sizes into it) and gets its
        own data and camera.
        """
        clone = object.__new__(Scene)
        clone.__dict__.update(self.__dict__)
        clone.model = copy.copy(self.model)
        clone.data = mujoco.MjData(clone.model)
        if self.camera_spec is not None:
            clone.camera = CameraSensor(clone.model, self.camera_spec)
        clone._bind_views()
        return clone

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        state.pop("_warnings", None)
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._bind_views()

    def close(self) -> None:
        """Free the camera's OpenGL context, if one was made."""
        if self.camera is not None:
            self.camera.close()
            self.camera = None


class HasScene(Protocol):
    """An object on a scene (the env)."""

    scene: Scene


class SceneField(Generic[T]):
    """A read-only attribute that is a value of its owner's ``scene`` (a dotted path)."""

    def __init__(self, path: str) -> None:
        self.get = operator.attrgetter(path)

    @overload
    def __get__(self, obj: None, owner: type) -> SceneField[T]: ...
    @overload
    def __get__(self, obj: HasScene, owner: type) -> T: ...
    def __get__(self, obj: HasScene | None, owner: type) -> T | SceneField[T]:
        if obj is None:
            return self
        return cast(T, self.get(obj.scene))


def resting_pose(
    model: mujoco.MjModel, root_qpos: int, data: mujoco.MjData | None = None
) -> tuple[float, NDArray[np.float64]]:
    """The free joint's height and tilt (a quaternion, no yaw) of a robot at rest.

    The compiled pose puts every wheel and the caster exactly on the floor (distance 0). A
    contact at distance 0 is active or not by the sign of rounding noise (float64 here,
    float32 in MuJoCo Warp), so resets from it fell freely for one substep on some seeds and
    not on others (issue #41). Resets start from where the robot rests instead (sunk into
    the soft contacts, every contact clearly active): found by letting it settle with the
    motors holding, on an empty floor (the obstacle slots are compiled below it), from ``data``
    (default: the compiled pose) and with ``root_qpos`` the robot's free joint in ``qpos``.
    """
    data = mujoco.MjData(model) if data is None else data
    for _ in range(math.ceil(_SETTLE_SECONDS / model.opt.timestep)):
        mujoco.mj_step(model, data)
    adr = root_qpos
    w, x, y, z = data.qpos[adr + 3 : adr + 7]
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    tilt = np.empty(4)
    unyaw = np.array([math.cos(yaw / 2), 0.0, 0.0, -math.sin(yaw / 2)])
    mujoco.mju_mulQuat(tilt, unyaw, data.qpos[adr + 3 : adr + 7])
    mujoco.mju_normalize4(tilt)
    return float(data.qpos[adr + 2]), tilt
