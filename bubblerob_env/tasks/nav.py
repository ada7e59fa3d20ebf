"""``BubbleRobNav-v0`` and ``PioneerP3DXNav-v0``: drive to a goal, a thin task on BubbleRobEnv."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from bubblerob_env.batch.common import Observation
from bubblerob_env.checks import unexpected_kwargs_error
from bubblerob_env.config import ARGUMENTS
from bubblerob_env.env import BubbleRobEnv
from bubblerob_env.mapping import DEFAULT_RESOLUTION, FREE, Grid, has_arena
from bubblerob_env.tasks.goals import (
    NavProblem,
    cell_of,
    clearance_grid,
    draw_problem,
    path_length,
    plan_path,
)
from bubblerob_env.tasks.nav_rules import (
    NAV_ARGUMENTS,
    WANDERING_PARTS,
    NavSettings,
    goal_reading,
    spaces_with_goal,
    with_goal,
)

__all__ = ["NAV_INFO_KEYS", "BubbleRobNavEnv", "check_goal", "planned_problem"]

NAV_INFO_KEYS = ("goal", "goal_distance", "shortest_path_length", "distance_driven")
"""What every ``info`` of a Nav env adds (with ``is_success``: the goal reached)."""
_LAYOUT_TRIES = 20  # layouts drawn before giving up on finding a goal (never needed in tests)


class BubbleRobNavEnv(BubbleRobEnv):
    """Drive to a goal without touching anything: ``gym.make("BubbleRobNav-v0")``.

    ## Description
    The robot, arena, sensors and actions of ``BubbleRob-v0`` (or ``PioneerP3DX-v0`` for
    ``PioneerP3DXNav-v0``), every keyword argument included; the task is to reach a goal.

    ## Observation Space
    ``BubbleRob-v0``'s, plus ``goal`` ``(2,)``: the goal's distance (m) and bearing (rad,
    counter-clockwise from the robot's heading, in [-pi, pi]) in the robot's frame. With
    ``obs_mode="flat"`` the two follow the other readings (``observation_layout["goal"]``).

    ## Starting State
    ``BubbleRob-v0``'s layout and start pose, then a goal drawn uniformly among the cells of the
    ground-truth grid (``grid_resolution`` m a cell) that the robot can reach from its start:
    every wall and obstacle widened by the robot's radius, searched by Dijkstra (8-connected,
    exact diagonal costs), at least ``min_goal_distance`` m from the start in a straight line.
    ``info["shortest_path_length"]`` is that search's path shortened by line of sight
    (:mod:`bubblerob_env.tasks.goals`); ``env.unwrapped.problem`` holds the path itself.
    ``reset(options={"goal": (x, y)})`` sets the goal instead (refused outside the arena, in a
    widened obstacle, or out of reach).

    ## Rewards
    ``reward = progress + arrival + collision + time``, each part in ``info``:
    ``reward_progress = progress_reward_weight * (d_before - d_after)`` with ``d`` the straight
    distance to the goal (as DRL-robot-navigation and Long et al.; the shortest path's length
    would need a distance field per step), ``reward_arrival = arrival_reward`` on reaching it,
    ``reward_collision = -collision_penalty`` on a touch and ``reward_time = -time_cost`` every
    step. ``BubbleRob-v0``'s wandering parts (forward, spin, clearance) are not used.

    ## Episode End
    Terminates with ``info["is_success"] = True`` when the robot's centre comes within
    ``goal_radius`` m of the goal; terminates as a failure on a collision (with
    ``terminate_on_collision``, the default); truncates at the time limit (1000 steps, 50 s) or
    a diverged simulation. ``is_success`` is False on every other step.

    ## Arguments
    ``BubbleRob-v0``'s, and ``goal_radius`` (m, > 0, default 0.2: Habitat's), ``min_goal_distance``
    (m, default 1), ``progress_reward_weight`` (per metre, default 10), ``arrival_reward``
    (default 100), ``time_cost`` (per step, default 0.01) and ``grid_resolution`` (m, default
    0.05). The scene must have the arena's walls.

    ## Version History
    - v0 (2026-11-27, issue #37): initial version.
    """

    def __init__(
        self,
        goal_radius: float = 0.2,
        min_goal_distance: float = 1.0,
        progress_reward_weight: float = 10.0,
        arrival_reward: float = 100.0,
        time_cost: float = 0.01,
        grid_resolution: float = DEFAULT_RESOLUTION,
        **env_kwargs: Any,
    ) -> None:
        """The task's arguments (see Arguments); every other one goes to :class:`BubbleRobEnv`."""
        unknown = [name for name in env_kwargs if name not in ARGUMENTS]
        if unknown:
            valid = [*NAV_ARGUMENTS, *ARGUMENTS]
            raise unexpected_kwargs_error("BubbleRobNavEnv.__init__", unknown, valid)
        self.settings = NavSettings.checked(
            goal_radius=goal_radius,
            min_goal_distance=min_goal_distance,
            progress_reward_weight=progress_reward_weight,
            arrival_reward=arrival_reward,
            time_cost=time_cost,
            grid_resolution=grid_resolution,
        )
        """The task's arguments, checked (shared with ``parallel_env(task="nav")``)."""
        settings = self.settings
        self.goal_radius, self.min_goal_distance = settings.goal_radius, settings.min_goal_distance
        self.progress_reward_weight = settings.progress_reward_weight
        self.arrival_reward, self.time_cost = settings.arrival_reward, settings.time_cost
        self.grid_resolution = settings.grid_resolution
        super().__init__(**env_kwargs)
        if not has_arena(self):
            raise ValueError(
                f"the Nav task needs a scene with the arena's walls; {self.xml_file.name} has none"
            )
        self._add_goal_to_spaces()
        self.problem: NavProblem | None = None
        """This episode's start, goal, shortest path and widened grid (after ``reset``)."""
        self.robot_pose = (0.0, 0.0, 0.0)
        """The robot's ground-truth (x, y, yaw) after the last ``reset`` or ``step``."""
        self._goal_distance = 0.0
        self._distance_driven = 0.0
        self._touched = False

    def _add_goal_to_spaces(self) -> None:
        flat = self.observation_format.space if self.obs_mode == "flat" else None
        assert flat is None or isinstance(flat, spaces.Box)
        self.dict_observation_space, self.observation_space, goal_slice = spaces_with_goal(
            self.dict_observation_space, flat, float(self.arena_size)
        )
        if goal_slice is not None:
            self.observation_layout = {**self.observation_layout, "goal": goal_slice}

    @property
    def goal(self) -> tuple[float, float]:
        """This episode's goal (x, y), metres in the world frame."""
        if self.problem is None:
            raise RuntimeError("the goal is drawn by reset(): reset the env first")
        return self.problem.goal

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Observation, dict[str, Any]]:
        """A layout and start pose as ``BubbleRob-v0``'s, then a goal (see Starting State)."""
        options = dict(options or {})
        given_goal = options.pop("goal", None)
        obs, info = super().reset(seed=seed, options=options)
        for _ in range(_LAYOUT_TRIES):
            problem = self._problem(given_goal)
            if problem is not None:
                break
            obs, info = super().reset(options=options)  # the start is boxed in: another layout
        else:
            raise RuntimeError(f"no reachable goal in {_LAYOUT_TRIES} layouts: a crowded arena")
        self.problem = problem
        self._distance_driven = 0.0
        self._touched = False
        self._goal_distance = self._update_pose(info)
        info = self._task_info(info)
        return self._with_goal(obs), info

    def _problem(self, goal: Any) -> NavProblem | None:
        assert self.layout is not None
        radius, arena = self.robot.radius, float(self.arena_size)
        if goal is None:
            return draw_problem(
                self.np_random, self.layout, arena, radius, self.min_goal_distance,
                self.grid_resolution,
            )  # fmt: skip
        grid = clearance_grid(self.layout, arena, radius, self.grid_resolution)
        start = self.layout.start_pose[:2]
        return planned_problem(grid, goal, (start[0], start[1]), radius, arena)

    def set_goal(self, goal: Any, start: tuple[float, float] | None = None) -> NavProblem:
        """Give this episode a new goal ``(x, y)`` now, as a ROS user's goal does mid-episode.

        The shortest path is planned from ``start`` (default: the robot's position; the live
        node passes its pose estimate) on this episode's grid; the goal is refused with a
        ``ValueError`` as ``reset``'s ``options["goal"]``. ``info``'s goal and shortest path
        follow from the next step; the distance driven goes on.
        """
        if self.problem is None:
            raise RuntimeError("set_goal() called before reset(): reset the env first")
        here = self.robot_pose[:2] if start is None else (float(start[0]), float(start[1]))
        radius, arena = self.robot.radius, float(self.arena_size)
        self.problem = planned_problem(self.problem.grid, goal, here, radius, arena)
        x, y, _ = self.robot_pose
        self._goal_distance = math.hypot(self.problem.goal[0] - x, self.problem.goal[1] - y)
        return self.problem

    def step(
        self, action: NDArray[np.float32]
    ) -> tuple[Observation, float, bool, bool, dict[str, Any]]:
        """One control step (``BubbleRob-v0``'s), scored and ended by the goal (see Rewards)."""
        if self.problem is None:
            raise RuntimeError("step() called before reset(): reset the env first")
        obs, _, terminated, truncated, info = super().step(action)
        before = self._goal_distance
        x0, y0 = self.robot_pose[:2]
        after = self._update_pose(info)
        self._distance_driven += math.hypot(self.robot_pose[0] - x0, self.robot_pose[1] - y0)
        self._touched = self._touched or bool(info["collision"])
        arrived = self.settings.arrived(after, self._touched, bool(truncated))
        parts = self.settings.reward_parts(before, after, arrived, float(info["reward_collision"]))
        for key in WANDERING_PARTS:
            del info[key]
        info.update(parts)
        info["is_success"] = arrived
        return (
            self._with_goal(obs),
            sum(parts.values()),
            terminated or arrived,
            truncated,
            self._task_info(info),
        )

    def _update_pose(self, info: dict[str, Any]) -> float:
        """Keep the robot's pose from ``info``; its straight distance to the goal."""
        self.robot_pose = (float(info["x"]), float(info["y"]), float(info["yaw"]))
        self._goal_distance = math.hypot(
            self.goal[0] - self.robot_pose[0], self.goal[1] - self.robot_pose[1]
        )
        return self._goal_distance

    def _task_info(self, info: dict[str, Any]) -> dict[str, Any]:
        assert self.problem is not None
        info["goal"] = np.array(self.problem.goal)
        info["goal_distance"] = self._goal_distance
        info["shortest_path_length"] = self.problem.length
        info["distance_driven"] = self._distance_driven
        return info

    def _with_goal(self, obs: Observation) -> Observation:
        """``obs`` with the goal's distance and bearing in the robot's frame."""
        return with_goal(obs, goal_reading(self.robot_pose, self.goal))


def planned_problem(
    grid: Grid, goal: Any, start: tuple[float, float], radius: float, arena_size: float
) -> NavProblem:
    """The problem of reaching ``goal`` from ``start`` on ``grid``; a ``ValueError`` if none."""
    target = check_goal(goal, arena_size)
    if grid.data[cell_of(grid, target)] != FREE:
        raise ValueError(
            f"goal {target} is inside an obstacle or a wall widened by the robot's radius "
            f"({radius} m); choose a free point"
        )
    path = plan_path(grid, start, target)
    if path is None:
        raise ValueError(f"goal {target} cannot be reached from {start}")
    return NavProblem(start, target, path, path_length(path), grid)


def check_goal(goal: Any, arena_size: float) -> tuple[float, float]:
    """``options["goal"]`` as (x, y) inside the arena, or a ``ValueError`` naming it."""
    try:
        x, y = (float(v) for v in goal)
    except (TypeError, ValueError):
        raise ValueError(f"goal must be two numbers (x, y) in metres, got {goal!r}") from None
    half = arena_size / 2.0
    if not (abs(x) < half and abs(y) < half):  # NaN fails too
        raise ValueError(
            f"goal {goal!r} is outside the arena: x and y must be inside (-{half:g}, {half:g}) m"
        )
    return x, y
