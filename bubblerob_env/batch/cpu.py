"""A native batch of BubbleRobs, N robots stepped per call (Gymnasium's vector entry point).

``gym.make_vec("BubbleRob-v0", num_envs=N, vectorization_mode="vector_entry_point")`` makes one.

Each robot is a :class:`~bubblerob_env.env.BubbleRobEnv` of its own (own ``MjModel`` copy, since
obstacle sizes live in the model, own ``MjData`` and random generator). A step is one call of the
env's numba kernel (:mod:`bubblerob_env.core`) per thread share of the robots: physics, contact
checks, sensors and rewards of the whole share with the GIL released once; observations, rewards
and ``info`` are then built for the whole batch with numpy. The kernel is the single env's own
code, so sub-env ``i`` reset with seed ``s`` gives bit for bit what ``gym.make("BubbleRob-v0")``
reset with seed ``s`` gives, for any ``num_envs`` and ``num_threads``. Only resets (once per
episode) and laser noise draws (each robot's own generator) run per robot in Python. The batch adds
what ``gym.make`` adds around one env: the time limit (``max_episode_steps``, 1000 by default)
and autoreset. Actions are checked for every robot before any robot steps: a bad row raises and
nothing moves. With the camera or ``render_mode="human"`` the calling thread steps them all (an
OpenGL context belongs to its thread, and rendering dominates such a step anyway).

Autoreset: Gymnasium's default ``AutoresetMode.NEXT_STEP`` (the step after an episode ends resets
that robot: reset observation, reward 0, reset ``info``), or ``autoreset_mode="SameStep"`` (the
robot is reset in the step that ends its episode; the last observation and ``info`` are in
``info["final_obs"]`` and ``info["final_info"]``), which :mod:`bubblerob_env.sb3` uses. The mode is
in ``metadata["autoreset_mode"]``.

Infos are Gymnasium's dict of arrays with a ``_key`` mask per key; array-valued keys (``position``,
``body_twist``, ...) are stacked into ``(num_envs, ...)`` float arrays rather than object arrays.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numpy.typing import NDArray

from bubblerob_env.batch.common import (
    BatchObs,
    add_finals,
    checked_actions,
    checked_autoreset_mode,
    collate_infos,
    reset_mask,
    robot_obs,
    world_seeds,
)
from bubblerob_env.checks import check_int_range
from bubblerob_env.config import EnvConfig
from bubblerob_env.core.batch import RobotBatch
from bubblerob_env.core.kernel import OUT
from bubblerob_env.env import BubbleRobEnv
from bubblerob_env.infos import batched_step_info, robot_step_info
from bubblerob_env.odometry import Odometry, draw_slip

__all__ = ["ARENA_MEMORY", "BubbleRobVectorEnv"]

ARENA_MEMORY = 256 * 1024
"""Bytes of each robot's ``MjData`` arena (contacts, constraints, stack) instead of MuJoCo's 13 MB
default; the most a robot used in long random runs is far below (see docs/BENCHMARKS.md)."""

Step = tuple[Any, float, bool, bool, dict[str, Any]]
# The kernel's result columns, as plain ints (enum members index numpy arrays more slowly).
_ARENA_FULL, _COLLISION, _CLIPPED, _DIVERGED, _REWARD = (
    int(c) for c in (OUT.ARENA_FULL, OUT.COLLISION, OUT.CLIPPED, OUT.DIVERGED, OUT.REWARD)
)


def _available_cores() -> int:
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


class BubbleRobVectorEnv(VectorEnv[Any, NDArray[np.float32], NDArray[Any]]):
    """``num_envs`` BubbleRobs stepped per call, with batched observations.

    Args:
        num_envs: Number of robots.
        num_threads: Threads stepping them; default the cores this process may use (at most
            ``num_envs``). Results do not depend on it.
        max_episode_steps: Time limit of each episode in steps (``None``: none), as
            ``gym.make``'s ``TimeLimit``; ``gym.make_vec`` passes the registered 1000.
        autoreset_mode: ``"NextStep"`` (Gymnasium's default) or ``"SameStep"``.
        **kwargs: Every argument of :class:`~bubblerob_env.env.BubbleRobEnv`, camera included.
    """

    def __init__(
        self,
        num_envs: int = 1,
        *,
        num_threads: int | None = None,
        max_episode_steps: int | None = 1000,
        autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
        **kwargs: Any,
    ) -> None:
        check_int_range("num_envs", num_envs, 1)
        threads = _available_cores() if num_threads is None else num_threads
        check_int_range("num_threads", threads, 1)
        if max_episode_steps is not None:
            check_int_range("max_episode_steps", max_episode_steps, 1)
        self.autoreset_mode = checked_autoreset_mode(autoreset_mode)
        # Each robot is the single env with a small MjData arena; clones share the first
        # robot's read-only parts (spawn them before any reset).
        first = BubbleRobEnv.from_config(EnvConfig.from_kwargs(kwargs), ARENA_MEMORY)
        self.envs: list[BubbleRobEnv] = [first, *(first.spawn() for _ in range(num_envs - 1))]
        self.num_envs = num_envs
        self.max_episode_steps = max_episode_steps
        self.render_mode = first.render_mode
        self.metadata = {**first.metadata, "autoreset_mode": self.autoreset_mode}
        self.single_observation_space = first.observation_space
        self.single_action_space = first.action_space
        self.observation_space = batch_space(first.observation_space, num_envs)
        self.action_space = batch_space(first.action_space, num_envs)
        self._core = RobotBatch(first.config, [env.scene for env in self.envs])
        self._odometry = Odometry(num_envs, first.drive.wheel_separation, first.odometry_noise)
        for i, env in enumerate(self.envs):  # each robot now senses into the batch's buffers
            env.attach(self._core, i, self._odometry)
        self._observation = first.observation_format
        self._trigger = first.proximity_spec.trigger_distance
        # OpenGL contexts (camera, window) belong to the thread that made them: with them, the
        # calling thread steps every robot (rendering dominates the step then anyway).
        uses_gl = first.camera_spec is not None or first.render_mode == "human"
        self.num_threads = 1 if uses_gl else min(threads, num_envs)
        # Contiguous blocks: no two threads write the same cache lines of the result buffers.
        self._shares = np.array_split(np.arange(num_envs, dtype=np.int64), self.num_threads)
        self._pool = (
            ThreadPoolExecutor(self.num_threads - 1, thread_name_prefix="bubblerob")
            if self.num_threads > 1
            else None
        )
        self._elapsed = np.zeros(num_envs, dtype=np.int64)
        self._autoreset = np.zeros(num_envs, dtype=bool)
        self._collided = np.zeros(num_envs, dtype=bool)
        self._clipped_actions = np.zeros(num_envs, dtype=np.int64)
        self._needs_reset = True
        self._closed = False
        self._obs: dict[str, NDArray[Any]] = {}

    def reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[BatchObs, dict[str, Any]]:
        """Reset every robot (or those in ``options["reset_mask"]``); ``seed`` as Gymnasium's."""
        self._check_open("reset")
        chosen, options = reset_mask(options, self.num_envs)
        seeds = world_seeds(seed, self.num_envs)
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        for i in np.flatnonzero(chosen).tolist():
            infos[i] = self._reset_robot(i, seeds[i], options or None)
        self._autoreset[chosen] = False
        self._needs_reset = False
        return self._batched_obs(), collate_infos(infos)

    def _reset_robot(
        self, i: int, seed: int | None, options: dict[str, Any] | None
    ) -> dict[str, Any]:
        """Reset robot ``i`` as ``gym.make``'s env resets; its observation goes into the batch."""
        env = self.envs[i]
        obs, info = env.reset(seed=seed, options=options)  # senses into row i of the batch
        if isinstance(obs, dict) and "camera" in obs:
            self._obs_camera[i] = obs["camera"]
        self._elapsed[i] = 0
        self._collided[i] = False
        self._clipped_actions[i] = 0
        return info

    def step(
        self, actions: NDArray[np.float32]
    ) -> tuple[BatchObs, NDArray[np.float64], NDArray[np.bool_], NDArray[np.bool_], dict[str, Any]]:
        """Step every robot with its row of ``actions`` (shape ``(num_envs, 2)``)."""
        result = self._step(actions)
        obs, rewards, terminated, truncated, stepped, diverged, resets, finals = result
        info = batched_step_info(
            self._core,
            self._trigger,
            self._collided,
            self._clipped_actions,
            diverged,
            resets,
            self._odometry.poses,
        )
        if finals:
            add_finals(info, finals, self.num_envs)
        return obs, rewards, terminated, truncated, info

    def step_robots(
        self, actions: NDArray[np.float32]
    ) -> tuple[
        BatchObs,
        NDArray[np.float64],
        NDArray[np.bool_],
        NDArray[np.bool_],
        list[dict[str, Any]],
        list[Step | None],
    ]:
        """:meth:`step`, with each robot's own ``info`` dict instead of the batched one.

        Also returns, in ``SameStep`` mode, the last ``(obs, reward, terminated, truncated, info)``
        of each robot whose episode ended in this step (else None).
        """
        result = self._step(actions)
        obs, rewards, terminated, truncated, stepped, diverged, resets, finals = result
        infos = [
            resets[i]
            if i in resets
            else robot_step_info(
                self._core,
                i,
                self._trigger,
                bool(self._collided[i]),
                int(self._clipped_actions[i]),
                diverged,
                self._odometry.poses,
            )
            for i in range(self.num_envs)
        ]
        final_steps: list[Step | None] = [None] * self.num_envs
        for i, (final_obs, final_info) in finals.items():
            final_steps[i] = (final_obs, rewards[i], terminated[i], truncated[i], final_info)
        return obs, rewards, terminated, truncated, infos, final_steps

    def _checked_actions(self, actions: NDArray[np.float32]) -> NDArray[np.float64]:
        """Every robot's action, checked before any robot steps (a bad row moves nothing)."""
        if self._needs_reset:
            raise RuntimeError("step() called before reset(): reset the vector env first")
        return checked_actions(actions, self.num_envs)

    def _step(self, actions: NDArray[np.float32]) -> tuple[Any, ...]:
        """One step of the batch: kernel, time limits, autoresets; the pieces of both APIs."""
        self._check_open("step")
        checked = self._checked_actions(actions)
        core = self._core
        stepped = ~self._autoreset
        robots = np.flatnonzero(stepped)
        core.actions[:] = checked
        self._draw_noise(robots)
        self._run_kernel(stepped)
        self._advance_odometry(robots)
        self._render_robots(robots)
        out = core.out
        if out[robots, _ARENA_FULL].any():
            i = int(robots[np.flatnonzero(out[robots, _ARENA_FULL])[0]])
            raise RuntimeError(
                f"robot {i}: MuJoCo's arena of {ARENA_MEMORY} bytes is full (contacts or "
                "constraints were dropped); raise bubblerob_env.vector.ARENA_MEMORY"
            )
        collision = stepped & (out[:, _COLLISION] != 0.0)
        self._collided |= collision
        self._clipped_actions += stepped & (out[:, _CLIPPED] != 0.0)
        diverged = {
            i: self.envs[i].scene.diverged() for i in robots[out[robots, _DIVERGED] != 0].tolist()
        }
        rewards = np.where(stepped, out[:, _REWARD], 0.0)
        terminated = collision & self.envs[0].terminate_on_collision
        truncated = np.zeros(self.num_envs, dtype=bool)
        truncated[list(diverged)] = True
        self._elapsed[stepped] += 1
        if self.max_episode_steps is not None:
            truncated |= stepped & (self._elapsed >= self.max_episode_steps)
        obs = self._batched_obs()  # the step's observations, before any reset below
        resets: dict[int, dict[str, Any]] = {}
        finals: dict[int, tuple[Any, dict[str, Any]]] = {}
        for i in np.flatnonzero(~stepped).tolist():  # NextStep: the step after the end
            resets[i] = self._reset_robot(i, None, None)
        if self.autoreset_mode == AutoresetMode.SAME_STEP:
            for i in np.flatnonzero(terminated | truncated).tolist():
                final_info = robot_step_info(
                    core,
                    i,
                    self._trigger,
                    bool(self._collided[i]),
                    int(self._clipped_actions[i]),
                    diverged,
                    self._odometry.poses,
                )
                finals[i] = (robot_obs(obs, i), final_info)
                resets[i] = self._reset_robot(i, None, None)
        else:
            self._autoreset = terminated | truncated
        if resets:
            obs = self._batched_obs()
        return obs, rewards, terminated, truncated, stepped, diverged, resets, finals

    def _render_robots(self, robots: NDArray[np.int64]) -> None:
        # The camera's frames, and the windows of render_mode="human", robot by robot.
        first = self.envs[0]
        if first.scene.camera is None and first.render_mode != "human":
            return
        for i in robots.tolist():
            env = self.envs[i]
            scene = env.scene
            if scene.camera is not None:
                self._obs_camera[i] = scene.camera(scene.model, scene.data)
            if env.render_mode == "human":
                if env.laser_spec is not None:
                    env.last_laser = self._core.laser[i].copy()
                env.render()

    def _draw_noise(self, robots: NDArray[np.int64]) -> None:
        # Each robot's laser noise from its own generator, as the single env draws it.
        spec = self.envs[0].laser_spec
        if spec is None or spec.noise_std <= 0.0:
            return
        for i in robots.tolist():
            self._core.noise[i] = self.envs[i].np_random.normal(
                0.0, spec.noise_std, size=spec.num_rays
            )

    def _advance_odometry(self, robots: NDArray[np.int64]) -> None:
        # After the kernel, each robot's wheel slip from its own generator, as the single env.
        noise = self._odometry.noise
        slip = (
            np.array([draw_slip(self.envs[i].np_random, noise) for i in robots.tolist()])
            if noise and len(robots)
            else None
        )
        self._odometry.advance(robots, self._core.out, slip)

    def _run_kernel(self, stepped: NDArray[np.bool_]) -> None:
        """One kernel call per thread share of the robots that step."""
        shares = [share[stepped[share]] for share in self._shares]
        if self._pool is None:
            self._core.step(np.concatenate(shares) if len(shares) > 1 else shares[0])
            return
        futures = [self._pool.submit(self._core.step, share) for share in shares[1:]]
        self._core.step(shares[0])
        for future in futures:
            future.result()

    @property
    def _obs_camera(self) -> NDArray[np.uint8]:
        if "camera" not in self._obs:
            spec = self.envs[0].camera_spec
            assert spec is not None
            self._obs["camera"] = np.zeros((self.num_envs, spec.height, spec.width, 3), np.uint8)
        return self._obs["camera"]

    def _batched_obs(self) -> BatchObs:
        """The batch's observations: copies of the kernel's buffers (they are reused)."""
        core, first = self._core, self.envs[0]
        laser = core.laser.copy() if first.laser_spec is not None else None
        proximity, velocity = core.proximity.copy(), core.velocity.copy()
        camera = self._obs_camera.copy() if first.camera_spec is not None else None
        obs: BatchObs = self._observation.assemble(laser, proximity, velocity, camera)
        return obs

    def _check_open(self, method: str) -> None:
        if self._closed:
            raise RuntimeError(f"{method}() called after close(); make a new vector env")

    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        """Each robot's ``name`` attribute, called with the arguments if it is callable."""
        results = []
        for env in self.envs:
            attribute = getattr(env, name)
            results.append(attribute(*args, **kwargs) if callable(attribute) else attribute)
        return tuple(results)

    def get_attr(self, name: str) -> tuple[Any, ...]:
        """Each robot's ``name`` attribute."""
        return tuple(getattr(env, name) for env in self.envs)

    def set_attr(self, name: str, values: Any) -> None:
        """Set ``name`` on every robot: one value each (a list or tuple), or the same for all."""
        if not isinstance(values, (list, tuple)):
            values = [values] * self.num_envs
        if len(values) != self.num_envs:
            raise ValueError(f"set_attr needs {self.num_envs} values, got {len(values)}")
        for env, value in zip(self.envs, values, strict=True):
            setattr(env, name, value)

    def render(self) -> tuple[Any, ...] | None:
        """Each robot's frame (``rgb_array``), or update their windows (``human``)."""
        if self.render_mode is None:
            return None
        for i, env in enumerate(self.envs):
            if env.laser_spec is not None:
                env.last_laser = self._core.laser[i].copy()
        return tuple(env.render() for env in self.envs)

    def close_extras(self, **kwargs: Any) -> None:
        """Close every robot's renderers and the threads."""
        self._closed = True
        # getattr: a constructor that raised (a bad kwarg) leaves neither, and __del__ comes here.
        for env in getattr(self, "envs", ()):
            env.close()
        pool = getattr(self, "_pool", None)
        if pool is not None:
            pool.shutdown()
