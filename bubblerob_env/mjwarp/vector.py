"""``backend="warp"``: N BubbleRobs stepped by MuJoCo Warp, on a GPU or on the CPU device.

``gym.make_vec("BubbleRob-v0", num_envs=N, vectorization_mode="vector_entry_point",
backend="warp", device="cuda:0")`` makes one. Spaces, kwargs, autoreset modes and ``info`` keys
are the CPU batch's (:class:`~bubblerob_env.batch.cpu.BubbleRobVectorEnv`); physics, the collision
check after every substep, the laser (:mod:`~bubblerob_env.mjwarp.laser`), the proximity sensor,
rewards, odometry, time limits and resets run on the device, for every world at once.

Equivalence with the CPU env, not bit-for-bit identity: MuJoCo Warp computes in float32 and its
solver is not MuJoCo's, so states drift apart by float32 rounding; tests/warp holds the laser,
first-contact steps and episode outcomes to the CPU env's (docs/BENCHMARKS.md states the drift).

Arenas: world ``i`` of ``reset(seed=s)`` gets the CPU env's arena for seed ``s + i``. Autoresets
take rows of a bank of ``layout_bank`` arenas, those of the CPU env with seeds ``s + N``,
``s + N + 1``, ...; which row a world gets next is drawn from a generator seeded by ``s``, so the
whole run repeats with the seed. ``arena_seeds`` holds each world's current arena's seed.

Outputs: numpy by default. With ``outputs="warp"`` observations, rewards, terminations and
truncations are ``warp.array`` s on the device (``info`` stays numpy); ``torch.from_dlpack(a)``
(or ``warp.to_torch``) views them as torch tensors without a copy, and actions may be a
``warp.array`` or a torch tensor on the same device.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numpy.typing import NDArray

from bubblerob_env.batch.common import (
    add_finals,
    checked_autoreset_mode,
    reset_mask,
    robot_obs,
    world_seeds,
)
from bubblerob_env.checks import check_bool, check_choice, check_int_range
from bubblerob_env.env import BubbleRobEnv
from bubblerob_env.infos import batched_step_info, robot_info, robot_step_info
from bubblerob_env.mjwarp.device import DeviceWorlds, HostCopy
from bubblerob_env.mjwarp.layouts import LayoutTable

__all__ = ["OUTPUTS", "WarpVectorEnv"]

OUTPUTS = ("numpy", "warp")
"""``outputs`` values: host numpy arrays, or device ``warp.array`` s."""
_DIVERGED_REASON = "the state is not finite (MuJoCo Warp raises no warnings)"


class WarpVectorEnv(VectorEnv[Any, Any, Any]):
    """``num_envs`` BubbleRobs in one MuJoCo Warp model, one world each.

    Args:
        num_envs: Number of robots (worlds).
        device: Warp device (``"cuda:0"``, ``"cpu"``); default Warp's (a GPU where there is one).
        max_episode_steps: Time limit in steps (``None``: none), as ``gym.make``'s.
        autoreset_mode: ``"NextStep"`` (Gymnasium's default) or ``"SameStep"``.
        layout_bank: Arenas the autoresets draw from (made at each seeded reset).
        outputs: ``"numpy"`` or ``"warp"`` (see the module docstring).
        graphs: Replay each step's launches as Warp graphs (captured on the second step; CUDA
            graphs on a GPU, Warp's own on the CPU). ``False`` launches them one by one.
        **kwargs: The arguments of :class:`~bubblerob_env.env.BubbleRobEnv`; no camera and no
            ``render_mode`` (rendering stays with the CPU backend).
    """

    def __init__(
        self,
        num_envs: int = 1,
        *,
        device: str | None = None,
        max_episode_steps: int | None = 1000,
        autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
        layout_bank: int = 1024,
        outputs: str = "numpy",
        graphs: bool = True,
        **kwargs: Any,
    ) -> None:
        check_int_range("num_envs", num_envs, 1)
        check_int_range("layout_bank", layout_bank, 1)
        check_choice("outputs", outputs, OUTPUTS)
        check_bool("graphs", graphs)
        if max_episode_steps is not None:
            check_int_range("max_episode_steps", max_episode_steps, 1)
        self.autoreset_mode = checked_autoreset_mode(autoreset_mode)
        if kwargs.get("camera"):
            raise ValueError("camera=True is not available with backend='warp'; use backend='cpu'")
        if kwargs.get("render_mode") is not None:
            raise ValueError(
                f"render_mode={kwargs['render_mode']!r} is not available with backend='warp'; "
                "use backend='cpu' to render"
            )
        self._template = BubbleRobEnv(**kwargs)  # checks every kwarg; answers get_attr
        first = self._template
        self.scene = first.scene
        """The CPU env's scene every world copies (its model, obstacle slots, sensors); the
        layout tables draw the arenas in it."""
        self.num_envs = num_envs
        self.max_episode_steps = max_episode_steps
        self.outputs = outputs
        self.layout_bank = layout_bank
        self.render_mode = None
        self.metadata = {**first.metadata, "autoreset_mode": self.autoreset_mode}
        self.single_observation_space = first.observation_space
        self.single_action_space = first.action_space
        self.observation_space = batch_space(first.observation_space, num_envs)
        self.action_space = batch_space(first.action_space, num_envs)
        self.worlds = DeviceWorlds(self.scene, num_envs, device, max_episode_steps, graphs)
        """The device state: MuJoCo Warp's model and data, the readings, the kernels' settings."""
        self.device = self.worlds.device
        self.arena_seeds = np.zeros(num_envs, dtype=np.int64)
        """The seed of each world's current arena (``gym.make``'s env reset with it has it)."""
        self._trigger = first.proximity_spec.trigger_distance
        # Scans come to the host for numpy outputs, and for SameStep's final observations.
        self._host_laser = outputs == "numpy" or self.autoreset_mode == AutoresetMode.SAME_STEP
        self._autoreset = np.zeros(num_envs, dtype=bool)
        self._bank: LayoutTable | None = None
        self._bank_rng = np.random.default_rng()
        self._needs_reset = True
        self._closed = False

    def reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[Any, dict[str, Any]]:
        """Reset every world (or those in ``options["reset_mask"]``); ``seed`` as Gymnasium's."""
        self._check_open("reset")
        chosen, left = reset_mask(options, self.num_envs)
        if left:
            raise ValueError(f"options may hold only 'reset_mask', got {sorted(left)}")
        seeds = world_seeds(seed, self.num_envs)
        base = seeds[0] if seeds[0] is not None else None
        if base is not None:
            self._bank_rng = np.random.default_rng(base)
        drawn = self._bank_rng.integers(2**31 - 1, size=self.num_envs)
        resolved = np.array([drawn[i] if s is None else s for i, s in enumerate(seeds)])
        if self._bank is None or base is not None:
            start = int(base if base is not None else drawn[0]) + self.num_envs
            if self._bank is None or int(self._bank.seeds[0]) != start:  # kept across resets
                seeds_ = range(start, start + self.layout_bank)
                self._bank = LayoutTable(self.scene, seeds_, self.device)
        rows = np.flatnonzero(chosen)
        table = LayoutTable(self.scene, resolved[rows].tolist(), self.device)
        table_rows = np.zeros(self.num_envs, dtype=np.int32)
        table_rows[rows] = np.arange(rows.size, dtype=np.int32)
        self.worlds.noise_seeds(resolved, chosen)
        self.worlds.reset(chosen, table, table_rows)
        self.worlds.sense(active=chosen, resetting=chosen)
        self.arena_seeds[rows] = resolved[rows]
        self._autoreset[chosen] = False
        self._needs_reset = False
        host = self.worlds.fetch()
        info = self._infos(host, resets=rows.tolist(), with_success=False)
        return self._observations(host), info

    def step(self, actions: Any) -> tuple[Any, Any, Any, Any, dict[str, Any]]:
        """Step every world with its row of ``actions`` (shape ``(num_envs, 2)``)."""
        self._check_open("step")
        if self._needs_reset:
            raise RuntimeError("step() called before reset(): reset the vector env first")
        self.worlds.set_actions(actions)
        self.worlds.physics()
        resetting = self._autoreset.copy()
        if resetting.any():  # NextStep: the worlds whose episode ended last step
            self._autoreset_worlds(resetting)
        self.worlds.sense(active=None, resetting=resetting)
        host = self.worlds.fetch(laser=self._host_laser)
        terminated, truncated = host.terminated.copy(), host.truncated.copy()
        terminated[resetting] = truncated[resetting] = False
        done = terminated | truncated
        if self.autoreset_mode == AutoresetMode.NEXT_STEP:
            self._autoreset = done
            info = self._infos(host, resets=np.flatnonzero(resetting).tolist())
            rewards, obs = host.rewards, self._observations(host)
            return (*self._outputs(obs, rewards, terminated, truncated), info)
        finals: dict[int, tuple[Any, dict[str, Any]]] = {}
        if done.any():
            final_obs = self._observations(host, host_only=True)
            for i in np.flatnonzero(done).tolist():
                final_info = self._step_info(host, i)
                finals[i] = (robot_obs(final_obs, i), final_info)
            self._autoreset_worlds(done)
            self.worlds.sense(active=done, resetting=done)
            host = self.worlds.fetch(rewards=host.rewards)
        info = self._infos(host, resets=np.flatnonzero(done).tolist())
        if finals:
            add_finals(info, finals, self.num_envs)
        obs = self._observations(host)
        return (*self._outputs(obs, host.rewards, terminated, truncated), info)

    def _outputs(self, obs: Any, rewards: Any, terminated: Any, truncated: Any) -> tuple[Any, ...]:
        if self.outputs == "warp":
            return obs, *self.worlds.device_results(rewards, terminated, truncated)
        return obs, rewards, terminated, truncated

    def _autoreset_worlds(self, resetting: NDArray[np.bool_]) -> None:
        """Reset ``resetting`` worlds from rows of the bank, drawn by the seeded generator."""
        assert self._bank is not None
        rows = np.zeros(self.num_envs, dtype=np.int32)
        picked = self._bank_rng.integers(len(self._bank), size=int(resetting.sum()))
        rows[resetting] = picked
        self.arena_seeds[resetting] = self._bank.seeds[picked]
        self.worlds.reset(resetting, self._bank, rows)

    def _observations(self, host: HostCopy, host_only: bool = False) -> Any:
        """Numpy observations, or the device's when ``outputs="warp"``."""
        if self.outputs == "warp" and not host_only:
            return self.worlds.device_observations(self.scene.config.obs_mode)
        laser = host.laser if self.scene.laser_spec is not None else None
        # The host copy's own arrays, new every fetch: no copies.
        return self._template.observation_format.assemble(laser, host.proximity, host.velocity)

    def _infos(
        self, host: HostCopy, resets: list[int], with_success: bool = True
    ) -> dict[str, Any]:
        """The CPU batch's ``info``: Gymnasium's dict of arrays, from the device's numbers."""
        diverged = {i: _DIVERGED_REASON for i in np.flatnonzero(host.diverged).tolist()}
        core, odometry = host, host.odometry
        if not with_success:  # reset(): every chosen world's reset info, no is_success
            return _reset_infos(core, self._trigger, resets, self.num_envs)
        reset_infos = {i: robot_info(core, i, self._trigger, 0, odometry) for i in resets}
        return batched_step_info(
            core,
            self._trigger,
            host.collided,
            host.clipped_actions,
            diverged,
            reset_infos,
            odometry,
        )

    def _step_info(self, host: HostCopy, i: int) -> dict[str, Any]:
        core = host
        diverged = {i: _DIVERGED_REASON} if host.diverged[i] else {}
        return robot_step_info(
            core,
            i,
            self._trigger,
            bool(host.collided[i]),
            int(host.clipped_actions[i]),
            diverged,
            host.odometry,
        )

    def _check_open(self, method: str) -> None:
        if self._closed:
            raise RuntimeError(f"{method}() called after close(); make a new vector env")

    def get_attr(self, name: str) -> tuple[Any, ...]:
        """The ``name`` attribute of the CPU env that describes every world (one per world)."""
        return (getattr(self._template, name),) * self.num_envs

    def close_extras(self, **kwargs: Any) -> None:
        """Free the device arrays."""
        self._closed = True
        template = getattr(self, "_template", None)
        if template is not None:
            template.close()
        self.__dict__.pop("worlds", None)


def _reset_infos(core: HostCopy, trigger: float, resets: list[int], n: int) -> dict[str, Any]:
    """The reset ``info`` of the ``resets`` worlds, the others' keys zero and masked out.

    What ``collate_infos`` makes of ``robot_info``'s dicts, in whole arrays (65,536 dicts cost
    ~1 s).
    """
    none = np.zeros(n, dtype=bool)
    info = batched_step_info(
        core, trigger, none, np.zeros(n, dtype=np.int64), {}, {}, core.odometry
    )
    del info["is_success"], info["_is_success"]
    chosen = np.zeros(n, dtype=bool)
    chosen[resets] = True
    if not chosen.all():
        for key in [key for key in info if not key.startswith("_")]:
            info[key][~chosen] = 0
            info[f"_{key}"] = chosen.copy()
    return info
