"""The Nav task on every slot of :class:`~bubblerob_env.multi.vector.WorldsVectorEnv`.

One :class:`~bubblerob_env.multi.goals.WorldGoals` per world, so each slot's goal, ``goal``
reading, reward parts, arrival and ``info`` keys are ``parallel_env(task="nav")``'s robot's, which
are the single Nav task's (:mod:`~bubblerob_env.tasks.nav_rules`). What the batch adds: a slot
that starts again gets a fresh goal (drawn as ``scenario="random"`` draws one, on its world's
grid, apart from the other robots' goals), and the readings and ``info`` are batched.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from bubblerob_env.arena import ArenaLayout
from bubblerob_env.batch.common import BatchObs
from bubblerob_env.config import EnvConfig
from bubblerob_env.core.kernel import OUT
from bubblerob_env.multi.goals import WorldGoals
from bubblerob_env.tasks.nav_rules import WANDERING_PARTS, NavSettings, with_goal

__all__ = ["NAV_PARTS", "SlotGoals"]

NAV_PARTS = ("reward_progress", "reward_arrival", "reward_collision", "reward_time")
"""The Nav task's reward parts, in the order :meth:`NavSettings.reward_parts` gives them."""
_X, _Y, _YAW = int(OUT.POSITION), int(OUT.POSITION + 1), int(OUT.YAW)
_COLLISION, _COLLISION_COST = int(OUT.COLLISION), int(OUT.COLLISION_COST)

Pose = tuple[float, float, float]
StepParts = list[dict[str, float]]


class SlotGoals:
    """The goals of ``num_worlds`` worlds of ``num_robots`` robots; slot ``i = w * N + k``."""

    def __init__(
        self, settings: NavSettings, config: EnvConfig, num_worlds: int, num_robots: int
    ) -> None:
        self.settings = settings
        self.num_robots = num_robots
        self.worlds = [WorldGoals(settings, config, num_robots) for _ in range(num_worlds)]

    def draw(
        self,
        w: int,
        rng: np.random.Generator,
        layout: ArenaLayout,
        poses: list[Pose],
        scenario: str,
    ) -> ArenaLayout | None:
        """World ``w``'s goals (``WorldGoals.draw``): the layout to use, None to draw again."""
        return self.worlds[w].draw(rng, layout, poses, scenario)

    def redraw(self, i: int, rng: np.random.Generator, start: tuple[float, float]) -> bool:
        """A fresh goal for slot ``i``'s new robot at ``start``; False when none qualifies."""
        w, k = divmod(i, self.num_robots)
        return self.worlds[w].redraw(k, rng, start)

    def begin(self, rows: list[int], out: NDArray[np.float64]) -> None:
        """The episodes of ``rows`` begin where the kernel's results put their robots."""
        for i in rows:
            w, k = divmod(i, self.num_robots)
            row = out[i].tolist()
            self.worlds[w].begin(k, (row[_X], row[_Y], row[_YAW]))

    def step(
        self, out: NDArray[np.float64], truncated: NDArray[np.bool_]
    ) -> tuple[NDArray[np.float64], NDArray[np.bool_], StepParts]:
        """Every slot's step: rewards, arrivals, and each slot's reward parts."""
        n = out.shape[0]
        rewards, arrived = np.zeros(n), np.zeros(n, dtype=bool)
        parts: StepParts = []
        for i, row in enumerate(out.tolist()):
            w, k = divmod(i, self.num_robots)
            pose = (row[_X], row[_Y], row[_YAW])
            collision = row[_COLLISION] != 0.0
            slot_parts, arrived[i] = self.worlds[w].advance(
                k, pose, collision, row[_COLLISION_COST], bool(truncated[i])
            )
            rewards[i] = sum(slot_parts.values())
            parts.append(slot_parts)
        return rewards, arrived, parts

    def observations(self, obs: BatchObs) -> BatchObs:
        """``obs`` with every slot's ``goal`` reading (a key, or the last two flat columns)."""
        readings = np.stack(
            [world.reading(k) for world in self.worlds for k in range(self.num_robots)]
        )
        if isinstance(obs, dict):
            batched: BatchObs = with_goal(obs, readings)
            return batched
        return np.concatenate([obs, readings], axis=1)

    def slot_info(self, i: int, info: dict[str, Any]) -> dict[str, Any]:
        """One slot's ``info`` with its goal, straight distance, shortest path and driven."""
        w, k = divmod(i, self.num_robots)
        return self.worlds[w].task_info(k, info)

    def final_info(
        self, i: int, info: dict[str, Any], parts: dict[str, float], arrived: bool
    ) -> dict[str, Any]:
        """An ended slot's last ``info``: the Nav parts for the wandering ones, and success."""
        for key in WANDERING_PARTS:
            del info[key]
        info.update(parts)
        info["is_success"] = arrived
        return self.slot_info(i, info)

    def step_info(
        self,
        info: dict[str, Any],
        parts: StepParts,
        arrived: NDArray[np.bool_],
        restarted: NDArray[np.bool_],
    ) -> None:
        """The batch's step ``info`` (dict of arrays) made the Nav task's, in place.

        ``restarted`` slots hold their new episode's reset ``info`` (the wandering parts, no
        ``is_success``), the others their step's (the Nav parts and ``is_success``: arrived).
        """
        stepped = ~restarted
        for key in WANDERING_PARTS:
            info[f"_{key}"] = restarted.copy()
        for key in NAV_PARTS:
            if key != "reward_collision":  # the same column in a reset and a step
                info[key] = np.array([p[key] for p in parts])
                info[f"_{key}"] = stepped.copy()
        info["is_success"] = arrived & stepped
        info["_is_success"] = stepped.copy()
        rows = [
            self.slot_info(i, {}) for i in range(len(self.worlds) * self.num_robots)
        ]  # fmt: skip
        everywhere = np.ones(len(rows), dtype=bool)
        for key in ("goal", "goal_distance", "shortest_path_length", "distance_driven"):
            info[key] = np.array([row[key] for row in rows])
            info[f"_{key}"] = everywhere.copy()
