"""Every robot of a world drives to its own goal: the state of ``parallel_env(task="nav")``.

Goals (``scenario="random"``) are drawn as the single Nav task draws one (:mod:`~bubblerob_env.
tasks.goals`): a free cell's centre on the ground-truth grid widened by the robot's radius,
reachable from the robot's start, at least ``min_goal_distance`` from it. The grid keeps the
walls and obstacles and ignores the other robots (they move); goals keep
``2 * radius + start_clearance`` apart (the start poses' spacing), so two robots parked at their
goals never touch. ``scenario="circle"``: each robot's goal is the antipodal point of its start
(Long et al., ICRA 2018), and obstacles that crowd a goal are left out, as they are around the
starts. The reward parts, the ``goal`` reading and arrival are the single task's
(:mod:`~bubblerob_env.tasks.nav_rules`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bubblerob_env.arena import ArenaLayout
from bubblerob_env.config import EnvConfig
from bubblerob_env.tasks.goals import NavProblem, clearance_grid, draw_goal, path_length, plan_path
from bubblerob_env.tasks.nav import planned_problem
from bubblerob_env.tasks.nav_rules import NAV_ARGUMENTS, WANDERING_PARTS, NavSettings, goal_reading

__all__ = ["TASKS", "WorldGoals", "circle_arena_size", "task_config", "task_settings"]

TASKS = ("wander", "nav")
"""``parallel_env``'s tasks: ``BubbleRob-v0``'s obstacle avoidance, or each robot to a goal."""

Pose = tuple[float, float, float]


def task_settings(task: str, kwargs: dict[str, Any]) -> NavSettings | None:
    """The Nav task's settings, its arguments taken out of ``kwargs``; None for ``"wander"``.

    An unknown task, a Nav argument with ``task="wander"`` or a bad value: one ``ValueError``.
    """
    if task not in TASKS:
        raise ValueError(f"task must be one of {list(TASKS)}, got {task!r}")
    arguments = {name: kwargs.pop(name) for name in NAV_ARGUMENTS if name in kwargs}
    if arguments and task != "nav":
        raise ValueError(f"{sorted(arguments)} are arguments of task='nav', not {task!r}")
    return NavSettings.checked(**arguments) if task == "nav" else None


def circle_arena_size(config: EnvConfig, num_robots: int) -> float:
    """The arena side whose start circle gives each robot ``4 r + c`` of arc (r: its radius).

    ``c``: ``start_clearance``. Two robot diameters and the clearance per robot on the circle
    leave a robot room to pass between any two neighbours. The circle's radius is then
    ``R = N (4 r + c) / (2 pi)`` and the arena ``2 (R + r + c)``, rounded up to 0.1 m.
    """
    radius, clearance = config.robot.radius, config.start_clearance
    circle = num_robots * (4.0 * radius + clearance) / (2.0 * math.pi)
    return math.ceil(round(20.0 * (circle + radius + clearance), 6)) / 10.0


def task_config(
    settings: NavSettings | None,
    scenario: str,
    num_robots: int,
    kwargs: dict[str, Any],
    robot: str,
) -> EnvConfig:
    """The world's config; with the Nav task on the circle, an arena that gives room to pass.

    The arena grows to :func:`circle_arena_size` unless ``arena_size`` is given (``kwargs``: the
    single env's arguments, the Nav ones already taken out by :func:`task_settings`).
    """
    config = EnvConfig.from_kwargs({**kwargs, "robot": robot})
    if settings is not None and scenario == "circle" and "arena_size" not in kwargs:
        needed = circle_arena_size(config, num_robots)
        if needed > config.arena_size:
            config = EnvConfig.from_kwargs({**kwargs, "robot": robot, "arena_size": needed})
    return config


class WorldGoals:
    """Each robot's goal, shortest path, straight distance to the goal and distance driven."""

    def __init__(self, settings: NavSettings, config: EnvConfig, num_robots: int) -> None:
        self.settings = settings
        self.config = config
        self.num_robots = num_robots
        self.problems: list[NavProblem] = []
        """Robot ``k``'s start, goal and shortest path (after a reset)."""
        self.distance = np.zeros(num_robots)
        self.driven = np.zeros(num_robots)
        self.touched = np.zeros(num_robots, dtype=bool)
        self.poses: list[Pose] = [(0.0, 0.0, 0.0)] * num_robots

    def draw(
        self, rng: np.random.Generator, layout: ArenaLayout, poses: list[Pose], scenario: str
    ) -> ArenaLayout | None:
        """Goals for robots at ``poses``; the layout to use (circle: clear of the goals).

        None when a robot has no goal (boxed in, or its antipode out of reach): draw another
        world.
        """
        config = self.config
        if scenario == "circle":
            layout = _clear_of(layout, [(-x, -y) for x, y, _ in poses], config)
        grid = clearance_grid(
            layout, config.arena_size, config.robot.radius, self.settings.grid_resolution
        )
        spacing = 2 * config.robot.radius + config.start_clearance
        problems: list[NavProblem] = []
        for x, y, _ in poses:
            if scenario == "circle":
                path = plan_path(grid, (x, y), (-x, -y))
                problem = None if path is None else NavProblem(
                    (x, y), (-x, -y), path, path_length(path), grid
                )  # fmt: skip
            else:
                taken = tuple(p.goal for p in problems)
                problem = draw_goal(
                    rng, grid, (x, y), self.settings.min_goal_distance, taken, spacing
                )
            if problem is None:
                return None
            problems.append(problem)
        self.problems = problems
        return layout

    def set(self, layout: ArenaLayout, poses: list[Pose], goals: Any) -> None:
        """``reset(options={"goals": ...})``: one (x, y) per robot, or one ``ValueError`` line."""
        config = self.config
        if np.shape(goals) != (self.num_robots, 2):
            raise ValueError(
                f"options['goals'] must be {self.num_robots} (x, y) goals, got {goals!r}"
            )
        grid = clearance_grid(
            layout, config.arena_size, config.robot.radius, self.settings.grid_resolution
        )
        self.problems = [
            planned_problem(grid, goal, (x, y), config.robot.radius, config.arena_size)
            for goal, (x, y, _) in zip(goals, poses, strict=True)
        ]

    def start(self, k: int, info: dict[str, Any]) -> dict[str, Any]:
        """Robot ``k``'s episode begins at ``info``'s pose; ``info`` with the goal's fields."""
        self.begin(k, (float(info["x"]), float(info["y"]), float(info["yaw"])))
        return self.task_info(k, info)

    def begin(self, k: int, pose: Pose) -> None:
        """Robot ``k``'s episode begins at ``pose`` (x, y, yaw): nothing driven yet."""
        self.driven[k], self.touched[k] = 0.0, False
        self.distance[k] = self._move(k, pose)

    def redraw(self, k: int, rng: np.random.Generator, start: tuple[float, float]) -> bool:
        """A new goal for robot ``k`` starting again at ``start``: as ``"random"`` draws one.

        On the world's grid, ``min_goal_distance`` from ``start`` and apart from the other
        robots' goals; False (goal unchanged) when none qualifies.
        """
        taken = tuple(p.goal for j, p in enumerate(self.problems) if j != k)
        spacing = 2 * self.config.robot.radius + self.config.start_clearance
        grid = self.problems[k].grid
        problem = draw_goal(rng, grid, start, self.settings.min_goal_distance, taken, spacing)
        if problem is None:
            return False
        self.problems[k] = problem
        return True

    def _move(self, k: int, pose: Pose) -> float:
        self.poses[k] = pose
        goal = self.problems[k].goal
        return math.hypot(goal[0] - pose[0], goal[1] - pose[1])

    def step(
        self, k: int, info: dict[str, Any], truncated: bool
    ) -> tuple[float, bool, dict[str, Any]]:
        """Robot ``k``'s step: its reward, whether it arrived, and ``info`` with the parts."""
        pose = (float(info["x"]), float(info["y"]), float(info["yaw"]))
        parts, arrived = self.advance(
            k, pose, bool(info["collision"]), float(info["reward_collision"]), truncated
        )
        for key in WANDERING_PARTS:
            del info[key]
        info.update(parts)
        info["is_success"] = arrived
        return sum(parts.values()), arrived, self.task_info(k, info)

    def advance(
        self, k: int, pose: Pose, collision: bool, reward_collision: float, truncated: bool
    ) -> tuple[dict[str, float], bool]:
        """Robot ``k`` now at ``pose``: the step's reward parts and whether it arrived."""
        before, (x0, y0, _) = float(self.distance[k]), self.poses[k]
        after = self._move(k, pose)
        self.distance[k] = after
        self.driven[k] += math.hypot(pose[0] - x0, pose[1] - y0)
        self.touched[k] = self.touched[k] or collision
        arrived = self.settings.arrived(after, bool(self.touched[k]), truncated)
        return self.settings.reward_parts(before, after, arrived, reward_collision), arrived

    def task_info(self, k: int, info: dict[str, Any]) -> dict[str, Any]:
        """``info`` with robot ``k``'s goal, straight distance, shortest path and driven."""
        info["goal"] = np.array(self.problems[k].goal)
        info["goal_distance"] = float(self.distance[k])
        info["shortest_path_length"] = self.problems[k].length
        info["distance_driven"] = float(self.driven[k])
        return info

    def reading(self, k: int) -> NDArray[np.float32]:
        """Robot ``k``'s ``goal`` observation: distance and bearing in its frame."""
        return goal_reading(self.poses[k], self.problems[k].goal)


def _clear_of(
    layout: ArenaLayout, points: list[tuple[float, float]], config: EnvConfig
) -> ArenaLayout:
    """``layout`` less the obstacles within a robot radius and the clearance of ``points``."""
    keep_out = config.robot.radius + config.start_clearance
    obstacles = tuple(
        o
        for o in layout.obstacles
        if all(math.hypot(o.x - x, o.y - y) - o.bounding_radius >= keep_out for x, y in points)
    )
    return ArenaLayout(obstacles, layout.start_pose)
