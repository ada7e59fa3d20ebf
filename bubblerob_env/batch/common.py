"""The vector protocol both batch backends share, and the observation, built in one place.

The CPU batch (:mod:`bubblerob_env.batch.cpu`) and the warp batch (:mod:`bubblerob_env.mjwarp`)
use the same seeds, reset masks, action and autoreset-mode checks and Gymnasium's batched
``info`` (``collate_infos``, ``add_finals``). :class:`ObservationFormat` gives the observation
spaces and assembles observations from the readings, for the single env (one robot's) and both
batches (every robot's rows) alike; :func:`checked_action` is the single env's action check.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode
from numpy.typing import NDArray

if TYPE_CHECKING:
    from bubblerob_env.scene import Scene

__all__ = [
    "BatchObs",
    "Observation",
    "ObservationFormat",
    "add_finals",
    "checked_action",
    "checked_actions",
    "checked_autoreset_mode",
    "collate_infos",
    "reset_mask",
    "robot_obs",
    "world_seeds",
]

Observation = dict[str, NDArray[Any]] | NDArray[np.float32]
"""A ``Dict`` observation (``obs_mode="dict"``) or a flat one (``obs_mode="flat"``)."""
BatchObs = dict[str, NDArray[Any]] | NDArray[np.float32]
"""Batched observations: a dict of arrays (``obs_mode="dict"``) or one array (``"flat"``)."""


class ObservationFormat:
    """The observation of a scene's robot: its spaces, and how readings become one.

    ``dict_space`` is the ``Dict`` space whatever ``obs_mode`` is; ``space`` is the env's
    ``observation_space`` (the ``Dict``, or for ``obs_mode="flat"`` one float32 ``Box`` of the
    laser, proximity and velocity readings in that order, ``layout`` naming each one's slice).
    """

    def __init__(self, scene: Scene) -> None:
        velocity_limit = scene.limits.velocity_limit.astype(np.float32)
        obs_spaces: dict[str, spaces.Space[Any]] = {}
        laser = scene.laser_spec
        if laser is not None:
            obs_spaces["laser"] = spaces.Box(0.0, laser.range_max, (laser.num_rays,), np.float32)
        proximity_max = scene.proximity_spec.range_max
        obs_spaces["proximity"] = spaces.Box(0.0, proximity_max, (1,), np.float32)
        obs_spaces["velocity"] = spaces.Box(-velocity_limit, velocity_limit, dtype=np.float32)
        if scene.camera_spec is not None:
            shape = (scene.camera_spec.height, scene.camera_spec.width, 3)
            obs_spaces["camera"] = spaces.Box(0, 255, shape, np.uint8)
        self.dict_space = spaces.Dict(obs_spaces)
        self.flat = scene.config.obs_mode == "flat"
        self.layout: dict[str, slice] = {}
        """``obs_mode="flat"``: each reading's slice of the flat observation."""
        self.space: spaces.Space[Any] = self.dict_space
        if not self.flat:
            return
        lows, highs, start = [], [], 0
        for key, box in obs_spaces.items():
            assert isinstance(box, spaces.Box)
            self.layout[key] = slice(start, start + box.shape[0])
            start += box.shape[0]
            lows.append(box.low)
            highs.append(box.high)
        self.space = spaces.Box(np.concatenate(lows), np.concatenate(highs), dtype=np.float32)

    def assemble(
        self,
        laser: NDArray[np.float32] | None,
        proximity: NDArray[np.float32],
        velocity: NDArray[np.float32],
        camera: NDArray[np.uint8] | None = None,
    ) -> Any:
        """The observation of these readings (``None``: the robot has no such sensor).

        One robot's readings (1-D, the camera ``(h, w, 3)``) or a batch's rows (one more leading
        axis); the arrays are used as they are (callers copy reused buffers).
        """
        parts: dict[str, NDArray[Any]] = {}
        if laser is not None:
            parts["laser"] = laser
        parts["proximity"] = proximity
        parts["velocity"] = velocity
        if camera is not None:
            parts["camera"] = camera
        if self.flat:
            return np.concatenate(list(parts.values()), axis=-1)
        return parts


def world_seeds(seed: int | Sequence[int | None] | None, n: int) -> list[int | None]:
    """Each world's reset seed: ``None`` for all, ``seed + i`` for an int, or one each (a list)."""
    if seed is None:
        return [None] * n
    if isinstance(seed, (int, np.integer)):
        return [int(seed) + i for i in range(n)]
    seeds = list(seed)
    if len(seeds) != n:
        raise ValueError(f"seed must be None, an int or {n} seeds (one per robot), got {seed!r}")
    return seeds


def checked_autoreset_mode(value: str | AutoresetMode) -> AutoresetMode:
    """``value`` as a Gymnasium autoreset mode the batch supports, or a ``ValueError``."""
    modes = [AutoresetMode.NEXT_STEP.value, AutoresetMode.SAME_STEP.value]
    if value not in modes and getattr(value, "value", None) not in modes:
        raise ValueError(f"autoreset_mode must be one of {modes}, got {value!r}")
    return AutoresetMode(value)


def reset_mask(
    options: dict[str, Any] | None, num_envs: int
) -> tuple[NDArray[np.bool_], dict[str, Any]]:
    """The robots ``reset`` resets (``options["reset_mask"]``, default all), other options."""
    left = dict(options or {})
    mask = left.pop("reset_mask", None)
    chosen = np.ones(num_envs, dtype=bool) if mask is None else np.asarray(mask, bool)
    if chosen.shape != (num_envs,):
        raise ValueError(f"options['reset_mask'] must have shape ({num_envs},)")
    return chosen, left


def checked_action(action: Any) -> tuple[float, float]:
    """One robot's action as two finite floats, or a ``ValueError`` saying what is wrong."""
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


def checked_actions(actions: Any, num_envs: int) -> NDArray[np.float64]:
    """Every robot's action, checked before any robot steps (a bad row moves nothing)."""
    try:
        checked = np.asarray(actions, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as error:
        raise ValueError(f"actions must be {num_envs} rows of 2 finite numbers: {error}") from None
    if checked.shape != (num_envs, 2):
        raise ValueError(f"actions must have shape ({num_envs}, 2), got {checked.shape}")
    bad = ~np.isfinite(checked).all(axis=1)
    if bad.any():
        rows = np.flatnonzero(bad)
        raise ValueError(
            f"actions of robot(s) {rows.tolist()} contain NaN or infinity "
            f"({checked[rows[0]].tolist()}); actions must be finite numbers, and are clipped "
            "to [-1, 1]; no robot was stepped"
        )
    return checked


def add_finals(
    info: dict[str, Any], finals: dict[int, tuple[Any, dict[str, Any]]], num_envs: int
) -> None:
    """``SameStep`` autoreset: the last observation and ``info`` of the robots in ``finals``."""
    done = np.zeros(num_envs, dtype=bool)
    done[list(finals)] = True
    final_obs = np.empty(num_envs, dtype=object)
    for i in range(num_envs):
        final_obs[i] = finals[i][0] if i in finals else None
    info["final_obs"], info["_final_obs"] = final_obs, done
    info["final_info"] = collate_infos(
        [finals[i][1] if i in finals else {} for i in range(num_envs)]
    )
    info["_final_info"] = done


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


def robot_obs(obs: Any, i: int) -> Any:
    """Robot ``i``'s row of a batched observation (a copy)."""
    if isinstance(obs, dict):
        return {key: value[i].copy() for key, value in obs.items()}
    return obs[i].copy()
