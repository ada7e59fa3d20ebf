"""The vector protocol both batch backends share.

The CPU batch (:mod:`bubblerob_env.batch.cpu`) and the warp batch (:mod:`bubblerob_env.mjwarp`)
use the same seeds, reset masks, action and autoreset-mode checks, Gymnasium's batched ``info``
(``collate_infos``, ``add_finals``) and the batched observation's rows.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode
from numpy.typing import NDArray

__all__ = [
    "BatchObs",
    "add_finals",
    "checked_actions",
    "checked_autoreset_mode",
    "collate_infos",
    "reset_mask",
    "robot_obs",
    "world_seeds",
]

BatchObs = dict[str, NDArray[Any]] | NDArray[np.float32]
"""Batched observations: a dict of arrays (``obs_mode="dict"``) or one array (``"flat"``)."""


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
