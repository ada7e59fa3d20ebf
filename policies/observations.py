"""The observations a policy takes, checked against an env's when the policy is loaded.

Every BubbleRob policy reads the env's ``Dict`` observation (``laser``, ``proximity``, ...). An
env made with ``obs_mode="flat"`` gives the same readings in one ``Box`` whose layout the env names
(``env.unwrapped.observation_layout``): a policy loaded for it is fed its observations cut back
into the ``Dict`` (:class:`FlatObservationPolicy`). Any other observation (an unknown wrapper's
``Box``, a missing key, another shape) is a one-line :class:`PolicyEnvMismatchError` at load
time, not an error at the first ``predict``.

A trained policy is also checked against the env it was trained for (:func:`check_env`: action
type, laser rays, camera) and, for an SB3 model, its observation space against the env's
(:func:`check_model_spaces`). Every policy adapter (a policy fed its observations changed:
cut from a flat one, pooled, normalised) is an :class:`ObservationAdapter`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from bubblerob_env import BubbleRobEnv
from policies.base import Policy

__all__ = [
    "FlatObservationPolicy",
    "ObservationAdapter",
    "PolicyEnvMismatchError",
    "bubblerob_base",
    "check_env",
    "check_exact_keys",
    "check_model_actions",
    "check_model_spaces",
    "check_observations",
    "dict_view",
    "env_signature",
]


class PolicyEnvMismatchError(ValueError):
    """A policy was asked to drive an env unlike the one it was made or trained for."""


def _shown(space: gym.Space[Any]) -> str:
    """A space in a few words (``str`` of a Box prints its bounds over many lines)."""
    return f"{type(space).__name__}({space.dtype}, shape {space.shape})"


def bubblerob_base(env: gym.Env[Any, Any] | None) -> BubbleRobEnv:
    """The BubbleRob env inside ``env`` (a default ``BubbleRobEnv()`` for None)."""
    if env is None:
        return BubbleRobEnv()
    base = env.unwrapped
    if not isinstance(base, BubbleRobEnv):
        raise TypeError(f"expected a BubbleRob env, got {type(base).__name__}")
    return base


def env_signature(env: gym.Env[Any, Any]) -> dict[str, Any]:
    """What a trained policy depends on: action type, laser rays and camera size (or None)."""
    base = bubblerob_base(env)
    camera = base.camera_spec
    return {
        "action_type": base.action_type,
        "laser_num_rays": 0 if base.laser_spec is None else int(base.laser_spec.num_rays),
        "camera": None if camera is None else [int(camera.height), int(camera.width)],
    }


def _describe(signature: dict[str, Any]) -> str:
    camera = signature.get("camera")
    return (
        f"action_type={signature.get('action_type')!r}, "
        f"laser_num_rays={signature.get('laser_num_rays')}, "
        f"camera={'off' if not camera else 'x'.join(map(str, camera))}"
    )


def check_env(
    name: str, trained: dict[str, Any], env: gym.Env[Any, Any], trained_kwargs: Any = None
) -> None:
    """Raise a one-line :class:`PolicyEnvMismatchError` if ``env`` differs from ``trained``."""
    actual = env_signature(env)
    differing = [key for key in ("action_type", "laser_num_rays", "camera") if key in trained]
    if all(trained[key] == actual[key] for key in differing):
        return
    kwargs = "" if trained_kwargs is None else f" (gym.make kwargs {trained_kwargs})"
    raise PolicyEnvMismatchError(
        f"policy {name!r} was trained for an env with {_describe(trained)}{kwargs}, "
        f"but this env has {_describe(actual)}: make the env it was trained for, or train one "
        "for this env"
    )


def check_exact_keys(name: str, keys: list[str], space: spaces.Dict) -> None:
    """A trained model takes exactly the env's keys: another set means another env."""
    if sorted(keys) != sorted(space.spaces):
        raise PolicyEnvMismatchError(
            f"policy {name!r} takes observation keys {sorted(keys)}, "
            f"but this env gives {sorted(space.spaces)}"
        )


def _pooled_shape(shape: tuple[int, ...], key: str, pooling: list[tuple[str, int]]) -> Any:
    for pooled_key, size in pooling:
        if pooled_key == key:
            if not shape or shape[-1] % size:
                return shape  # the shape check below reports the mismatch
            shape = (*shape[:-1], shape[-1] // size)
    return shape


def check_model_spaces(
    name: str,
    trained: gym.Space[Any],
    env: gym.Env[Any, Any],
    space: spaces.Dict,
    pooling: list[tuple[str, int]],
) -> None:
    """A model's observation space against the env's (its ``Dict``, after laser pooling)."""
    if not isinstance(trained, spaces.Dict):  # trained on obs_mode="flat": fed as it is
        if trained != env.observation_space:
            raise PolicyEnvMismatchError(
                f"policy {name} was trained on flat observations of shape {trained.shape}, but "
                f"this env gives {type(env.observation_space).__name__} observations of shape "
                f"{env.observation_space.shape}: make the env with obs_mode='flat' as in training"
            )
        return
    check_exact_keys(name, list(trained.spaces), space)
    for key, trained_space in trained.spaces.items():
        given = _pooled_shape(tuple(space[key].shape or ()), key, pooling)
        if given != trained_space.shape:
            pooled = " after its laser pooling" if given != space[key].shape else ""
            raise PolicyEnvMismatchError(
                f"policy {name} takes {key} of shape {trained_space.shape}, "
                f"but this env gives {space[key].shape}{pooled}"
            )
        if _bounds(trained_space) != _bounds(space[key]):
            raise PolicyEnvMismatchError(
                f"policy {name} takes {key} in {_bounds(trained_space)}, but this env gives it "
                f"in {_bounds(space[key])}: it was trained for another robot or env kwargs"
            )


def _bounds(space: gym.Space[Any]) -> Any:
    """A ``Box``'s range as ``[low, high]`` (each rounded, one number where all agree), else None.

    Bounds only: pooling shortens a scan but keeps its range, and SB3 stores them as float32.
    """
    if not isinstance(space, spaces.Box):
        return None
    low, high = (
        np.unique(np.round(np.asarray(b, dtype=np.float64), 4)) for b in (space.low, space.high)
    )
    show = [v.tolist() if len(v) > 1 else float(v[0]) for v in (low, high)]
    return show


def check_model_actions(name: str, trained: gym.Space[Any], env: gym.Env[Any, Any]) -> None:
    """A model's action space against the env's: shape and bounds (wheels or twist, the robot).

    A policy trained on twist actions (m/s, rad/s) would drive a wheels env (rad/s per wheel)
    with numbers that mean something else, and another robot's limits clip differently.
    """
    given = env.action_space
    if trained.shape != given.shape or _action_bounds(trained) != _action_bounds(given):
        raise PolicyEnvMismatchError(
            f"policy {name} acts in {_shown(trained)} bounded by {_action_bounds(trained)}, but "
            f"this env takes {_shown(given)} bounded by {_action_bounds(given)} "
            f"(action_type {getattr(env.unwrapped, 'action_type', '?')!r}): it was trained for "
            "another action_type, robot or speed limits"
        )


def _action_bounds(space: gym.Space[Any]) -> Any:
    if not isinstance(space, spaces.Box):
        return None
    return [np.round(np.asarray(b, dtype=np.float64), 4).tolist() for b in (space.low, space.high)]


def dict_view(env: gym.Env[Any, Any], name: str) -> tuple[spaces.Dict, dict[str, slice] | None]:
    """The ``Dict`` space policies see in ``env``, and the flat layout to cut it from.

    The layout is None where ``env`` gives the ``Dict`` itself. Raises
    :class:`PolicyEnvMismatchError` for an observation whose layout is not known.
    """
    space = env.observation_space
    if isinstance(space, spaces.Dict):
        return space, None
    base = env.unwrapped
    layout = getattr(base, "observation_layout", None)
    flat = getattr(base, "obs_mode", "dict") == "flat" and bool(layout)
    full = getattr(base, "dict_observation_space", None)
    if flat and space == base.observation_space and isinstance(full, spaces.Dict):
        assert isinstance(layout, Mapping)
        return full, dict(layout)
    raise PolicyEnvMismatchError(
        f"policy {name!r} takes BubbleRob's Dict observations, but this env gives "
        f"{_shown(space)}, which a wrapper made from them: load the policy for the env inside "
        "that wrapper, or make the env with obs_mode='flat', whose layout is known"
    )


def check_observations(
    name: str, needed: Mapping[str, tuple[int, ...] | None], space: spaces.Dict
) -> None:
    """Raise a one-line :class:`PolicyEnvMismatchError` unless ``space`` has what is ``needed``.

    ``needed`` maps each key the policy reads to the shape it takes (None: any shape).
    """
    given = space.spaces
    missing = sorted(key for key in needed if key not in given)
    if missing:
        raise PolicyEnvMismatchError(
            f"policy {name!r} reads observation keys {sorted(needed)}, but this env gives "
            f"{sorted(given)} (missing {missing})"
        )
    for key, shape in needed.items():
        actual = given[key].shape
        if shape is not None and tuple(actual or ()) != tuple(shape):
            raise PolicyEnvMismatchError(
                f"policy {name!r} takes {key} of shape {tuple(shape)}, "
                f"but this env gives {tuple(actual or ())}"
            )


class ObservationAdapter:
    """The one policy adapter base: a policy fed its observations through :meth:`adapt`.

    Subclasses define ``adapt`` (an observation, or a batch, as the wrapped policy takes it);
    ``predict`` and ``reset`` pass through to the wrapped policy.
    """

    def __init__(self, policy: Policy) -> None:
        self.policy = policy

    def adapt(self, observation: Any) -> Any:
        """The observation as the wrapped policy takes it."""
        raise NotImplementedError

    def predict(
        self,
        observation: Any,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> Any:
        """The wrapped policy's ``predict`` on the adapted observation."""
        return self.policy.predict(self.adapt(observation), state, episode_start, deterministic)

    def reset(self) -> None:
        """Reset the wrapped policy."""
        self.policy.reset()


class FlatObservationPolicy(ObservationAdapter):
    """A policy of ``Dict`` observations driving an ``obs_mode="flat"`` env.

    Each flat observation (one, or a batch with a leading axis) is cut into the ``Dict`` by the
    env's ``observation_layout`` (key -> slice of the last axis) before ``policy`` sees it.
    """

    def __init__(self, policy: Policy, layout: Mapping[str, slice]) -> None:
        super().__init__(policy)
        self.layout = dict(layout)

    def unflatten(self, observation: Any) -> dict[str, NDArray[Any]]:
        """The ``Dict`` observation(s) inside a flat one (or a batch of them)."""
        flat = np.asarray(observation)
        return {key: flat[..., part] for key, part in self.layout.items()}

    adapt = unflatten
