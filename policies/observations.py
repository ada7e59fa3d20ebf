"""The observations a policy takes, checked against an env's when the policy is loaded.

Every BubbleRob policy reads the env's ``Dict`` observation (``laser``, ``proximity``, ...). An
env made with ``obs_mode="flat"`` gives the same readings in one ``Box`` whose layout the env names
(``env.unwrapped.observation_layout``): a policy loaded for it is fed its observations cut back
into the ``Dict`` (:class:`FlatObservationPolicy`). Any other observation (an unknown wrapper's
``Box``, a missing key, another shape) is a one-line :class:`PolicyEnvMismatchError` at load
time, not an error at the first ``predict``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from policies.base import Policy

__all__ = [
    "FlatObservationPolicy",
    "ObservationAdapter",
    "PolicyEnvMismatchError",
    "check_observations",
    "dict_view",
]


class PolicyEnvMismatchError(ValueError):
    """A policy was asked to drive an env unlike the one it was made or trained for."""


def _shown(space: gym.Space[Any]) -> str:
    """A space in a few words (``str`` of a Box prints its bounds over many lines)."""
    return f"{type(space).__name__}({space.dtype}, shape {space.shape})"


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
    """A policy fed its observations through :meth:`adapt` (what subclasses define)."""

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
