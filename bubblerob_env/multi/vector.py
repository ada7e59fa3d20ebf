"""A native batch of worlds of several robots: one vector-env slot per robot.

``WorldsVectorEnv(num_worlds=M, num_robots=N)`` is a Gymnasium ``VectorEnv`` of ``M * N`` slots
(robot ``k`` of world ``w`` is slot ``w * N + k``), for learners that share one policy over all
robots (Long et al., ICRA 2018). One step is one numba call per thread share of the worlds
(:class:`~bubblerob_env.core.worlds.WorldBatch`, GIL released). A slot whose episode ends (its
robot touched something, its time limit, or its world diverged) restarts in the same step as a
new robot at a free pose of its world (``SameStep`` autoreset: the last observation and
``info`` are in ``info["final_obs"]`` and ``info["final_info"]``), while the world's other robots
drive on; a diverged world is drawn anew. The obstacles of a world are drawn at :meth:`reset`.

``task="nav"`` gives every slot ``parallel_env(task="nav")``'s goal, ``goal`` reading, reward
parts, ``info`` keys and success (the robot within ``goal_radius`` of its goal terminates with
``is_success``); a slot that starts again gets a fresh goal (:mod:`~bubblerob_env.multi.
nav_slots`). ``WorldsVectorEnv(num_robots=1, task="nav")`` is a batch of ``BubbleRobNav-v0``
worlds with its observation space.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import mujoco
import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numpy.typing import NDArray

from bubblerob_env.arena import ArenaLayout
from bubblerob_env.batch.common import (
    BatchObs,
    ObservationFormat,
    add_finals,
    checked_actions,
    robot_obs,
    world_seeds,
)
from bubblerob_env.batch.common import collate_infos as collate
from bubblerob_env.core.kernel import OUT
from bubblerob_env.core.worlds import WorldBatch
from bubblerob_env.infos import batched_step_info, robot_info, robot_step_info
from bubblerob_env.multi.goals import task_config, task_settings
from bubblerob_env.multi.nav_slots import SlotGoals, StepParts
from bubblerob_env.multi.placement import (
    check_circle_jitter,
    check_fits,
    free_pose,
    sample_world,
)
from bubblerob_env.multi.scene import WorldScene, partner_name
from bubblerob_env.odometry import Odometry, draw_slip
from bubblerob_env.tasks.nav_rules import spaces_with_goal

__all__ = ["WORLD_ARENA_MEMORY", "WorldsVectorEnv"]

WORLD_ARENA_MEMORY = 256 * 1024
"""Bytes of ``MjData`` arena per robot of a world (the single-robot batch's per robot)."""
_COLLISION, _CLIPPED, _DIVERGED, _REWARD = (
    int(c) for c in (OUT.COLLISION, OUT.CLIPPED, OUT.DIVERGED, OUT.REWARD)
)
_WORLD_TRIES = 20  # worlds drawn before giving up on goals for every robot (parallel_env's)
_RESPAWN_TRIES = 20  # free poses tried for a restarted robot with no goal in reach


class WorldsVectorEnv(VectorEnv[Any, NDArray[np.float32], NDArray[Any]]):
    """``num_worlds`` worlds of ``num_robots`` robots, one slot per robot.

    Args:
        num_worlds: Worlds (each its own ``MjModel`` copy and ``MjData``).
        num_robots: Robots in each world.
        robot, scenario, task, circle_jitter: as :func:`~bubblerob_env.multi.parallel_env`'s
            (``task="nav"`` takes the Nav arguments, ``goal_radius`` ..., among ``kwargs``).
        num_threads: Threads stepping the worlds (default: the usable cores, at most the
            worlds). Results do not depend on it.
        max_episode_steps: Each slot's time limit in steps.
        world_steps: Draw each world anew every this many steps, every slot of it truncated
            (default None: never). With ``scenario="circle"`` the crossing then starts again,
            as a restarted slot alone starts at a free pose with a fresh goal.
        **kwargs: The single env's arguments (no camera, no rendering).
    """

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP}

    def __init__(
        self,
        num_worlds: int = 1,
        num_robots: int = 8,
        *,
        robot: str = "bubblerob",
        scenario: str = "random",
        task: str = "wander",
        circle_jitter: float = 0.0,
        num_threads: int | None = None,
        max_episode_steps: int = 1000,
        world_steps: int | None = None,
        **kwargs: Any,
    ) -> None:
        for name, value in (("num_worlds", num_worlds), ("num_robots", num_robots)):
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
        if kwargs.get("camera") or kwargs.get("render_mode") is not None:
            raise ValueError("WorldsVectorEnv has no camera and no rendering; use parallel_env")
        settings = task_settings(task, kwargs)
        config = task_config(settings, scenario, num_robots, kwargs, robot)
        check_fits(config, num_robots, scenario)
        self.circle_jitter = check_circle_jitter(config, num_robots, scenario, circle_jitter)
        self.config, self.scenario, self.task = config, scenario, task
        self.max_episode_steps = max_episode_steps
        if world_steps is not None and (
            isinstance(world_steps, bool) or not isinstance(world_steps, int) or world_steps < 1
        ):
            raise ValueError(f"world_steps must be None or an integer >= 1, got {world_steps!r}")
        self.world_steps = world_steps
        first = WorldScene(config, num_robots, WORLD_ARENA_MEMORY * num_robots)
        self.worlds = [first, *(first.spawn() for _ in range(num_worlds - 1))]
        self.num_worlds, self.num_robots = num_worlds, num_robots
        self.num_envs = num_worlds * num_robots
        self.batch = WorldBatch(
            config,
            [w.scene for w in self.worlds],
            first.robots,
            first.geom_robot,
            first.window_group,
        )
        self._format = ObservationFormat(first.scene)
        self.single_observation_space = self._format.space
        self.goals = None
        """Every slot's goal with ``task="nav"`` (else None)."""
        if settings is not None:
            self.goals = SlotGoals(settings, config, num_worlds, num_robots)
            flat = self._format.space if config.obs_mode == "flat" else None
            assert flat is None or isinstance(flat, spaces.Box)
            _, self.single_observation_space, _ = spaces_with_goal(
                self._format.dict_space, flat, config.arena_size
            )
        self.single_action_space = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._trigger = first.scene.proximity_spec.trigger_distance
        drive = first.scene.limits.drive
        self._odometry = Odometry(self.num_envs, drive.wheel_separation, config.odometry_noise)
        self._rngs = [seeding.np_random()[0] for _ in range(num_worlds)]
        self._layouts: list[ArenaLayout | None] = [None] * num_worlds
        threads = num_threads or len(os.sched_getaffinity(0))
        self.num_threads = max(1, min(threads, num_worlds))
        self._shares = np.array_split(np.arange(num_worlds, dtype=np.int64), self.num_threads)
        self._pool = (
            ThreadPoolExecutor(self.num_threads - 1, thread_name_prefix="bubblerob-worlds")
            if self.num_threads > 1
            else None
        )
        self._elapsed = np.zeros(self.num_envs, dtype=np.int64)
        self._world_elapsed = np.zeros(num_worlds, dtype=np.int64)
        self._collided = np.zeros(self.num_envs, dtype=bool)
        self._clipped = np.zeros(self.num_envs, dtype=np.int64)
        self._ready = False

    def reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[BatchObs, dict[str, Any]]:
        """Draw every world anew; ``seed``: world ``w`` gets ``seed + w`` (or a seed each)."""
        for w, world_seed in enumerate(world_seeds(seed, self.num_worlds)):
            if world_seed is not None:
                self._rngs[w] = seeding.np_random(world_seed)[0]
            self._reset_world(w)
        self._ready = True
        infos = [
            robot_info(self.batch.core, i, self._trigger, 0, self._odometry.poses)
            for i in range(self.num_envs)
        ]
        if self.goals is not None:
            infos = [self.goals.slot_info(i, info) for i, info in enumerate(infos)]
        return self._observations(), collate(infos)

    def _rows(self, w: int) -> NDArray[np.int64]:
        return np.arange(w * self.num_robots, (w + 1) * self.num_robots, dtype=np.int64)

    def _reset_world(self, w: int) -> None:
        world, rng = self.worlds[w], self._rngs[w]
        scene = world.scene
        for _ in range(_WORLD_TRIES):  # as parallel_env's reset: the same world for a seed
            layout, poses = sample_world(
                rng, self.config, self.num_robots, self.scenario, self.circle_jitter
            )
            if self.goals is None:
                break
            with_goals = self.goals.draw(w, rng, layout, poses, self.scenario)
            if with_goals is not None:
                layout = with_goals
                break
        else:
            raise RuntimeError(f"no goal for every robot in {_WORLD_TRIES} worlds: a crowded arena")
        self._layouts[w] = layout
        mujoco.mj_resetData(scene.model, scene.data)
        scene.slots.apply(scene.model, scene.data, layout.obstacles)
        for k, pose in enumerate(poses):
            world.place_robot(k, pose)
        mujoco.mj_forward(scene.model, scene.data)
        self._start(self._rows(w), w)
        self._world_elapsed[w] = 0
        if self.goals is not None:
            self.goals.begin(self._rows(w).tolist(), self.batch.core.out)

    def _start(self, rows: NDArray[np.int64], w: int) -> None:
        self._draw_noise(rows)
        self.batch.start(rows, self.worlds[w].scene.model)
        for i in rows.tolist():
            self._odometry.reset(i, self.batch.core.out[i])
        self._elapsed[rows] = 0
        self._collided[rows] = False
        self._clipped[rows] = 0

    def _respawn(self, i: int) -> None:
        """Slot ``i``'s robot starts again at a free pose of its world; the others drive on."""
        w, k = divmod(i, self.num_robots)
        world = self.worlds[w]
        layout = self._layouts[w]
        assert layout is not None
        out = self.batch.core.out
        others = [
            (float(out[j, OUT.POSITION]), float(out[j, OUT.POSITION + 1]))
            for j in self._rows(w).tolist()
            if j != i
        ]
        rng = self._rngs[w]
        for _ in range(_RESPAWN_TRIES):
            pose = free_pose(rng, self.config, layout.obstacles, others)
            if self.goals is None or self.goals.redraw(i, rng, pose[:2]):
                break
        world.place_robot(k, pose)
        mujoco.mj_forward(world.scene.model, world.scene.data)
        self._start(np.array([i], dtype=np.int64), w)
        if self.goals is not None:
            self.goals.begin([i], self.batch.core.out)

    def _draw_noise(self, rows: NDArray[np.int64]) -> None:
        spec = self.worlds[0].scene.laser_spec
        if spec is None or spec.noise_std <= 0.0:
            return
        for i in rows.tolist():
            rng = self._rngs[i // self.num_robots]
            self.batch.core.noise[i] = rng.normal(0.0, spec.noise_std, size=spec.num_rays)

    def step(
        self, actions: NDArray[np.float32]
    ) -> tuple[BatchObs, NDArray[np.float64], NDArray[np.bool_], NDArray[np.bool_], dict[str, Any]]:
        """Step every world; ended slots restart in the same step (``SameStep``)."""
        if not self._ready:
            raise RuntimeError("step() called before reset(): reset the vector env first")
        core = self.batch.core
        core.actions[:] = checked_actions(actions, self.num_envs)
        self._draw_noise(np.arange(self.num_envs, dtype=np.int64))
        self._run_kernel()
        self._advance_odometry()
        out = core.out
        collision = out[:, _COLLISION] != 0.0
        self._collided |= collision
        self._clipped += out[:, _CLIPPED] != 0.0
        self._elapsed += 1
        diverged_worlds = sorted({i // self.num_robots for i in np.flatnonzero(out[:, _DIVERGED])})
        diverged = {}
        for w in diverged_worlds:
            reason = self.worlds[w].scene.diverged()
            diverged.update(dict.fromkeys(self._rows(w).tolist(), reason))
        rewards = out[:, _REWARD].copy()
        terminated = collision & self.config.terminate_on_collision
        truncated = self._elapsed >= self.max_episode_steps
        self._world_elapsed += 1
        if self.world_steps is not None:
            redrawn = np.flatnonzero(self._world_elapsed >= self.world_steps).tolist()
            for w in redrawn:
                truncated[self._rows(w)] = True
            diverged_worlds = sorted({*diverged_worlds, *redrawn})
        truncated[list(diverged)] = True
        task: tuple[StepParts, NDArray[np.bool_]] | None = None
        if self.goals is not None:  # before any restart moves a robot
            rewards, arrived, parts = self.goals.step(out, truncated)
            terminated |= arrived
            task = (parts, arrived)
        obs = self._observations()
        names, touched = self._partners(collision)
        done = terminated | truncated
        finals = self._finals(obs, np.flatnonzero(done).tolist(), names, diverged, task)
        resets = self._restart(np.flatnonzero(done).tolist(), diverged_worlds)
        info = batched_step_info(
            core,
            self._trigger,
            self._collided,
            self._clipped,
            diverged,
            resets,
            self._odometry.poses,
        )
        # Restarted slots' info is their new episode's (SameStep): no collided_with there.
        info["collided_with"], info["_collided_with"] = names, touched & ~done
        if self.goals is not None and task is not None:
            self.goals.step_info(info, task[0], task[1], done)
        if finals:
            add_finals(info, finals, self.num_envs)
            obs = self._observations()
        return obs, rewards, terminated, truncated, info

    def _advance_odometry(self) -> None:
        noise = self._odometry.noise
        slip = None
        if noise:
            rngs = [self._rngs[i // self.num_robots] for i in range(self.num_envs)]
            slip = np.array([draw_slip(rng, noise) for rng in rngs])
        self._odometry.advance(np.arange(self.num_envs, dtype=np.int64), self.batch.core.out, slip)

    def _finals(
        self,
        obs: BatchObs,
        ended: list[int],
        names: NDArray[Any],
        diverged: dict[int, str],
        task: tuple[StepParts, NDArray[np.bool_]] | None,
    ) -> dict[int, tuple[Any, dict[str, Any]]]:
        """The last observation and ``info`` of each slot in ``ended`` (``task``: Nav's step)."""
        finals = {}
        for i in ended:
            final_info = robot_step_info(
                self.batch.core,
                i,
                self._trigger,
                bool(self._collided[i]),
                int(self._clipped[i]),
                diverged,
                self._odometry.poses,
            )
            if names[i]:
                final_info["collided_with"] = names[i]
            if self.goals is not None and task is not None:
                final_info = self.goals.final_info(i, final_info, task[0][i], bool(task[1][i]))
            finals[i] = (robot_obs(obs, i), final_info)
        return finals

    def _restart(self, ended: list[int], diverged_worlds: list[int]) -> dict[int, dict[str, Any]]:
        """Draw diverged worlds anew and respawn the other ended slots; their reset ``info``."""
        for w in diverged_worlds:
            self._reset_world(w)
        resets = {}
        for i in ended:
            if i // self.num_robots not in diverged_worlds:
                self._respawn(i)
            resets[i] = robot_info(self.batch.core, i, self._trigger, 0, self._odometry.poses)
        return resets

    def _partners(self, collision: NDArray[np.bool_]) -> tuple[NDArray[Any], NDArray[np.bool_]]:
        """``info["collided_with"]``: the robot touched (its name in the world) or "obstacle"."""
        names = np.full(self.num_envs, "", dtype=object)
        for i in np.flatnonzero(collision).tolist():
            names[i] = partner_name(int(self.batch.partner[i]), self.config.robot.name)
        return names, collision.copy()

    def _run_kernel(self) -> None:
        if self._pool is None:
            self.batch.step(self._shares[0])
            return
        futures = [self._pool.submit(self.batch.step, share) for share in self._shares[1:]]
        self.batch.step(self._shares[0])
        for future in futures:
            future.result()

    def _observations(self) -> BatchObs:
        core = self.batch.core
        laser = core.laser.copy() if self.worlds[0].scene.laser_spec is not None else None
        obs: BatchObs = self._format.assemble(
            laser, core.proximity.copy(), core.velocity.copy(), None
        )
        return obs if self.goals is None else self.goals.observations(obs)

    def close_extras(self, **kwargs: Any) -> None:
        """Stop the threads."""
        pool = getattr(self, "_pool", None)
        if pool is not None:
            pool.shutdown()
