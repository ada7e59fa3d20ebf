"""Several robots in one world as a PettingZoo ``ParallelEnv``: :func:`parallel_env`.

Each agent is one robot with the single env's spaces, reward and ``info``; all robots share one
MuJoCo world (:class:`~bubblerob_env.multi.scene.WorldScene`), stepped in one numba call
(:class:`~bubblerob_env.core.worlds.WorldBatch`). A robot that touches a wall, an obstacle or
another robot terminates (with ``terminate_on_collision``), and so does the robot it touched;
``info["collided_with"]`` names the other robot or says ``"obstacle"``. A terminated robot
leaves ``agents`` and stays where it stopped, wheels commanded to 0: an obstacle to the others.
``max_episode_steps`` truncates every robot. One robot (``scenario="random"``) gives
``BubbleRob-v0``'s episodes bit for bit.

``task="nav"`` gives each robot its own goal (:mod:`~bubblerob_env.multi.goals`), its
``goal`` reading, the single Nav task's reward parts and ``info``, and success: a robot within
``goal_radius`` of its goal terminates with ``is_success`` and stays there, stopped, an
obstacle to the others (as Long et al.'s arrived robots).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import mujoco
import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from numpy.typing import NDArray
from pettingzoo import ParallelEnv

from bubblerob_env.arena import ArenaLayout
from bubblerob_env.batch.common import Observation, ObservationFormat, checked_action
from bubblerob_env.core.kernel import OUT
from bubblerob_env.core.worlds import WorldBatch
from bubblerob_env.infos import robot_info
from bubblerob_env.multi.goals import WorldGoals, task_config, task_settings
from bubblerob_env.multi.placement import check_circle_jitter, check_fits, sample_world
from bubblerob_env.multi.scene import WorldScene, agent_name, partner_name
from bubblerob_env.odometry import Odometry, draw_slip
from bubblerob_env.rendering import EnvViews
from bubblerob_env.tasks.nav_rules import spaces_with_goal, with_goal

__all__ = ["MultiRobotEnv", "parallel_env"]

Pose = tuple[float, float, float]

_ONE_WORLD = np.zeros(1, dtype=np.int64)
_WORLD_TRIES = 20  # worlds drawn before giving up on goals for every robot (never needed)


def parallel_env(
    num_robots: int = 2,
    robot: str = "bubblerob",
    scenario: str = "random",
    max_episode_steps: int = 1000,
    task: str = "wander",
    **kwargs: Any,
) -> MultiRobotEnv:
    """``num_robots`` robots (``"bubblerob"`` or ``"pioneer_p3dx"``) in one world.

    ``scenario``: ``"random"`` free start poses, ``"circle"`` on a circle facing its centre;
    ``task``: ``"wander"`` (``BubbleRob-v0``'s) or ``"nav"`` (each robot to its goal, with
    ``BubbleRobNav-v0``'s arguments: ``goal_radius`` ...); ``circle_jitter`` (m, default 0): a
    seed turns the circle and moves each robot along it by up to that arc
    (:mod:`~bubblerob_env.multi.placement`); ``kwargs``: the single env's
    (``gym.make("BubbleRob-v0", **kwargs)``).
    """
    return MultiRobotEnv(num_robots, robot, scenario, max_episode_steps, task, **kwargs)


# PettingZoo ships no type information: its ParallelEnv is Any to mypy.
class MultiRobotEnv(ParallelEnv[str, Observation, NDArray[np.float32]]):  # type: ignore[misc]
    """The PettingZoo env of :func:`parallel_env`; agents ``<robot>_0`` .. ``<robot>_<N-1>``."""

    metadata = {"name": "bubblerob_multi_v0", "render_modes": ["rgb_array"], "render_fps": 20}

    def __init__(
        self,
        num_robots: int = 2,
        robot: str = "bubblerob",
        scenario: str = "random",
        max_episode_steps: int = 1000,
        task: str = "wander",
        circle_jitter: float = 0.0,
        **kwargs: Any,
    ) -> None:
        settings = task_settings(task, kwargs)
        if isinstance(num_robots, bool) or not isinstance(num_robots, int) or num_robots < 1:
            raise ValueError(f"num_robots must be an integer >= 1, got {num_robots!r}")
        if isinstance(max_episode_steps, bool) or not isinstance(max_episode_steps, int):
            raise ValueError(f"max_episode_steps must be an integer, got {max_episode_steps!r}")
        if max_episode_steps < 1:
            raise ValueError(f"max_episode_steps must be >= 1, got {max_episode_steps}")
        if kwargs.get("render_mode") not in (None, "rgb_array"):
            raise ValueError(
                f"render_mode must be None or 'rgb_array', got {kwargs['render_mode']!r}"
            )
        config = task_config(settings, scenario, num_robots, kwargs, robot)  # room to pass
        check_fits(config, num_robots, scenario)
        self.circle_jitter = check_circle_jitter(config, num_robots, scenario, circle_jitter)
        self.robot_kwargs = {**kwargs, "robot": robot, "arena_size": config.arena_size}
        """One robot's single-env arguments (``BubbleRob-v0``'s; the world's arena)."""
        self.config = config
        self.task = task
        self.goals = None if settings is None else WorldGoals(settings, config, num_robots)
        """Each robot's goal and progress with ``task="nav"`` (else None)."""
        self.layout = ArenaLayout((), (0.0, 0.0, 0.0))
        """The obstacles and robot 0's start pose (after a reset)."""
        self.scenario = scenario
        self.max_episode_steps = max_episode_steps
        self.render_mode = config.render_mode
        self.metadata = {**self.metadata, "render_fps": 1.0 / config.control_timestep}
        self.world = WorldScene(config, num_robots)
        scene = self.world.scene
        self.batch = WorldBatch(
            config, [scene], self.world.robots, self.world.geom_robot, self.world.window_group
        )
        self.observation_format = ObservationFormat(scene)
        self.possible_agents = [agent_name(config.robot.name, k) for k in range(num_robots)]
        self.agents: list[str] = []
        self._index = {agent: k for k, agent in enumerate(self.possible_agents)}
        self._observation_space = self.observation_format.space
        if self.goals is not None:
            readings = self.observation_format.dict_space
            flat = self._observation_space if config.obs_mode == "flat" else None
            assert flat is None or isinstance(flat, spaces.Box)
            _, self._observation_space, _ = spaces_with_goal(readings, flat, config.arena_size)
        self._action_space = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
        self._odometry = Odometry(
            num_robots, scene.limits.drive.wheel_separation, config.odometry_noise
        )
        self._np_random: np.random.Generator | None = None
        self._steps = 0
        self._collided = [False] * num_robots
        self._clipped = [0] * num_robots
        size = (config.render_width, config.render_height)
        self._views = EnvViews(config.render_mode, size, config.arena_size + 0.3)

    @property
    def num_robots(self) -> int:
        """Robots in the world."""
        return self.world.num_robots

    def observation_space(self, agent: str) -> gym.Space[Any]:
        """The single env's observation space (the same object on every call)."""
        self._check_agent(agent)
        return self._observation_space

    def action_space(self, agent: str) -> gym.Space[Any]:
        """The single env's action space (the same object on every call)."""
        self._check_agent(agent)
        return self._action_space

    def _check_agent(self, agent: str) -> None:
        if agent not in self._index:
            raise ValueError(f"agent must be one of {self.possible_agents}, got {agent!r}")

    @property
    def np_random(self) -> np.random.Generator:
        """The world's generator (layout, start poses, noise)."""
        if self._np_random is None:
            self._np_random, _ = seeding.np_random()
        return self._np_random

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, Observation], dict[str, dict[str, Any]]]:
        """A new layout and start poses; every robot is an agent again.

        ``options``: ``{"start_poses": [(x, y, yaw), ...]}`` one pose per robot and/or
        ``{"obstacles": (Obstacle, ...)}`` replace what the reset draws (a pose that touches
        anything is a ``ValueError``); with ``task="nav"``, ``{"goals": [(x, y), ...]}`` one goal
        per robot (refused as the single Nav env's ``options["goal"]``).
        """
        if seed is not None:
            self._np_random, _ = seeding.np_random(seed)
        options = dict(options or {})
        goals = options.pop("goals", None)
        if goals is not None and self.goals is None:
            raise ValueError("options['goals'] needs task='nav'")
        for _ in range(_WORLD_TRIES):
            drawn, given = self._draw_world(options)
            if self.goals is None:
                break
            if goals is not None or given:
                self._set_goals(drawn, goals)
                break
            layout = self.goals.draw(self.np_random, self.layout, drawn, self.scenario)
            if layout is not None:
                self.layout = layout
                break
        else:
            raise RuntimeError(f"no goal for every robot in {_WORLD_TRIES} worlds: a crowded arena")
        return self._start_world(drawn, given)

    def _set_goals(self, drawn: list[Pose], goals: Any) -> None:
        """Given goals, or goals drawn for given poses or obstacles (one ``ValueError`` line)."""
        assert self.goals is not None
        if goals is not None:
            self.goals.set(self.layout, drawn, goals)
        elif self.goals.draw(self.np_random, self.layout, drawn, "random") is None:
            raise ValueError("no goal can be drawn for every robot from the given start poses")

    def _draw_world(self, options: dict[str, Any]) -> tuple[list[Pose], bool]:
        """The layout (``self.layout``) and start poses, drawn or given; whether given."""
        rng = self.np_random
        scene = self.world.scene
        poses = options.get("start_poses")
        obstacles = options.get("obstacles")
        single = self.num_robots == 1 and self.scenario == "random"
        given = poses is not None or obstacles is not None
        if single:
            self.layout = scene.place_layout(rng)  # exactly the single env's reset
            drawn = [self.layout.start_pose]
        else:
            self.layout, drawn = sample_world(
                rng, self.config, self.num_robots, self.scenario, self.circle_jitter
            )
        if given:
            poses = drawn if poses is None else _checked_poses(poses, self.num_robots)
            obstacles = self.layout.obstacles if obstacles is None else tuple(obstacles)
            self.layout = ArenaLayout(obstacles, poses[0])
            drawn = poses
        return drawn, given

    def _start_world(
        self, drawn: list[Pose], given: bool
    ) -> tuple[dict[str, Observation], dict[str, dict[str, Any]]]:
        """Place the robots at ``drawn`` (robot 0 is there already in a single world)."""
        scene = self.world.scene
        if given or not (self.num_robots == 1 and self.scenario == "random"):
            self._place(drawn)
        scene.forward()
        if given:
            self._check_free()
        self.agents = list(self.possible_agents)
        self._steps = 0
        self._collided = [False] * self.num_robots
        self._clipped = [0] * self.num_robots
        rows = np.arange(self.num_robots, dtype=np.int64)
        self._draw_noise(rows)
        self.batch.start(rows, scene.model)
        for k in range(self.num_robots):
            self._odometry.reset(k, self.batch.core.out[k])
        infos = {agent: self._info(k) for k, agent in enumerate(self.agents)}
        goals = self.goals
        if goals is not None:
            infos = {a: goals.start(k, info) for k, (a, info) in enumerate(infos.items())}
        observations = {agent: self._observation(k) for k, agent in enumerate(self.agents)}
        return observations, infos

    def _place(self, poses: list[tuple[float, float, float]]) -> None:
        scene = self.world.scene
        mujoco.mj_resetData(scene.model, scene.data)
        scene.slots.apply(scene.model, scene.data, self.layout.obstacles)
        for k, pose in enumerate(poses):
            self.world.place_robot(k, pose)

    def _check_free(self) -> None:
        """A ``ValueError`` naming the robot whose given start touches something."""
        model, data = self.world.scene.model, self.world.scene.data
        geom_robot, is_obstacle = self.world.geom_robot, model.geom_group == 0
        for geom1, geom2 in data.contact.geom[: data.ncon].tolist():
            for mine, other in ((geom1, geom2), (geom2, geom1)):
                k, j = int(geom_robot[mine]), int(geom_robot[other])
                if k >= 0 and (is_obstacle[other] or (j >= 0 and j != k)):
                    raise ValueError(
                        f"start pose of {self.possible_agents[k]} touches "
                        f"{self.possible_agents[j] if j >= 0 else 'a wall or obstacle'}; "
                        "choose free poses"
                    )

    def _draw_noise(self, rows: NDArray[np.int64]) -> None:
        # One draw per live robot's scan, in agent order (one robot: the single env's draws).
        spec = self.world.scene.laser_spec
        if spec is not None and spec.noise_std > 0.0:
            for k in rows.tolist():
                self.batch.core.noise[k] = self.np_random.normal(
                    0.0, spec.noise_std, size=spec.num_rays
                )

    def step(
        self, actions: dict[str, NDArray[np.float32]]
    ) -> tuple[
        dict[str, Observation],
        dict[str, float],
        dict[str, bool],
        dict[str, bool],
        dict[str, dict[str, Any]],
    ]:
        """One control step of every live robot; ``actions`` holds one per agent."""
        if not self.agents:
            raise RuntimeError("step() with no live agents: reset() the env first")
        missing = [agent for agent in self.agents if agent not in actions]
        if missing:
            raise ValueError(f"step() needs an action for every live agent; missing {missing}")
        core = self.batch.core
        live = np.array([self._index[agent] for agent in self.agents], dtype=np.int64)
        for agent, k in zip(self.agents, live.tolist(), strict=True):
            core.actions[k] = checked_action(actions[agent])
        self._draw_noise(live)
        self.batch.step(_ONE_WORLD)
        self._steps += 1
        values = core.out.tolist()
        diverged = ""
        if any(values[k][OUT.DIVERGED] for k in live.tolist()):
            diverged = self.world.scene.diverged()
        truncated = bool(diverged) or self._steps >= self.max_episode_steps
        result: tuple[dict[str, Any], ...] = ({}, {}, {}, {}, {})
        for agent, k in zip(self.agents, live.tolist(), strict=True):
            noise = self.config.odometry_noise
            slip = draw_slip(self.np_random, noise)[None] if noise else None
            self._odometry.advance_one(k, values[k], slip)
            collision = values[k][OUT.COLLISION] != 0.0
            self._clipped[k] += values[k][OUT.CLIPPED] != 0.0
            self._collided[k] = self._collided[k] or collision
            info = self._info(k)
            info["is_success"] = not (self._collided[k] or diverged)
            if diverged:
                info["physics_diverged"] = diverged
            if collision:
                info["collided_with"] = self._partner_name(k)
            terminated = collision and self.config.terminate_on_collision
            reward = values[k][OUT.REWARD]
            if self.goals is not None:
                reward, arrived, info = self.goals.step(k, info, truncated)
                terminated = terminated or arrived
            for part, value in zip(
                result,
                (self._observation(k), reward, terminated, truncated, info),
                strict=True,
            ):
                part[agent] = value
        done = [agent for agent in self.agents if result[2][agent] or result[3][agent]]
        for agent in done:
            self.batch.alive[self._index[agent]] = 0
        self.agents = [agent for agent in self.agents if agent not in done]
        observations, rewards, terminations, truncations, infos = result
        return observations, rewards, terminations, truncations, infos

    def _partner_name(self, k: int) -> str:
        return partner_name(int(self.batch.partner[k]), self.config.robot.name)

    def _observation(self, k: int) -> Observation:
        core = self.batch.core
        laser = core.laser[k].copy() if self.world.scene.laser_spec is not None else None
        camera = self.world.camera_image(k)
        obs: Observation = self.observation_format.assemble(
            laser, core.proximity[k].copy(), core.velocity[k].copy(), camera
        )
        return obs if self.goals is None else with_goal(obs, self.goals.reading(k))

    def _info(self, k: int) -> dict[str, Any]:
        scene = self.world.scene
        return robot_info(
            self.batch.core,
            k,
            scene.proximity_spec.trigger_distance,
            self._clipped[k],
            self._odometry.poses,
        )

    def __getstate__(self) -> dict[str, Any]:
        # The kernel's address table points into this process's MuJoCo data: a copy (pickle,
        # deepcopy) builds its own batch on its own data and takes over the buffers.
        state = dict(self.__dict__)
        state["batch"] = state["batch"].buffers()
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        buffers = state.pop("batch")
        self.__dict__.update(state)
        world = self.world
        self.batch = WorldBatch(
            self.config, [world.scene], world.robots, world.geom_robot, world.window_group
        )
        self.batch.restore(buffers)

    def render(self) -> NDArray[np.uint8] | None:
        """``rgb_array``: the overhead view of the world (robot 0's scan drawn)."""
        if self.render_mode is None:
            return None
        scene = self.world.scene
        spec = scene.laser_spec
        range_max = spec.range_max if spec is not None else 0.0
        last = self.batch.core.laser[0] if spec is not None else None
        return self._views.render(scene.model, scene.data, scene.laser, last, range_max)

    def close(self) -> None:
        """Free the cameras' and the view's OpenGL contexts."""
        self.world.close()
        self._views.close()


def _checked_poses(poses: Any, num_robots: int) -> list[Pose]:
    """``poses`` as ``num_robots`` ``(x, y, yaw)`` floats, or one ``ValueError`` line."""
    array = np.asarray(poses, dtype=np.float64)
    if array.shape != (num_robots, 3) or not np.isfinite(array).all():
        raise ValueError(
            f"options['start_poses'] must be {num_robots} finite (x, y, yaw) poses, got {poses!r}"
        )
    return [(float(x), float(y), float(yaw)) for x, y, yaw in array.tolist()]
