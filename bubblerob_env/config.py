"""``EnvConfig``: the env's keyword arguments, checked, with the robot's defaults filled in.

One frozen value says what a :class:`~bubblerob_env.env.BubbleRobEnv` (and each robot of a batch,
CPU or MuJoCo Warp) is asked to be: :meth:`EnvConfig.from_kwargs` checks every keyword argument
(the first bad one raises, worded as the env always worded it) and fills each ``None`` with the
robot's value (:mod:`bubblerob_env.robots`). What the robot can do in its compiled scene (the
drive, the twist limits, the velocity observation's bounds) is :class:`SpeedLimits`, made by the
scene (:class:`~bubblerob_env.scene.Scene`) from the config and the model's wheels.

This module knows no Gym class: the Gymnasium face (:mod:`bubblerob_env.env`), the batches and
the kernel's settings (:mod:`bubblerob_env.core.batch`) all read these values.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Generic, Protocol, TypeVar, cast, overload

import numpy as np
from numpy.typing import NDArray

from bubblerob_env.checks import (
    check_bool,
    check_bounded,
    check_choice,
    check_env_arguments,
    check_positive,
    check_start_pose,
    unexpected_kwargs_error,
)
from bubblerob_env.kinematics import DiffDrive
from bubblerob_env.robots import RobotDescription, robot_description
from bubblerob_env.sensors import RADIATION_TYPES

__all__ = [
    "ACTION_TYPES",
    "ARGUMENTS",
    "ConfigField",
    "DEFAULT_CAMERA_SIZE",
    "LASER_BACKENDS",
    "OBS_MODES",
    "RENDER_MODES",
    "EnvConfig",
    "SpeedLimits",
]

ACTION_TYPES = ("wheels", "twist")
OBS_MODES = ("dict", "flat")
RENDER_MODES = ("human", "rgb_array")
"""Every render mode the env has (its ``metadata`` lists those that work on this machine)."""
LASER_BACKENDS = ("auto", "analytic", "mujoco")
"""``laser_backend`` values: the analytic caster where the scene allows it (``auto``), always
(``analytic``: an error where it cannot), or MuJoCo's ``mj_multiRay`` (``mujoco``)."""
DEFAULT_CAMERA_SIZE = 64
"""Camera image side (pixels) where only the other side, or neither, is given."""
T = TypeVar("T")

ARGUMENTS: dict[str, Any] = {
    "xml_file": None,
    "action_type": "wheels",
    "control_timestep": 0.05,
    "physics_substeps": 4,
    "max_wheel_speed": None,
    "max_linear_speed": None,
    "max_angular_speed": None,
    "odometry_noise": 0.0,
    "laser_num_rays": None,
    "laser_fov": None,
    "laser_range_min": None,
    "laser_range_max": None,
    "laser_noise_std": 0.0,
    "laser_backend": "auto",
    "proximity_range_max": None,
    "proximity_trigger_distance": None,
    "proximity_radiation_type": "ULTRASOUND",
    "camera": None,
    "camera_width": None,
    "camera_height": None,
    "camera_shadows": False,
    "arena_size": None,
    "num_obstacles": None,
    "obstacle_size": None,
    "obstacle_colours": False,
    "start_clearance": None,
    "start_pose": None,
    "forward_reward_weight": 1.0,
    "spin_cost_weight": 0.2,
    "clearance_cost_weight": 0.5,
    "clearance_distance": None,
    "collision_penalty": 100.0,
    "terminate_on_collision": True,
    "obs_mode": "dict",
    "render_mode": None,
    "render_width": 480,
    "render_height": 480,
    "robot": "bubblerob",
}
"""Every keyword argument of ``BubbleRobEnv`` and its default, in the signature's order (a
``None`` means the robot's value, or for ``xml_file`` the robot's scene)."""


def check_asked_world(camera: object, args: Mapping[str, Any], robot: RobotDescription) -> None:
    """Refuse what the env could take and then not honour (``ValueError``, one line).

    ``camera=False`` given (``camera``: as given, ``None`` if not) beside a camera size (a size
    alone turns the camera on); an
    ``obstacle_size`` whose largest box or cylinder cannot be placed in the arena at all: it would
    be dropped from every layout (:func:`~bubblerob_env.arena.sample_layout` keeps a robot
    diameter between obstacles and walls).
    """
    sized = [name for name in ("camera_width", "camera_height") if args[name] is not None]
    if camera is False and sized:
        raise ValueError(
            f"camera=False contradicts {sized[0]}={args[sized[0]]!r} (a camera size turns the "
            "camera on): drop one of them"
        )
    most = int(args["num_obstacles"][1])
    biggest = float(args["obstacle_size"][1])
    room = float(args["arena_size"]) / 2.0 - 2.0 * robot.radius  # sample_layout's gap to walls
    if most > 0 and math.hypot(biggest, biggest) >= room:
        allowed = room / math.sqrt(2.0)
        raise ValueError(
            f"obstacle_size {tuple(args['obstacle_size'])!r}: a box of half side {biggest:g} m "
            f"cannot be placed in arena_size {float(args['arena_size']):g} m with the robot's "
            f"gap to the walls: the largest must be < {max(allowed, 0.0):.3f} m (or "
            "num_obstacles (0, 0))"
        )


@dataclass(frozen=True)
class EnvConfig:
    """The env's arguments, checked; the robot's values where ``None`` was given.

    Each field is the ``BubbleRobEnv`` keyword argument of the same name, but ``robot`` is the
    robot's description and ``xml_file`` the scene's path. Every argument whose default is
    ``None`` takes the robot's value from its description (:mod:`bubblerob_env.robots`); the
    values in brackets below are BubbleRob's. ``max_linear_speed`` and ``max_angular_speed``
    stay ``None`` where the wheels decide (:class:`SpeedLimits`).

    Attributes:
        xml_file: Scene MJCF (must include the robot, see ``assets/``); default the robot's
            (``arena.xml``).
        action_type: ``"wheels"`` or ``"twist"`` (see the env's Action Space).
        control_timestep: Seconds of simulated time per ``step`` (20 Hz by default).
        physics_substeps: MuJoCo steps per control step; the physics timestep is their ratio.
        max_wheel_speed: Wheel speed (rad/s) that an action of 1 means in wheels mode; also
            the motors' limit in twist mode (10).
        max_linear_speed: m/s meant by a linear action of 1; default: the wheels' limit.
        max_angular_speed: rad/s meant by an angular action of 1; default: the robot's top
            yaw rate, or (BubbleRob) spinning in place with both wheels at their limit.
        odometry_noise: Relative wheel-slip error of the odometry per control step, from 0
            to 1: each wheel's travel in a step is multiplied by ``1 + odometry_noise *
            N(0, 1)``, two draws per step from the episode's generator, and the odometry
            drifts. 0 (the default) draws nothing: the odometry is the truth. ``info`` has
            the odometry (``odom_x``, ``odom_y``, ``odom_yaw``) beside the truth (``x``,
            ``y``, ``yaw``); see :mod:`bubblerob_env.odometry`.
        laser_num_rays: Rays per scan; 0 removes the laser from the observation (360).
        laser_fov: Field of view in radians: 2*pi (360 degrees) or less, centred on +x
            (2*pi).
        laser_range_min: Minimum valid range (m), reported to ROS (0.05).
        laser_range_max: Maximum range (m); no return reads this value (5).
        laser_noise_std: Standard deviation (m) of Gaussian noise on each hit.
        laser_backend: ``"auto"``: the exact analytic caster where every laser-visible geom
            is an upright box or cylinder that never tilts (the arena's walls and
            obstacles), else MuJoCo's ``mj_multiRay``; ``"analytic"``: the caster or a
            ``ValueError`` saying why not; ``"mujoco"``: always ``mj_multiRay``. Both give
            the same readings; ``laser_spec.caster`` says which one runs.
        proximity_range_max: Range of the nose sensor (m) (0.6).
        proximity_trigger_distance: Distance under which the nose sensor "triggers" (m)
            (0.3).
        proximity_radiation_type: ``"ULTRASOUND"`` (the seed's ``FrontUS``) or
            ``"INFRARED"``: what ROS ``sensor_msgs/Range`` messages report; the sensing is the
            same ray either way.
        camera: Add the forward camera to the observation (64x64 unless sized).
        camera_width: Image width in pixels; giving a size enables the camera.
        camera_height: Image height in pixels; giving a size enables the camera.
        camera_shadows: Render shadows and reflections (about 15x slower on a CPU).
        arena_size: Inside side length of the square arena (m) (4).
        num_obstacles: Inclusive range of the number of obstacles per episode ((4, 10)).
        obstacle_size: Range of obstacle radius / half side (m) ((0.08, 0.25)).
        obstacle_colours: Paint each obstacle a colour drawn from the palette (see Starting
            State); ``False`` keeps the scene's obstacle material.
        start_clearance: Minimum free space around the robot at the start (m) (0.25).
        start_pose: Fixed start ``(x, y, yaw)``; default: random each reset.
        forward_reward_weight: Weight of the forward-speed reward.
        spin_cost_weight: Weight of the yaw-rate cost.
        clearance_cost_weight: Weight of the cost of driving close to obstacles.
        clearance_distance: Range (m) under which that cost starts (0.35).
        collision_penalty: Cost of touching a wall or an obstacle.
        terminate_on_collision: End the episode on collision.
        obs_mode: ``"dict"`` (the env's ``Dict``) or ``"flat"``: one float32 ``Box`` of
            the laser, proximity and velocity readings, in that order
            (``env.unwrapped.observation_layout`` names each part's slice), for libraries
            that take no ``Dict``. The camera has no place in it: ``camera`` with
            ``"flat"`` is a ``ValueError``.
        render_mode: ``None``, ``"rgb_array"`` (overhead view with the laser drawn) or
            ``"human"`` (a window; needs a display).
        render_width: Width of ``rgb_array`` frames.
        render_height: Height of ``rgb_array`` frames.
        robot: Which robot (a name in :data:`bubblerob_env.robots.ROBOTS`): ``"bubblerob"``
            or ``"pioneer_p3dx"`` (what ``PioneerP3DX-v0`` passes).
    """

    robot: RobotDescription
    xml_file: Path
    action_type: str
    control_timestep: float
    physics_substeps: int
    max_wheel_speed: float
    max_linear_speed: float | None
    max_angular_speed: float | None
    odometry_noise: float
    laser_num_rays: int
    laser_fov: float
    laser_range_min: float
    laser_range_max: float
    laser_noise_std: float
    laser_backend: str
    proximity_range_max: float
    proximity_trigger_distance: float
    proximity_radiation_type: str
    camera: bool
    camera_width: int | None
    camera_height: int | None
    camera_shadows: bool
    arena_size: float
    num_obstacles: tuple[int, int]
    obstacle_size: tuple[float, float]
    obstacle_colours: bool
    start_clearance: float
    start_pose: tuple[float, float, float] | None
    forward_reward_weight: float
    spin_cost_weight: float
    clearance_cost_weight: float
    clearance_distance: float
    collision_penalty: float
    terminate_on_collision: bool
    obs_mode: str
    render_mode: str | None
    render_width: int
    render_height: int

    @classmethod
    def from_kwargs(cls, kwargs: Mapping[str, Any]) -> EnvConfig:
        """Check ``kwargs`` (``BubbleRobEnv``'s keyword arguments) and fill in the defaults.

        An unknown name raises ``TypeError`` in Python's wording followed by the valid names; the
        first bad value raises ``ValueError`` naming it and what is allowed.
        """
        unknown = [name for name in kwargs if name not in ARGUMENTS]
        if unknown:
            raise unexpected_kwargs_error("BubbleRobEnv.__init__", unknown, list(ARGUMENTS))
        given = {**ARGUMENTS, **kwargs}
        camera_given = given["camera"]  # None: not given (a camera size alone turns it on)
        given["camera"] = False if camera_given is None else camera_given
        robot = robot_description(given.pop("robot"))
        args = robot.fill_defaults(given)
        check_env_arguments(args, ACTION_TYPES, RADIATION_TYPES, RENDER_MODES, robot)
        check_asked_world(camera_given, args, robot)
        check_choice("laser_backend", args["laser_backend"], LASER_BACKENDS)
        check_choice("obs_mode", args["obs_mode"], OBS_MODES)
        odometry_noise = check_bounded("odometry_noise", args["odometry_noise"], 0.0, 1.0)
        obstacle_colours = check_bool("obstacle_colours", args["obstacle_colours"])
        lo, hi = args["num_obstacles"]
        size = args["obstacle_size"]
        arena_size = float(args["arena_size"])
        start_pose = args["start_pose"]
        if start_pose is not None:
            start_pose = check_start_pose(start_pose, arena_size, robot.radius)
        xml_file = args["xml_file"]
        return cls(
            **{
                **args,
                "robot": robot,
                "xml_file": Path(xml_file) if xml_file is not None else robot.scene_file,
                "odometry_noise": odometry_noise,
                "obstacle_colours": obstacle_colours,
                "arena_size": arena_size,
                "num_obstacles": (int(lo), int(hi)),
                "obstacle_size": (float(size[0]), float(size[1])),
                "start_clearance": float(args["start_clearance"]),
                "start_pose": start_pose,
                "clearance_distance": float(args["clearance_distance"]),
            }
        )

    @property
    def camera_size(self) -> tuple[int | None, int | None] | None:
        """The camera's ``(width, height)`` as given (``None``: default side); ``None``: off."""
        if self.camera or self.camera_width or self.camera_height:
            return (self.camera_width, self.camera_height)
        return None


@dataclass(frozen=True)
class SpeedLimits:
    """What the robot's wheels allow in its scene: the drive and the twist limits."""

    drive: DiffDrive
    max_linear_speed: float
    """m/s that a linear action of 1 means (the config's, or the wheels' top speed)."""
    max_angular_speed: float
    """rad/s that an angular action of 1 means (the config's, or spinning in place flat out)."""

    @classmethod
    def of(cls, config: EnvConfig, drive: DiffDrive) -> SpeedLimits:
        """``config``'s speeds, the drive's where ``None``; a ``ValueError`` unless > 0."""
        linear = float(config.max_linear_speed or drive.max_linear_speed)
        angular = float(config.max_angular_speed or drive.max_angular_speed)
        check_positive("max_linear_speed", linear)
        check_positive("max_angular_speed", angular)
        return cls(drive, linear, angular)

    @property
    def velocity_limit(self) -> NDArray[np.float64]:
        """Bounds of the ``velocity`` observation: twice the linear and angular limits."""
        return np.array([2 * self.max_linear_speed, 2 * self.max_angular_speed])


class Configured(Protocol):
    """An object with a config (the env: its scene's)."""

    config: EnvConfig


class ConfigField(Generic[T]):
    """An attribute that is the field of the same name of its owner's ``config``.

    Setting it gives the owner a copy of the config with the new value (the config itself stays
    frozen); what was built from the old config (the kernel's settings) is not rebuilt.
    """

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    @overload
    def __get__(self, obj: None, owner: type) -> ConfigField[T]: ...
    @overload
    def __get__(self, obj: Configured, owner: type) -> T: ...
    def __get__(self, obj: Configured | None, owner: type) -> T | ConfigField[T]:
        if obj is None:
            return self
        return cast(T, getattr(obj.config, self.name))

    def __set__(self, obj: Configured, value: T) -> None:
        changes: dict[str, Any] = {self.name: value}
        obj.config = replace(obj.config, **changes)
