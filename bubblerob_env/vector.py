"""A native batch of BubbleRobs, N robots stepped per call (Gymnasium's vector entry point).

``gym.make_vec("BubbleRob-v0", num_envs=N, vectorization_mode="vector_entry_point")`` makes one.

Each robot is a :class:`~bubblerob_env.env.BubbleRobEnv` of its own (own ``MjModel`` copy, since
obstacle sizes live in the model, own ``MjData`` and random generator), stepped by the env's own
code, so sub-env ``i`` reset with seed ``s`` gives bit for bit what ``gym.make("BubbleRob-v0")``
reset with seed ``s`` gives, for any ``num_envs`` and ``num_threads``. The batch adds what
``gym.make`` adds around one env: the time limit (``max_episode_steps``, 1000 by default) and
autoreset. The physics substeps and the laser's rays run in MuJoCo's C code, which releases the GIL,
on ``num_threads`` threads (default: the cores this process may use); each thread steps a fixed
share of the robots. With the camera or ``render_mode="human"`` the calling thread steps them all
(an OpenGL context belongs to its thread, and rendering dominates such a step anyway).

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
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import mujoco
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numpy.typing import NDArray

from bubblerob_env.checks import check_int_range
from bubblerob_env.env import BubbleRobEnv

__all__ = ["ARENA_MEMORY", "BubbleRobVectorEnv", "collate_infos"]

ARENA_MEMORY = 256 * 1024
"""Bytes of each robot's ``MjData`` arena (contacts, constraints, stack) instead of MuJoCo's 13 MB
default; the most a robot used in long random runs is far below (see docs/BENCHMARKS.md)."""
# MuJoCo drops contacts or constraints when the arena is full and says so in these counters.
_ARENA_WARNINGS = (
    int(mujoco.mjtWarning.mjWARN_CONTACTFULL),
    int(mujoco.mjtWarning.mjWARN_CNSTRFULL),
)

Step = tuple[dict[str, NDArray[Any]], float, bool, bool, dict[str, Any]]


class _BatchEnv(BubbleRobEnv):
    """A robot of a batch: the single env with a small ``MjData`` arena."""

    _ARENA_MEMORY = ARENA_MEMORY


def _available_cores() -> int:
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def _seeds(seed: int | Sequence[int | None] | None, n: int) -> list[int | None]:
    if seed is None:
        return [None] * n
    if isinstance(seed, (int, np.integer)):
        return [int(seed) + i for i in range(n)]
    seeds = list(seed)
    if len(seeds) != n:
        raise ValueError(f"seed must be None, an int or {n} seeds (one per robot), got {seed!r}")
    return seeds


class BubbleRobVectorEnv(VectorEnv[dict[str, NDArray[Any]], NDArray[np.float32], NDArray[Any]]):
    """``num_envs`` BubbleRobs stepped per call, with batched ``Dict`` observations.

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
        modes = (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP)
        if autoreset_mode not in modes and autoreset_mode not in [m.value for m in modes]:
            raise ValueError(
                f"autoreset_mode must be one of {[m.value for m in modes]}, got {autoreset_mode!r}"
            )
        self.autoreset_mode = AutoresetMode(autoreset_mode)
        first = _BatchEnv(**kwargs)
        # Clones share the first robot's read-only parts; spawn them before any reset.
        self.envs: list[BubbleRobEnv] = [first, *(first._spawn() for _ in range(num_envs - 1))]
        self.num_envs = num_envs
        self.max_episode_steps = max_episode_steps
        self.render_mode = first.render_mode
        self.metadata = {**first.metadata, "autoreset_mode": self.autoreset_mode}
        self.single_observation_space = first.observation_space
        self.single_action_space = first.action_space
        self.observation_space = batch_space(first.observation_space, num_envs)
        self.action_space = batch_space(first.action_space, num_envs)
        # OpenGL contexts (camera, window) belong to the thread that made them: with them, the
        # calling thread steps every robot (rendering dominates the step then anyway).
        uses_gl = first.camera_spec is not None or first.render_mode == "human"
        self.num_threads = 1 if uses_gl else min(threads, num_envs)
        self._shares = [range(k, num_envs, self.num_threads) for k in range(self.num_threads)]
        self._pool = (
            ThreadPoolExecutor(self.num_threads - 1, thread_name_prefix="bubblerob")
            if self.num_threads > 1
            else None
        )
        self._elapsed = np.zeros(num_envs, dtype=np.int64)
        self._autoreset = np.zeros(num_envs, dtype=bool)
        self._needs_reset = True
        self._results: list[Any] = [None] * num_envs

    def reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[dict[str, NDArray[Any]], dict[str, Any]]:
        """Reset every robot (or those in ``options["reset_mask"]``); ``seed`` as Gymnasium's."""
        options = dict(options or {})
        mask = options.pop("reset_mask", None)
        chosen = np.ones(self.num_envs, dtype=bool) if mask is None else np.asarray(mask, bool)
        if chosen.shape != (self.num_envs,):
            raise ValueError(f"options['reset_mask'] must have shape ({self.num_envs},)")
        seeds = _seeds(seed, self.num_envs)
        kwargs = {"options": options or None}

        def reset_one(i: int) -> None:
            self._results[i] = self.envs[i].reset(seed=seeds[i], **kwargs)

        self._run(reset_one, [i for i in range(self.num_envs) if chosen[i]])
        self._elapsed[chosen] = 0
        self._autoreset[chosen] = False
        self._needs_reset = False
        obs = self._batch_obs([self._results[i][0] for i in range(self.num_envs)])
        infos = [self._results[i][1] if chosen[i] else {} for i in range(self.num_envs)]
        return obs, collate_infos(infos)

    def step(
        self, actions: NDArray[np.float32]
    ) -> tuple[
        dict[str, NDArray[Any]],
        NDArray[np.float64],
        NDArray[np.bool_],
        NDArray[np.bool_],
        dict[str, Any],
    ]:
        """Step every robot with its row of ``actions`` (shape ``(num_envs, 2)``)."""
        obs, rewards, terminated, truncated, infos, finals = self.step_robots(actions)
        info = collate_infos(infos)
        if any(final is not None for final in finals):
            self._add_finals(info, finals)
        return obs, rewards, terminated, truncated, info

    def step_robots(
        self, actions: NDArray[np.float32]
    ) -> tuple[
        dict[str, NDArray[Any]],
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
        if self._needs_reset:
            raise RuntimeError("step() called before reset(): reset the vector env first")
        actions = np.asarray(actions)
        if actions.shape != self.action_space.shape:
            raise ValueError(
                f"actions must have shape {self.action_space.shape}, got {actions.shape}"
            )
        autoreset = self._autoreset.copy()
        same_step = self.autoreset_mode == AutoresetMode.SAME_STEP
        finals: list[Step | None] = [None] * self.num_envs
        self._run(lambda i: self._step_one(i, actions[i], bool(autoreset[i])), range(self.num_envs))
        if same_step:
            self._run(lambda i: self._reset_done(i, finals), range(self.num_envs))
        obs_list, rewards, terminated, truncated, infos = zip(*self._results, strict=True)
        terminated_arr = np.array(terminated, dtype=bool)
        truncated_arr = np.array(truncated, dtype=bool)
        if not same_step:
            self._autoreset = terminated_arr | truncated_arr
        return (
            self._batch_obs(list(obs_list)),
            np.array(rewards, dtype=np.float64),
            terminated_arr,
            truncated_arr,
            list(infos),
            finals,
        )

    def _step_one(self, i: int, action: NDArray[Any], autoreset: bool) -> None:
        env = self.envs[i]
        if autoreset:
            obs, info = env.reset()
            self._elapsed[i] = 0
            self._results[i] = (obs, 0.0, False, False, info)
        else:
            self._results[i] = self._finish(i, env.step(action))

    def _finish(self, i: int, result: Step) -> Step:
        """The time limit, as ``TimeLimit`` applies it, and the arena check."""
        obs, reward, terminated, truncated, info = result
        warnings = self.envs[i]._warnings
        if any(warnings[w] for w in _ARENA_WARNINGS):
            raise RuntimeError(
                f"robot {i}: MuJoCo's arena of {ARENA_MEMORY} bytes is full (contacts or "
                "constraints were dropped); raise bubblerob_env.vector.ARENA_MEMORY"
            )
        self._elapsed[i] += 1
        if self.max_episode_steps is not None and self._elapsed[i] >= self.max_episode_steps:
            truncated = True
        return obs, reward, terminated, truncated, info

    def _reset_done(self, i: int, finals: list[Step | None]) -> None:
        obs, reward, terminated, truncated, info = self._results[i]
        if terminated or truncated:
            finals[i] = self._results[i]
            new_obs, new_info = self.envs[i].reset()
            self._elapsed[i] = 0
            self._results[i] = (new_obs, reward, terminated, truncated, new_info)

    def _add_finals(self, info: dict[str, Any], finals: list[Step | None]) -> None:
        done = np.array([f is not None for f in finals])
        final_obs = np.empty(self.num_envs, dtype=object)
        for i, final in enumerate(finals):
            final_obs[i] = final[0] if final is not None else None
        info["final_obs"], info["_final_obs"] = final_obs, done
        info["final_info"] = collate_infos([f[4] if f is not None else {} for f in finals])
        info["_final_info"] = done

    def _run(self, work: Callable[[int], None], indices: Sequence[int]) -> None:
        """``work(i)`` for every index, split over the threads (each its fixed share)."""
        chosen = set(indices)
        shares = [[i for i in share if i in chosen] for share in self._shares]

        def run_share(share: list[int]) -> None:
            for i in share:
                work(i)

        if self._pool is None:
            for share in shares:
                run_share(share)
            return
        futures = [self._pool.submit(run_share, share) for share in shares[1:]]
        run_share(shares[0])
        for future in futures:
            future.result()

    def _batch_obs(self, obs_list: list[dict[str, NDArray[Any]]]) -> dict[str, NDArray[Any]]:
        return {key: np.array([obs[key] for obs in obs_list]) for key in obs_list[0]}

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
        return tuple(env.render() for env in self.envs)

    def close_extras(self, **kwargs: Any) -> None:
        """Close every robot's renderers and the threads."""
        for env in self.envs:
            env.close()
        if self._pool is not None:
            self._pool.shutdown()


def collate_infos(infos: list[dict[str, Any]]) -> dict[str, Any]:
    """Per-robot ``info`` dicts as Gymnasium's dict of arrays, with a ``_key`` mask per key.

    Numbers become float64, int64 or bool arrays, arrays are stacked, strings an object array;
    robots without a key get zeros (``""``) there and ``False`` in its mask.
    """
    out: dict[str, Any] = {}
    n = len(infos)
    everywhere = set(infos[0]).intersection(*infos[1:]) if n else set()
    all_true = np.ones(n, dtype=bool)
    for key in dict.fromkeys(key for info in infos for key in info):
        if key in everywhere:  # the common case: one pass, no defaults
            column: list[Any] = [info[key] for info in infos]
            present = all_true.copy()
        else:
            sample = next(info[key] for info in infos if key in info)
            default = np.zeros_like(sample) if isinstance(sample, np.ndarray) else type(sample)()
            column = [info.get(key, default) for info in infos]
            present = np.array([key in info for info in infos], dtype=bool)
        sample = column[0]
        if isinstance(sample, np.ndarray):
            out[key] = np.array(column)  # stacks equal shapes, faster than np.stack
        elif isinstance(sample, str):
            out[key] = np.array(column, dtype=object)
        else:
            out[key] = np.array(column)
        out[f"_{key}"] = present
    return out
