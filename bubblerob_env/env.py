"""``BubbleRob-v0``: obstacle avoidance with a differential-drive robot in MuJoCo.

This module is the Gymnasium face: spaces, reset, step, render and pickling. The checked
arguments are an :class:`~bubblerob_env.config.EnvConfig`; the model, data, sensors and arena
placement a :class:`~bubblerob_env.scene.Scene`; the step runs in the numba kernel through a
:class:`~bubblerob_env.core.batch.RobotBatch` of one robot (a batch attaches the env to a row of
its own), and :class:`~bubblerob_env.batch.common.ObservationFormat` builds the observation.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from bubblerob_env.arena import ArenaLayout
from bubblerob_env.batch.common import Observation, ObservationFormat, checked_action
from bubblerob_env.config import (
    ACTION_TYPES,
    ARGUMENTS,
    OBS_MODES,
    RENDER_MODES,
    ConfigField,
    EnvConfig,
)
from bubblerob_env.core.batch import RobotBatch
from bubblerob_env.core.kernel import OUT
from bubblerob_env.infos import robot_info, row_info
from bubblerob_env.kinematics import DiffDrive
from bubblerob_env.odometry import Odometry, draw_slip
from bubblerob_env.rendering import EnvViews, render_modes_here
from bubblerob_env.robots import RobotDescription
from bubblerob_env.scene import Scene, SceneField
from bubblerob_env.sensors import CameraSpec, LaserSpec, ProximitySpec, StaticTransform
from bubblerob_env.specs import EnvSpecs

__all__ = ["ACTION_TYPES", "OBS_MODES", "BubbleRobEnv", "Observation"]

# The kernel's buffers, views of this robot's rows and the bound kernel: attached again, never
# pickled.
_VIEWS = (
    "_core",
    "_one_robot",
    "_row",
    "_step_kernel",
    "_action_row",
    "_out_row",
    "_laser_row",
    "_proximity_row",
    "_velocity_row",
)
# Actions whose values need no checking beyond finiteness (numpy's own float arrays).
_FLOAT32, _FLOAT64 = np.dtype(np.float32), np.dtype(np.float64)
# The kernel's result columns the step reads, as plain ints (faster to index with than enums).
_COLLISION, _CLIPPED, _DIVERGED, _REWARD = (
    int(c) for c in (OUT.COLLISION, OUT.CLIPPED, OUT.DIVERGED, OUT.REWARD)
)


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
    Every argument of ``__init__`` is a keyword argument of ``gym.make("BubbleRob-v0", ...)``;
    unknown ones raise ``TypeError`` in Python's wording ("got an unexpected keyword argument
    'x'") followed by the valid names, and bad values raise ``ValueError`` naming the value and
    what is allowed.
    :class:`~bubblerob_env.config.EnvConfig` documents each one.

    ## Version History
    - v0 (2026-11-27, issue #41): a reset puts the robot where it rests (sunk 0.26 mm into the
      soft floor contacts, pitched 0.3 mrad; found by letting it settle once when the scene is
      built), not at the compiled pose that touched the floor at distance 0. There each contact
      was active or not by the sign of rounding noise, so on some seeds the first substep was a
      free fall (wheels spinning up to 5.52 rad/s in the air), and MuJoCo Warp's float32 decided
      differently from float64 (seed 3: 4.95 rad/s). Episodes change slightly (the first
      substeps; the robot no longer drops and bounces); the shipped policies' test table was
      re-run.
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

    metadata = {"render_modes": list(RENDER_MODES), "render_fps": 20}
    # The arguments, as the env's config holds them (the robot's values where None was given);
    # setting one (as VectorEnv.set_attr does) gives the env a config with the new value.
    robot = ConfigField[RobotDescription]()
    """The robot's description (sizes, sensors, frames, limits, arena)."""
    xml_file = ConfigField[Path]()
    action_type = ConfigField[str]()
    physics_substeps = ConfigField[int]()
    odometry_noise = ConfigField[float]()
    obs_mode = ConfigField[str]()
    obstacle_colours = ConfigField[bool]()
    arena_size = ConfigField[float]()
    num_obstacles = ConfigField[tuple[int, int]]()
    obstacle_size = ConfigField[tuple[float, float]]()
    start_clearance = ConfigField[float]()
    start_pose = ConfigField[tuple[float, float, float] | None]()
    forward_reward_weight = ConfigField[float]()
    spin_cost_weight = ConfigField[float]()
    clearance_cost_weight = ConfigField[float]()
    clearance_distance = ConfigField[float]()
    collision_penalty = ConfigField[float]()
    terminate_on_collision = ConfigField[bool]()
    # What the scene made of them.
    model = SceneField[mujoco.MjModel]("model")
    data = SceneField[mujoco.MjData]("data")
    laser_spec = SceneField[LaserSpec | None]("laser_spec")
    proximity_spec = SceneField[ProximitySpec]("proximity_spec")
    camera_spec = SceneField[CameraSpec | None]("camera_spec")
    static_transforms = SceneField[tuple[StaticTransform, ...]]("static_transforms")
    specs = SceneField[EnvSpecs]("specs")
    """The env's own description as plain data (what the ROS layer and policies read)."""
    drive = SceneField[DiffDrive]("limits.drive")
    max_linear_speed = SceneField[float]("limits.max_linear_speed")
    max_angular_speed = SceneField[float]("limits.max_angular_speed")
    _odometry: Odometry
    _odometry_row: int

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
        camera: bool | None = None,
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
        """Build the env from its keyword arguments (see Arguments).

        :class:`~bubblerob_env.config.EnvConfig` documents and checks each one; every argument
        whose default is ``None`` takes the robot's value (:mod:`bubblerob_env.robots`).
        Unknown names are rejected with a ``TypeError`` listing the valid names.
        """
        given = {name: value for name, value in locals().items() if name in ARGUMENTS}
        self._setup(Scene(EnvConfig.from_kwargs({**given, **unknown_kwargs})))

    @property
    def config(self) -> EnvConfig:
        """The env's checked arguments (its scene's)."""
        return self.scene.config

    @config.setter
    def config(self, config: EnvConfig) -> None:
        self.scene.config = config

    @classmethod
    def from_config(cls, config: EnvConfig, arena_memory: int | None = None) -> BubbleRobEnv:
        """The env of a checked ``config``; ``arena_memory`` as :class:`Scene`'s (batches)."""
        env = cls.__new__(cls)
        env._setup(Scene(config, arena_memory))
        return env

    def _setup(self, scene: Scene) -> None:
        self.scene = scene
        """The model, data, obstacle slots and sensors (:class:`~bubblerob_env.scene.Scene`)."""
        config = scene.config
        self.render_mode = config.render_mode
        # Per env: videos play at real speed for any control step, and only the render modes
        # that work here are listed (Gymnasium's check_env makes the env in each listed mode).
        self.metadata = {
            **self.metadata,
            "render_modes": render_modes_here(self.metadata["render_modes"]),
            "render_fps": 1.0 / config.control_timestep,
        }
        self.layout: ArenaLayout | None = None
        self.observation_format = ObservationFormat(scene)
        """The observation's spaces and assembly (shared with the batches)."""
        self.action_space = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
        self.dict_observation_space = self.observation_format.dict_space
        """The ``Dict`` space, whatever ``obs_mode`` is."""
        self.observation_layout = self.observation_format.layout
        """``obs_mode="flat"``: each reading's slice of the flat observation."""
        self.observation_space = self.observation_format.space
        size = (config.render_width, config.render_height)
        self._views = EnvViews(config.render_mode, size, config.arena_size + 0.3)
        self.last_laser: NDArray[np.float32] | None = None
        """The last scan, which ``render`` draws (a batch sets it before rendering)."""
        self._clipped_actions = 0
        self._collided = False
        self._closed = False
        self.attach(RobotBatch(config, [scene]), 0)

    def attach(self, core: RobotBatch, row: int, odometry: Odometry | None = None) -> None:
        """Step and observe through row ``row`` of ``core`` (a batch attaches its robots).

        The odometry is row ``row`` of ``odometry`` (a batch's); None: one of the env's own,
        which carries on the state the env had (an unpickled env, a copy).
        """
        self._core, self._row = core, row
        self._one_robot = np.array([row], dtype=np.int64)
        self._step_kernel: Callable[[], None] | None = None  # bound on the first step
        # Views of this robot's rows (the buffers are written in place, never replaced).
        self._action_row, self._out_row = core.actions[row], core.out[row]
        self._laser_row, self._proximity_row = core.laser[row], core.proximity[row]
        self._velocity_row = core.velocity[row]
        core.refresh_geoms(row, self.scene.model)
        if odometry is None:
            odometry = Odometry(1, self.drive.wheel_separation, self.odometry_noise)
            previous: Odometry | None = getattr(self, "_odometry", None)
            if previous is not None:
                odometry.state[0] = previous.state[self._odometry_row]
        self._odometry, self._odometry_row = odometry, row

    @property
    def dt(self) -> float:
        """Seconds of simulated time per ``step``."""
        return float(self.scene.model.opt.timestep) * self.physics_substeps

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Observation, dict[str, Any]]:
        """Draw a new arena layout and start pose (see Starting State)."""
        self._check_open("reset")
        super().reset(seed=seed)
        self.layout = self.scene.place_layout(self.np_random)
        self.scene.forward()
        self._clipped_actions = 0
        self._collided = False
        self._draw_noise()
        self._core.start(self._row, self.scene.model)
        self._odometry.reset(self._row, self._core.out[self._row])
        obs = self._observation()
        info = self._info()
        if self.render_mode == "human":
            self.render()
        return obs, info

    def step(
        self, action: NDArray[np.float32]
    ) -> tuple[Observation, float, bool, bool, dict[str, Any]]:
        """Apply ``action`` for one control step (see Action Space)."""
        self._check_open("step")
        if self.layout is None:
            raise RuntimeError("step() called before reset(): reset the env first")
        self._action_row[0], self._action_row[1] = _action_values(action)
        self._draw_noise()
        # The kernel does what this method did in Python, with the same arithmetic: step2 then
        # step1 per substep (kinematics, contacts and sensors of the final state), a contact
        # check after every substep (a touch that begins and ends inside one control step is
        # still a collision), the sensors, the reward and its parts.
        (self._step_kernel or self._bind_kernel())()
        out = self._out_row.copy()  # one copy: info's arrays are views into it
        values = out.tolist()
        slip = draw_slip(self.np_random, self.odometry_noise)[None] if self.odometry_noise else None
        odometry = self._odometry.advance_one(self._odometry_row, values, slip)
        collision = values[_COLLISION] != 0.0
        self._clipped_actions += values[_CLIPPED] != 0.0
        diverged = self.scene.diverged() if values[_DIVERGED] else ""
        obs = self._observation()
        terminated = collision and self.terminate_on_collision
        self._collided = self._collided or collision
        if self.render_mode == "human":
            self.render()
        info = row_info(
            out,
            values,
            odometry,
            self._proximity_row.item(),
            self.scene.proximity_spec.trigger_distance,
            self._clipped_actions,
        )
        # Success so far: on the episode's last step, whether the episode is a success.
        info["is_success"] = not (self._collided or diverged)
        if diverged:
            info["physics_diverged"] = diverged
        return obs, values[_REWARD], terminated, bool(diverged), info

    def _bind_kernel(self) -> Callable[[], None]:
        self._step_kernel = self._core.stepper(self._one_robot)
        return self._step_kernel

    def _draw_noise(self) -> None:
        # Laser noise comes from the episode's generator, one draw per scan, as before.
        spec = self.scene.laser_spec
        if spec is not None and spec.noise_std > 0.0:
            noise = self.np_random.normal(0.0, spec.noise_std, size=spec.num_rays)
            self._core.noise[self._row] = noise

    def __getstate__(self) -> dict[str, Any]:
        # A copy (SB3, RLlib and vector envs pickle envs) makes its own windows and OpenGL
        # contexts (EnvViews, CameraSensor) on first use, and binds to a kernel batch of its own.
        return {key: value for key, value in self.__dict__.items() if key not in _VIEWS}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self.attach(RobotBatch(self.scene.config, [self.scene]), 0)

    def spawn(self) -> BubbleRobEnv:
        """A new env with these arguments on a clone of the scene (:meth:`Scene.spawn`).

        For batches (:mod:`bubblerob_env.batch.cpu`): cheaper in time and memory than building.
        Call it on an env that was never reset: the clone has its own scene and random
        generator, and behaves exactly as a new env once a batch has attached it to a row of its
        buffers (:meth:`attach`).
        """
        clone = object.__new__(type(self))
        clone.__dict__.update(
            {key: value for key, value in self.__dict__.items() if key not in _VIEWS}
        )
        clone.scene = self.scene.spawn()
        clone._np_random = clone._np_random_seed = None
        clone.layout = clone.last_laser = None
        clone._views = copy.copy(self._views)  # its own renderer, made on first use
        return clone

    def _check_open(self, method: str) -> None:
        if self._closed:
            raise RuntimeError(f"{method}() called after close(); make a new env")

    def _observation(self) -> Observation:
        """The kernel's readings of this robot as an observation (copies: buffers are reused)."""
        scene = self.scene
        laser = None
        if scene.laser_spec is not None:
            laser = self.last_laser = self._laser_row.copy()
        proximity, velocity = self._proximity_row.copy(), self._velocity_row.copy()
        camera = scene.camera(scene.model, scene.data) if scene.camera is not None else None
        obs: Observation = self.observation_format.assemble(laser, proximity, velocity, camera)
        return obs

    def _info(self) -> dict[str, Any]:
        """``info`` from the kernel's numbers for this robot."""
        return robot_info(
            self._core,
            self._row,
            self.scene.proximity_spec.trigger_distance,
            self._clipped_actions,
            self._odometry.poses,
        )

    def render(self) -> NDArray[np.uint8] | None:
        """``rgb_array``: overhead frame with the laser drawn; ``human``: update the window."""
        self._check_open("render")
        scene, spec = self.scene, self.scene.laser_spec
        range_max = spec.range_max if spec is not None else 0.0
        return self._views.render(scene.model, scene.data, scene.laser, self.last_laser, range_max)

    def close(self) -> None:
        """Free renderers and windows; the env cannot step again afterwards."""
        self._closed = True
        self.scene.close()
        self._views.close()


def _action_values(action: Any) -> tuple[float, float]:
    """:func:`checked_action`, with a shortcut for what agents pass: a float array of 2.

    Its values as Python floats are exactly those ``np.asarray(action, np.float64)`` holds;
    anything else (lists, other dtypes, shapes, NaN) takes the full check and its messages.
    """
    if type(action) is np.ndarray and action.shape == (2,):
        dtype = action.dtype
        if dtype is _FLOAT32 or dtype is _FLOAT64:
            a0, a1 = action.tolist()
            if math.isfinite(a0) and math.isfinite(a1):
                return a0, a1
    return checked_action(action)
