"""What every BubbleRob policy shares: SB3's ``predict`` call on single or batched observations."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from bubblerob_env.kinematics import DiffDrive

__all__ = ["ActionMapper", "Observation", "Policy", "as_batch", "batch_size", "take"]

Observation = dict[str, NDArray[Any]]
"""One BubbleRob observation (keys ``laser``, ``proximity``, ``velocity``, maybe ``camera``), or a
batch of them (each value with a leading batch axis)."""


@runtime_checkable
class Policy(Protocol):
    """What ``load_policy`` returns: SB3's ``predict`` and a ``reset`` between episodes.

    ``predict`` takes one observation or a batch and gives the action (shape (2,)) or actions
    (shape (n, 2)), float32 in [-1, 1], and the policy's state (None for stateless policies).
    Stateful policies start over where ``episode_start`` is true, or after ``reset()``.
    """

    def predict(
        self,
        observation: Observation,
        state: Any = None,
        episode_start: NDArray[np.bool_] | None = None,
        deterministic: bool = True,
    ) -> tuple[NDArray[np.float32], Any]:
        """Action(s) for ``observation`` and the policy's state."""
        ...

    def reset(self) -> None:
        """Forget any state carried between calls."""
        ...


def batch_size(obs: dict[str, NDArray[Any]]) -> int | None:
    """``None`` for one observation (``proximity`` of shape (1,)), else the number of envs."""
    proximity = np.asarray(obs["proximity"])
    return None if proximity.ndim == 1 else int(proximity.shape[0])


def as_batch(
    observation: dict[str, Any], shapes: dict[str, tuple[int, ...]]
) -> tuple[dict[str, NDArray[Any]], bool]:
    """``observation``'s ``shapes`` keys as a batch, and whether it was one observation.

    One observation has each key of its shape in ``shapes``; a batch has a leading axis more.
    A network's ``predict`` (ONNX, SB3) runs batches and gives a single observation one action.
    """
    first = next(iter(shapes))
    single = np.ndim(observation[first]) == len(shapes[first])
    batch = {key: np.asarray(observation[key]) for key in shapes}
    return ({key: value[None] for key, value in batch.items()} if single else batch), single


def take(obs: dict[str, NDArray[Any]], index: int | None) -> dict[str, NDArray[Any]]:
    """Observation ``index`` of a batch (or the observation itself when ``index`` is None)."""
    if index is None:
        return obs
    return {key: np.asarray(value)[index] for key, value in obs.items()}


@dataclass(frozen=True)
class ActionMapper:
    """Turns a wanted body twist or wheel speeds into a normalised action for either action type."""

    drive: DiffDrive
    action_type: str = "wheels"
    max_linear_speed: float | None = None
    max_angular_speed: float | None = None

    @property
    def linear_limit(self) -> float:
        """m/s meant by a linear action of 1 in twist mode."""
        return self.max_linear_speed or self.drive.max_linear_speed

    @property
    def angular_limit(self) -> float:
        """rad/s meant by an angular action of 1 in twist mode."""
        return self.max_angular_speed or self.drive.max_angular_speed

    def from_twist(self, linear: float, angular: float) -> NDArray[np.float32]:
        """Action that drives at ``linear`` m/s while turning at ``angular`` rad/s."""
        if self.action_type == "twist":
            action = [linear / self.linear_limit, angular / self.angular_limit]
        else:
            action = list(self.drive.wheel_speeds(linear, angular) / self.drive.max_wheel_speed)
        return np.clip(np.array(action, dtype=np.float32), -1.0, 1.0)

    def from_wheels(self, left: float, right: float) -> NDArray[np.float32]:
        """Action for wheel speeds given as fractions of the wheel limit."""
        if self.action_type == "wheels":
            action = [left, right]
        else:
            max_wheel = self.drive.max_wheel_speed
            linear, angular = self.drive.body_twist(left * max_wheel, right * max_wheel)
            action = [linear / self.linear_limit, angular / self.angular_limit]
        return np.clip(np.array(action, dtype=np.float32), -1.0, 1.0)
