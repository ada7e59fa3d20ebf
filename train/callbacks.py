"""SB3 callbacks for rl-zoo's ``callback`` hyperparameter (``{"module.Class": {kwargs}}``).

``ObstacleCurriculum`` starts training in emptier arenas: the number of obstacles per episode
grows from ``start`` to the env's own ``num_obstacles`` over the first ``ramp_fraction`` of
training. Only the training envs change; evaluation episodes are always the full task.
"""

from __future__ import annotations

import math
import operator
from typing import Any

from stable_baselines3.common.callbacks import BaseCallback

__all__ = ["ObstacleCurriculum"]


def _number(value: Any) -> float:
    """``value`` as a float, NaN for anything else (which no range check accepts)."""
    if isinstance(value, bool):
        return math.nan
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def _start_range(start: Any) -> tuple[int, int]:
    """``[low, high]`` as two ints, ``(-1, -1)`` for anything else (refused by the caller)."""
    try:
        low, high = (operator.index(value) for value in start)  # ints, NumPy's too
    except (TypeError, ValueError):
        return -1, -1
    return low, high


class ObstacleCurriculum(BaseCallback):
    """Grow the training envs' ``num_obstacles`` range linearly from ``start`` to the env's own.

    The new range applies from each env's next ``reset``. ``start`` is an inclusive
    ``[low, high]`` no larger than the env's range (the env places at most its own ``high``).
    """

    def __init__(
        self, start: tuple[int, int] | list[int] = (0, 3), ramp_fraction: float = 0.5
    ) -> None:
        super().__init__()
        low, high = _start_range(start)
        if not 0 <= low <= high:
            raise ValueError(
                f"ObstacleCurriculum start must be two ints [low, high] with 0 <= low <= high, "
                f"got {start!r}"
            )
        fraction = _number(ramp_fraction)
        if not 0.0 < fraction <= 1.0:
            raise ValueError(
                "ObstacleCurriculum ramp_fraction must be a number in (0, 1], "
                f"got {ramp_fraction!r}"
            )
        self.start = (low, high)
        self.ramp_fraction = fraction
        self.target: tuple[int, int] = (low, high)
        self.current: tuple[int, int] | None = None

    def _on_training_start(self) -> None:
        target = tuple(self.training_env.get_attr("num_obstacles")[0])
        if self.start[1] > target[1] or self.start[0] > target[0]:
            raise ValueError(
                f"ObstacleCurriculum start {list(self.start)} exceeds the env's num_obstacles "
                f"{list(target)}"
            )
        self.target = (int(target[0]), int(target[1]))
        self._apply()

    def _on_rollout_start(self) -> None:
        self._apply()

    def _on_step(self) -> bool:
        return True

    def range_at(self, progress: float) -> tuple[int, int]:
        """The ``num_obstacles`` range after ``progress`` (0..1) of training."""
        ramp = min(1.0, max(0.0, progress) / self.ramp_fraction)
        low = round(self.start[0] + ramp * (self.target[0] - self.start[0]))
        high = round(self.start[1] + ramp * (self.target[1] - self.start[1]))
        return int(low), int(high)

    def _apply(self) -> None:
        total: Any = getattr(self.model, "_total_timesteps", 0) or 1
        wanted = self.range_at(self.num_timesteps / float(total))
        if wanted != self.current:
            # Through the wrappers (Monitor, TimeLimit) to the env that owns the attribute.
            self.training_env.env_method("set_wrapper_attr", "num_obstacles", wanted)
            self.current = wanted
            self.logger.record("curriculum/max_obstacles", wanted[1])
