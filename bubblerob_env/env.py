"""``BubbleRob-v0``: obstacle avoidance with a differential-drive robot in MuJoCo."""

from __future__ import annotations

import copy
import dataclasses
import inspect
import math
from pathlib import Path
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from bubblerob_env import names
from bubblerob_env.arena import (
    ArenaLayout,
    ObstacleSlots,
    build_model,
    colour_obstacles,
    sample_layout,
)
from bubblerob_env.checks import (
    check_bool,
    check_bounded,
    check_choice,
    check_env_arguments,
    check_positive,
    check_start_pose,
    unexpected_kwargs_error,
)
from bubblerob_env.core.kernel import OUT
from bubblerob_env.core.robots import LASER_BACKENDS, RobotBatch, analytic_unsupported
from bubblerob_env.infos import robot_info
from bubblerob_env.kinematics import DiffDrive
from bubblerob_env.odometry import Odometry, draw_slip
from bubblerob_env.rendering import HumanViewer, OverheadRenderer, render_modes_here
from bubblerob_env.robots import RobotDescription, robot_description
from bubblerob_env.sensors import (
    RADIATION_TYPES,
    CameraSensor,
    CameraSpec,
    Laser,
    LaserSpec,
    ProximitySpec,
    StaticTransform,
    static_transforms,
)
from bubblerob_env.specs import EnvSpecs

__all__ = ["ACTION_TYPES", "OBS_MODES", "BubbleRobEnv"]

ACTION_TYPES = ("wheels", "twist")
OBS_MODES = ("dict", "flat")
_DEFAULT_CAMERA_SIZE = 64
_DATA_VIEWS = ("_warnings", "_core", "_one_robot", "_row")
# MuJoCo resets the state itself after these: the episode cannot go on.
_DIVERGENCE_WARNINGS = (
    mujoco.mjtWarning.mjWARN_BADQACC,
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADQVEL,
)
_BADQACC, _BADQPOS, _BADQVEL = (int(w) for w in _DIVERGENCE_WARNINGS)
# The kernel's result columns the step reads, as plain ints (faster to index with than enums).
_COLLISION, _CLIPPED, _DIVERGED, _REWARD = (
    int(c) for c in (OUT.COLLISION, OUT.CLIPPED, OUT.DIVERGED, OUT.REWARD)
)


Observation = dict[str, NDArray[Any]] | NDArray[np.float32]
"""A ``Dict`` observation (``obs_mode="dict"``) or a flat one (``obs_mode="flat"``)."""


class BubbleRobEnv(gym.Env[Observation, NDArray[np.float32]]):
    """BubbleRob, the CoppeliaSim tutorial robot, avoiding obstacles in a walled arena.

    ## Description
    A ~20 cm differential-drive robot (two motorised wheels, a frictionless caster, a proximity
    sensor on its nose, a 2D laser scanner on top and an optional forward RGB camera) drives in a
    square arena with randomly placed cylinders and boxes. The task is to drive fast without
    touching anything. Frames follow REP 103: +x forward, +y left, +z up, yaw counter-clockwise.

    ## Action Space
    ``Box(-1, 1, (2,), float32)``, scaled by the kwargs:

    - ``action_type="wheels"``: ``[left, right]`` wheel speed targets as fractions of
      ``max_wheel_speed`` (rad/s), like the seed's ``leftMotorSpeed`` / ``rightMotorSpeed``.
    - ``action_type="twist"``: ``[linear x, angular z]`` as fractions of ``max_linear_speed``
      (m/s) and ``max_angular_speed`` (rad/s), like the seed's ``cmd_vel``. Converted to wheel
      speeds by differential-drive inverse kinematics with the model's wheel radius and separation;
      when a wheel would exceed ``max_wheel_speed`` both are scaled down, keeping the curvature.
      A positive angular command turns counter-clockwise.

    Out-of-range actions are clipped to [-1, 1] and counted (``info["action_clipped"]``,
    ``info["clipped_actions"]``); NaN or infinite actions raise ``ValueError``.

    ## Observation Space
    ``Dict`` of float32 arrays (and a uint8 image):

    - ``laser`` ``(laser_num_rays,)``: ranges in metres, ray 0 at ``angle_min``, counter-clockwise
      (see :class:`~bubblerob_env.sensors.LaserSpec`); no return reads ``laser_range_max``.
    - ``proximity`` ``(1,)``: distance straight ahead of the nose, ``proximity_range_max`` if none.
    - ``velocity`` ``(2,)``: measured forward speed (m/s) and yaw rate (rad/s) of ``base_link``,
      clipped to twice the twist limits.
    - ``camera`` ``(camera_height, camera_width, 3)`` uint8 RGB, only when the camera is enabled.

    ## Rewards
    ``reward = forward - spin - clearance - collision`` with, per step,
    ``forward = forward_reward_weight * v / max_linear_speed`` (negative when reversing),
    ``spin = spin_cost_weight * |yaw rate| / max_angular_speed``,
    ``clearance = clearance_cost_weight * clip((clearance_distance - d) / (clearance_distance -
    0.11), 0, 1)`` where ``d`` is the nearest laser (or, without a laser, proximity) reading, so
    it grows from 0 at ``clearance_distance`` to the full weight at the robot's hull (0.11 m), and
    ``collision = collision_penalty`` on the step the robot touches a wall or an obstacle.
    The default penalty (100) exceeds the forward reward of the ~100 steps a discount of 0.99
    looks ahead, so no speed gain is worth a crash (with 10, PPO learned to drive fast and crash).
    The parts are in ``info`` as ``reward_forward``, ``reward_spin``, ``reward_clearance`` and
    ``reward_collision`` (the costs as negative numbers).

    ## Starting State
    Each ``reset(seed=...)`` draws ``num_obstacles`` cylinders and boxes (radius / half sides in
    ``obstacle_size``) at free positions, and a start pose at least ``start_clearance`` metres from
    everything, with a uniform random heading; or uses ``start_pose`` when given. The robot starts
    at rest. A scene given by ``xml_file`` is used as is, plus the random obstacles. With
    ``obstacle_colours=True`` each obstacle also gets a colour from
    :data:`~bubblerob_env.arena.OBSTACLE_PALETTE` (``layout.obstacles[i].colour``), drawn from the
    episode's generator after the layout, so the layout is the one the seed gives without colours
    (later draws, such as laser noise, shift); off (the default), nothing is drawn and episodes
    are bit for bit those without the kwarg.

    ## Episode End
    Terminates when the robot touches a wall or obstacle (if ``terminate_on_collision``): any
    MuJoCo contact between a robot geom and a wall or obstacle geom. Truncates at the time limit
    (``max_episode_steps=1000``, 50 s, set at registration), or when MuJoCo reports that the
    simulation diverged (``info["physics_diverged"]`` says why). On the last step of an episode
    ``info["is_success"]`` tells whether it reached the time limit without any collision: every
    step's ``info`` has it, meaning "no collision (and no divergence) so far", so on the last step
    it is the episode's success whatever ended it. (The env sets it, not a wrapper after
    ``TimeLimit``: ``gym.make_vec``'s vector entry point refuses specs with wrappers.)

    ## Arguments
    Every argument below is a keyword argument of ``gym.make("BubbleRob-v0", ...)``; unknown ones
    raise ``TypeError`` in Python's wording ("got an unexpected keyword argument 'x'") followed by
    the valid names, and bad values raise ``ValueError`` naming the value and what is allowed.
    See ``__init__`` for each one's meaning.

    ## Version History
    - v0 (2026-11-26, issue #29): the vector entry point (``gym.make_vec(...,
      vectorization_mode="vector_entry_point")``) takes ``backend`` (``"cpu"``, the default:
      unchanged, bit for bit; ``"warp"``: MuJoCo Warp, :mod:`bubblerob_env.mjwarp`) and
      ``device``. The single env is unchanged.
    - v0 (2026-11-25, issue #26): new kwarg ``robot`` (``"bubblerob"``, the default, or
      ``"pioneer_p3dx"``: ``PioneerP3DX-v0``); the robot-dependent kwargs default to ``None``,
      the robot's value (:mod:`bubblerob_env.robots`). BubbleRob's episodes and bags are bit for
      bit those of before.
    - v0 (2026-11-25, issue #28): new kwarg ``obstacle_colours`` (default ``False``: episodes and
      recorded bags unchanged) for the camera's recognition task (:mod:`bubblerob_env.vision`).
    - v0 (2026-11-25 revision): the step runs in a numba kernel (``bubblerob_env.core``) and the
      laser in an exact analytic caster where the scene allows it; episodes are bit for bit
      those of the previous revision (compared on 6017 steps over five configurations, and
      ``mj_multiRay`` against the caster on 100k+ rays). New kwargs: ``laser_backend``
      (``laser_spec.caster`` says which caster runs) and ``obs_mode="flat"``. ``step()`` before
      ``reset()`` and ``render()`` after ``close()`` raise; an action too large for a float is a
      ``ValueError``; ``metadata["render_modes"]`` lists ``human`` only where a display exists.
    - v0 (2026-11-24 revision): obstacles are solid. Before, each obstacle slot was a geom of the
      world body moved after compilation, and MuJoCo's midphase kept its compile-time bounding
      box, so 17 of the 20 slots let the robot drive through (148 of 182 drives at obstacles).
      Each slot is now a mocap body. Also: ``info["is_success"]`` on every step (on the last,
      the episode's success); bad ``start_pose``, non-finite reward weights, physics steps over
      0.05 s, image sizes outside [1, 4096] and more than 256 obstacles are rejected; a diverged
      simulation truncates;
      ``metadata["render_fps"]`` is ``1 / control_timestep``; the camera's OpenGL context is made
      on first use (fork-safe) and the env pickles. The id stays v0: no release had the old world
      as a documented behaviour worth keeping, and every result measured on it was re-measured.
    - v0 (2026-11-23): initial version.
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 20}
    laser_spec: LaserSpec | None
    proximity_spec: ProximitySpec
    camera_spec: CameraSpec | None
    _laser: Laser | None
    _odometry: Odometry
    _odometry_row: int
    _ARENA_MEMORY: int | None = None  # bytes of MjData arena; None: the scene's (MuJoCo default)

    def __init__(
        self,
        xml_file: str | Path | None = None,
        action_type: str = "wheels",
        control_timestep: float = 0.05,
        physics_substeps: int = 4,
        max_wheel_speed: float | None = None,
        max_linear_speed: float | None = None,
        max_angular_speed: float | None = None,
        odometry_noise: float = 0.0,
        laser_num_rays: int | None = None,
        laser_fov: float | None = None,
        laser_range_min: float | None = None,
        laser_range_max: float | None = None,
        laser_noise_std: float = 0.0,
        laser_backend: str = "auto",
        proximity_range_max: float | None = None,
        proximity_trigger_distance: float | None = None,
        proximity_radiation_type: str = "ULTRASOUND",
        camera: bool = False,
        camera_width: int | None = None,
        camera_height: int | None = None,
        camera_shadows: bool = False,
        arena_size: float | None = None,
        num_obstacles: tuple[int, int] | None = None,
        obstacle_size: tuple[float, float] | None = None,
        obstacle_colours: bool = False,
        start_clearance: float | None = None,
        start_pose: tuple[float, float, float] | None = None,
        forward_reward_weight: float = 1.0,
        spin_cost_weight: float = 0.2,
        clearance_cost_weight: float = 0.5,
        clearance_distance: float | None = None,
        collision_penalty: float = 100.0,
        terminate_on_collision: bool = True,
        obs_mode: str = "dict",
        render_mode: str | None = None,
        render_width: int = 480,
        render_height: int = 480,
        *,
        robot: str = "bubblerob",
        **unknown_kwargs: Any,
    ) -> None:
        """Build the env.

        Every argument whose default is ``None`` takes the robot's value from its description
        (:mod:`bubblerob_env.robots`); the values in brackets below are BubbleRob's.

        Args:
            xml_file: Scene MJCF (must include the robot, see ``assets/``); default the robot's
                (``arena.xml``).
            action_type: ``"wheels"`` or ``"twist"`` (see Action Space).
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
            obs_mode: ``"dict"`` (the ``Dict`` above) or ``"flat"``: one float32 ``Box`` of
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
            **unknown_kwargs: Rejected with a ``TypeError`` listing the valid names.
        """
        if unknown_kwargs:
            valid = [
                p
                for p in inspect.signature(BubbleRobEnv.__init__).parameters
                if p not in ("self", "unknown_kwargs")
            ]
            raise unexpected_kwargs_error("BubbleRobEnv.__init__", list(unknown_kwargs), valid)
        self.robot: RobotDescription = robot_description(robot)
        """The robot's description (sizes, sensors, frames, limits, arena)."""
        arguments = self.robot.fill_defaults(
            {
                name: value
                for name, value in locals().items()
                if name not in ("self", "unknown_kwargs", "robot")
            }
        )
        check_env_arguments(
            arguments, ACTION_TYPES, RADIATION_TYPES, self.metadata["render_modes"], self.robot
        )
        max_wheel_speed, max_angular_speed = (
            arguments["max_wheel_speed"],
            arguments["max_angular_speed"],
        )
        laser = tuple(
            arguments[f"laser_{key}"] for key in ("num_rays", "fov", "range_min", "range_max")
        )
        proximity = (arguments["proximity_range_max"], arguments["proximity_trigger_distance"])
        arena_size, num_obstacles = arguments["arena_size"], arguments["num_obstacles"]
        obstacle_size, start_clearance = arguments["obstacle_size"], arguments["start_clearance"]
        clearance_distance = arguments["clearance_distance"]
        check_choice("laser_backend", laser_backend, LASER_BACKENDS)
        check_choice("obs_mode", obs_mode, OBS_MODES)
        self.odometry_noise = check_bounded("odometry_noise", odometry_noise, 0.0, 1.0)
        self.obs_mode = obs_mode
        self.obstacle_colours = check_bool("obstacle_colours", obstacle_colours)
        lo, hi = num_obstacles
        obstacle_size = (float(obstacle_size[0]), float(obstacle_size[1]))

        self.action_type = action_type
        self.render_mode = render_mode
        self.physics_substeps = physics_substeps
        self.arena_size = float(arena_size)
        self.num_obstacles = (int(lo), int(hi))
        self.obstacle_size = (float(obstacle_size[0]), float(obstacle_size[1]))
        self.start_clearance = float(start_clearance)
        self.start_pose: tuple[float, float, float] | None = None
        if start_pose is not None:
            self.start_pose = check_start_pose(start_pose, self.arena_size, self.robot.radius)
        self.forward_reward_weight = forward_reward_weight
        self.spin_cost_weight = spin_cost_weight
        self.clearance_cost_weight = clearance_cost_weight
        self.clearance_distance = float(clearance_distance)
        self.collision_penalty = collision_penalty
        self.terminate_on_collision = terminate_on_collision

        self.xml_file = Path(xml_file) if xml_file is not None else self.robot.scene_file
        self.model, _ = build_model(
            self.xml_file,
            self.arena_size,
            self.num_obstacles[1],
            self._ARENA_MEMORY,
            self.robot.arena.obstacle_height,
        )
        self.model.opt.timestep = control_timestep / physics_substeps
        self._size_framebuffer(
            (render_width, render_height),
            (camera_width or _DEFAULT_CAMERA_SIZE, camera_height or _DEFAULT_CAMERA_SIZE),
        )
        # Per env: videos play at real speed for any control step, and only the render modes
        # that work here are listed (Gymnasium's check_env makes the env in each listed mode).
        self.metadata = {
            **self.metadata,
            "render_modes": render_modes_here(self.metadata["render_modes"]),
            "render_fps": 1.0 / control_timestep,
        }
        self.model.actuator_ctrlrange[:] = (-max_wheel_speed, max_wheel_speed)
        self.data = mujoco.MjData(self.model)
        self._slots = ObstacleSlots(self.model, self.num_obstacles[1])
        self.layout: ArenaLayout | None = None

        self.drive = DiffDrive.from_model(self.model, max_wheel_speed)
        self.max_linear_speed = float(max_linear_speed or self.drive.max_linear_speed)
        self.max_angular_speed = float(max_angular_speed or self.drive.max_angular_speed)
        check_positive("max_linear_speed", self.max_linear_speed)
        check_positive("max_angular_speed", self.max_angular_speed)

        self._build_sensors(
            (*laser, laser_noise_std),
            (*proximity, proximity_radiation_type),
            (camera_width, camera_height) if camera or camera_width or camera_height else None,
            camera_shadows,
            control_timestep,
        )
        if self.camera_spec is not None and obs_mode == "flat":
            raise ValueError(
                "obs_mode='flat' has no place for the camera image; use obs_mode='dict' with "
                "the camera, or drop camera/camera_width/camera_height"
            )
        analytic = self._choose_caster(laser_backend)
        self.static_transforms: tuple[StaticTransform, ...] = static_transforms(
            self.model, self.robot.frames
        )
        self.specs = EnvSpecs(
            self.laser_spec,
            self.proximity_spec,
            self.camera_spec,
            self.static_transforms,
            self.drive,
            self.action_type,
            self.max_linear_speed,
            self.max_angular_speed,
            self.odometry_noise,
            self.robot.name,
            self.robot.laser.publish_every,
        )
        """The env's own description as plain data (what the ROS layer and policies read)."""

        self._index_model()
        self._build_spaces()

        self._render_size = (render_width, render_height)
        self._overhead: OverheadRenderer | None = None
        # The window opens on the first render, but a missing display is reported now.
        self._viewer: HumanViewer | None = None
        if render_mode == "human":
            HumanViewer.require_display()
        self._last_laser: NDArray[np.float32] | None = None
        self._clipped_actions = 0
        self._collided = False
        self._closed = False
        self._analytic = analytic
        self._bind_views()

    def _choose_caster(self, laser_backend: str) -> bool:
        """Whether the analytic caster runs (see ``laser_backend``); names it in the laser spec."""
        if self.laser_spec is None:
            return False
        mujoco.mj_forward(self.model, self.data)
        problems = analytic_unsupported(self.model, self.data, self._slots.geom_ids)
        mujoco.mj_resetData(self.model, self.data)
        if laser_backend == "analytic" and problems:
            raise ValueError(
                f"laser_backend='analytic' cannot cast in the scene {self.xml_file.name}: "
                f"{'; '.join(problems[:5])} (it models upright boxes and cylinders); use "
                "laser_backend='auto' or 'mujoco'"
            )
        analytic = laser_backend != "mujoco" and not problems
        caster = "analytic" if analytic else "mujoco"
        self.laser_spec = dataclasses.replace(self.laser_spec, caster=caster)
        if self._laser is not None:
            self._laser.spec = self.laser_spec
        return analytic

    def _build_sensors(
        self,
        laser: tuple[int, float, float, float, float],
        proximity: tuple[float, float, str],
        camera_size: tuple[int | None, int | None] | None,
        camera_shadows: bool,
        control_timestep: float,
    ) -> None:
        """The laser (none with 0 rays), the nose sensor and the camera (when sized or asked)."""
        self.laser_spec = None
        self._laser = None
        if laser[0] > 0:
            self.laser_spec = LaserSpec(*laser, scan_time=control_timestep)
            self._laser = Laser(self.model, self.laser_spec)
        self.proximity_spec = ProximitySpec(
            proximity[0], proximity[1], radiation_type=str(proximity[2])
        )
        self.camera_spec = None
        self._camera = None
        if camera_size is not None:
            self.camera_spec = CameraSpec(
                camera_size[0] or _DEFAULT_CAMERA_SIZE,
                camera_size[1] or _DEFAULT_CAMERA_SIZE,
                float(self.model.cam_fovy[self.model.camera(names.FRONT_CAMERA).id]),
                shadows=camera_shadows,
                reflections=camera_shadows,
            )
            self._camera = CameraSensor(self.model, self.camera_spec)

    def _index_model(self) -> None:
        """Ids that resets read."""
        # A list: indexing it with a few contacts' geom ids is faster than numpy fancy indexing.
        self._is_obstacle: list[bool] = (self.model.geom_group == names.OBSTACLE_GROUP).tolist()
        self._base = self.model.body(names.BASE_BODY).id
        self._root_qpos = int(self.model.joint(names.ROOT_JOINT).qposadr[0])
        # The step's sensordata addresses are the kernel's settings (core/robots.py).

    def _build_spaces(self) -> None:
        """Action and observation spaces, from the sensor specs and the speed limits."""
        self.action_space = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
        self._velocity_limit = np.array([2 * self.max_linear_speed, 2 * self.max_angular_speed])
        obs_spaces: dict[str, spaces.Space[Any]] = {}
        if self.laser_spec is not None:
            laser = self.laser_spec
            obs_spaces["laser"] = spaces.Box(0.0, laser.range_max, (laser.num_rays,), np.float32)
        proximity_max = self.proximity_spec.range_max
        obs_spaces["proximity"] = spaces.Box(0.0, proximity_max, (1,), np.float32)
        obs_spaces["velocity"] = spaces.Box(
            -self._velocity_limit.astype(np.float32),
            self._velocity_limit.astype(np.float32),
            dtype=np.float32,
        )
        if self.camera_spec is not None:
            shape = (self.camera_spec.height, self.camera_spec.width, 3)
            obs_spaces["camera"] = spaces.Box(0, 255, shape, np.uint8)
        self.dict_observation_space = spaces.Dict(obs_spaces)
        """The ``Dict`` space, whatever ``obs_mode`` is."""
        self.observation_layout: dict[str, slice] = {}
        """``obs_mode="flat"``: each reading's slice of the flat observation."""
        if self.obs_mode == "dict":
            self.observation_space = self.dict_observation_space  # type: ignore[assignment]
            return
        lows, highs, start = [], [], 0
        for key, box in obs_spaces.items():
            assert isinstance(box, spaces.Box)
            self.observation_layout[key] = slice(start, start + box.shape[0])
            start += box.shape[0]
            lows.append(box.low)
            highs.append(box.high)
        self.observation_space = spaces.Box(
            np.concatenate(lows), np.concatenate(highs), dtype=np.float32
        )

    def _bind_views(self, sensing: bool = True) -> None:
        # Views into self.data and the kernel's addresses of this robot's model and data;
        # rebuilt after unpickling (a copy has new data, and Ray hands back read-only arrays).
        self._warnings = self.data.warning.number
        if sensing:  # else the caller attaches the env to a batch's buffers (_attach)
            shared = getattr(self, "_core", None)  # a clone's (see _spawn) shares the tables
            self._attach(RobotBatch([self], self._analytic, shared.tables if shared else None), 0)

    def _attach(self, core: RobotBatch, row: int, odometry: Odometry | None = None) -> None:
        """Step and observe through row ``row`` of ``core`` (a batch attaches its robots).

        The odometry is row ``row`` of ``odometry`` (a batch's); None: one of the env's own,
        which carries on the state the env had (an unpickled env, a copy).
        """
        self._core, self._row = core, row
        self._one_robot = np.array([row], dtype=np.int64)
        core.refresh_geoms(row, self.model)
        if odometry is None:
            odometry = Odometry(1, self.drive.wheel_separation, self.odometry_noise)
            previous: Odometry | None = getattr(self, "_odometry", None)
            if previous is not None:
                odometry.state[0] = previous.state[self._odometry_row]
        self._odometry, self._odometry_row = odometry, row

    def _size_framebuffer(self, *sizes: tuple[int, int]) -> None:
        # Renderers need an offscreen buffer at least as large as their image.
        global_ = self.model.vis.global_
        global_.offwidth = max(global_.offwidth, *(width for width, _ in sizes))
        global_.offheight = max(global_.offheight, *(height for _, height in sizes))

    @property
    def dt(self) -> float:
        """Seconds of simulated time per ``step``."""
        return float(self.model.opt.timestep) * self.physics_substeps

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Observation, dict[str, Any]]:
        """Draw a new arena layout and start pose (see Starting State)."""
        self._check_open("reset")
        self._place_layout(seed)
        mujoco.mj_forward(self.model, self.data)
        if self.start_pose is not None and self._in_collision():
            raise ValueError(
                f"start_pose {self.start_pose} overlaps a wall or obstacle of the scene "
                f"{self.xml_file.name}; choose a free pose"
            )
        self._clipped_actions = 0
        self._collided = False
        core = self._core
        core.refresh_geoms(self._row, self.model)
        self._draw_noise()
        core.observe(self._one_robot)
        row = core.out[self._row]
        self._odometry.reset(self._row, row)
        row[OUT.COLLISION] = row[OUT.CLIPPED] = 0.0
        row[OUT.WHEEL_COMMAND : OUT.WHEEL_COMMAND + 2] = 0.0
        row[OUT.REWARD : OUT.COLLISION_COST + 1] = 0.0
        obs = self._observation()
        info = self._info()
        if self.render_mode == "human":
            self.render()
        return obs, info

    def _place_layout(self, seed: int | None) -> None:
        """Seed the generator, draw the layout, write it and the start pose into MuJoCo.

        The part of ``reset`` that MuJoCo Warp's layout tables share (before ``mj_forward``).
        """
        super().reset(seed=seed)
        self.layout = sample_layout(
            self.np_random,
            self.arena_size,
            self.num_obstacles,
            self.obstacle_size,
            self.start_clearance,
            self.start_pose,
            self.robot.radius,
        )
        if self.obstacle_colours:
            self.layout = colour_obstacles(self.np_random, self.layout)
        mujoco.mj_resetData(self.model, self.data)
        self._slots.apply(self.model, self.data, self.layout.obstacles)
        x, y, yaw = self.layout.start_pose
        adr = self._root_qpos
        self.data.qpos[adr : adr + 3] = (x, y, self.model.body_pos[self._base][2])
        self.data.qpos[adr + 3 : adr + 7] = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))

    def step(
        self, action: NDArray[np.float32]
    ) -> tuple[Observation, float, bool, bool, dict[str, Any]]:
        """Apply ``action`` for one control step (see Action Space)."""
        self._check_open("step")
        if self.layout is None:
            raise RuntimeError("step() called before reset(): reset the env first")
        core = self._core
        core.actions[self._row] = self._checked_action(action)
        self._draw_noise()
        # The kernel does what this method did in Python, with the same arithmetic: step2 then
        # step1 per substep (kinematics, contacts and sensors of the final state), a contact
        # check after every substep (a touch that begins and ends inside one control step is
        # still a collision), the sensors, the reward and its parts.
        core.step(self._one_robot)
        values = core.out[self._row].tolist()
        slip = draw_slip(self.np_random, self.odometry_noise)[None] if self.odometry_noise else None
        self._odometry.advance_one(self._odometry_row, values, slip)
        collision = values[_COLLISION] != 0.0
        self._clipped_actions += values[_CLIPPED] != 0.0
        diverged = self._diverged() if values[_DIVERGED] else ""
        obs = self._observation()
        reward = values[_REWARD]
        terminated = collision and self.terminate_on_collision
        self._collided = self._collided or collision
        if self.render_mode == "human":
            self.render()
        info = self._info()
        # Success so far: on the episode's last step, whether the episode is a success.
        info["is_success"] = not (self._collided or diverged)
        if diverged:
            info["physics_diverged"] = diverged
        return obs, reward, terminated, bool(diverged), info

    def _checked_action(self, action: NDArray[np.float32]) -> tuple[float, float]:
        """The action as two finite floats, or a ``ValueError`` saying what is wrong."""
        try:
            raw = np.asarray(action, dtype=np.float64)
        except (TypeError, ValueError, OverflowError) as error:
            raise ValueError(
                f"action must be 2 finite numbers (clipped to [-1, 1]), got {action!r}: {error}"
            ) from None
        if raw.shape != (2,):
            shown = raw.ravel()[:4].tolist()  # a list stays on one line; numpy's repr wraps
            more = ", ..." if raw.size > 4 else ""
            raise ValueError(
                f"action must have shape (2,), got shape {raw.shape}: {str(shown)[:-1]}{more}]"
            )
        a0, a1 = raw.tolist()
        if not (math.isfinite(a0) and math.isfinite(a1)):
            raise ValueError(
                f"action {[a0, a1]} contains NaN or infinity; actions must be finite numbers, "
                "and are clipped to [-1, 1]"
            )
        return a0, a1

    def _draw_noise(self) -> None:
        # Laser noise comes from the episode's generator, one draw per scan, as before.
        spec = self.laser_spec
        if spec is not None and spec.noise_std > 0.0:
            noise = self.np_random.normal(0.0, spec.noise_std, size=spec.num_rays)
            self._core.noise[self._row] = noise

    def _diverged(self) -> str:
        """MuJoCo's divergence warning from this step, or ``""``.

        MuJoCo resets the state by itself when the accelerations blow up, so the episode is
        truncated with the reason in ``info["physics_diverged"]`` and a logged warning.
        """
        counts = self._warnings
        if not (counts[_BADQACC] or counts[_BADQPOS] or counts[_BADQVEL]):
            return ""
        for warning in _DIVERGENCE_WARNINGS:
            if counts[warning]:
                message = (
                    f"MuJoCo reported {warning.name} (the simulation diverged and MuJoCo reset "
                    f"it) at sim time {self.data.time:.3f} s; the episode is truncated. Lower "
                    f"control_timestep / physics_substeps (now {self.model.opt.timestep} s)."
                )
                gym.logger.warn(message)
                return message
        return ""

    def __getstate__(self) -> dict[str, Any]:
        # Windows and OpenGL contexts cannot be pickled or deep-copied; a copy (SB3, RLlib and
        # vector envs pickle envs) re-creates them on first use, as the original did.
        state = {**self.__dict__, "_overhead": None, "_viewer": None}
        for view in _DATA_VIEWS:
            state.pop(view, None)
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._bind_views()

    def _spawn(self) -> BubbleRobEnv:
        """A new env with these arguments, sharing what steps never change (spaces, specs).

        For batches (:mod:`bubblerob_env.vector`): cheaper in time and memory than building or
        deep-copying. Call it on an env that was never reset: the clone copies its model, gets
        its own data and random generator, and behaves exactly as a new env once the batch has
        attached it to a row of its buffers (:meth:`_attach`).
        """
        clone = copy.copy(self)
        clone.model = copy.copy(self.model)  # resets write obstacle sizes into the model
        clone.data = mujoco.MjData(clone.model)
        if self.camera_spec is not None:
            clone._camera = CameraSensor(clone.model, self.camera_spec)
        clone._np_random = clone._np_random_seed = None
        clone.layout = clone._last_laser = None
        clone._bind_views(sensing=False)
        return clone

    def _check_open(self, method: str) -> None:
        if self._closed:
            raise RuntimeError(f"{method}() called after close(); make a new env")

    def _observation(self) -> Observation:
        """The kernel's readings of this robot as an observation (copies: buffers are reused)."""
        core, row = self._core, self._row
        obs: dict[str, NDArray[Any]] = {}
        if self.laser_spec is not None:
            obs["laser"] = self._last_laser = core.laser[row].copy()
        obs["proximity"] = core.proximity[row].copy()
        obs["velocity"] = core.velocity[row].copy()
        if self._camera is not None:
            obs["camera"] = self._camera(self.model, self.data)
        if self.obs_mode == "flat":
            return np.concatenate(list(obs.values()))
        return obs

    def _in_collision(self) -> bool:
        # Only robot geoms collide with walls and obstacles (contype/conaffinity in the MJCF).
        ncon = self.data.ncon
        if not ncon:
            return False
        is_obstacle = self._is_obstacle
        for geom1, geom2 in self.data.contact.geom[:ncon].tolist():
            if is_obstacle[geom1] or is_obstacle[geom2]:
                return True
        return False

    def _info(self) -> dict[str, Any]:
        """``info`` from the kernel's numbers for this robot."""
        return robot_info(
            self._core,
            self._row,
            self.proximity_spec.trigger_distance,
            self._clipped_actions,
            self._odometry.poses,
        )

    def render(self) -> NDArray[np.uint8] | None:
        """``rgb_array``: overhead frame with the laser drawn; ``human``: update the window."""
        self._check_open("render")
        if self.render_mode == "human":
            if self._viewer is None:
                self._viewer = HumanViewer(self.model, self.data)
            self._viewer.render()
            return None
        if self.render_mode != "rgb_array":
            return None
        if self._overhead is None:
            self._overhead = OverheadRenderer(self.model, *self._render_size, self.arena_size + 0.3)
        if self._laser is None or self._last_laser is None or self.laser_spec is None:
            return self._overhead.render(self.data)
        origin, points = self._laser.endpoints(self.data, self._last_laser)
        hit = self._last_laser < self.laser_spec.range_max
        return self._overhead.render(self.data, origin, points, hit)

    def close(self) -> None:
        """Free renderers and windows; the env cannot step again afterwards."""
        self._closed = True
        for closable in (self._camera, self._overhead, self._viewer):
            if closable is not None:
                closable.close()
        self._camera = self._overhead = self._viewer = None
