"""Seeded start poses for the robots of a world and the obstacles around them.

Every robot starts ``start_clearance`` m (and one robot radius) clear of the walls, of every
obstacle and of every other robot's bounding circle, so no start touches anything.
``scenario="random"`` draws the poses uniformly (robot 0's exactly as the single env draws its
start, so one robot gives the single env's episodes), ``"circle"`` puts the robots evenly on the
largest circle that keeps that clearance from the walls, each facing the centre: one world for
every seed. With ``circle_jitter`` (m) a seed turns the whole circle by a uniform angle and moves
each robot along it by up to that arc, as crowd-navigation benchmarks perturb their circle
crossings (CrowdNav's circle crossing jitters positions; Long et al. evaluate one fixed circle).
The obstacles are the single env's layout around robot 0, less any that would crowd another
robot.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from bubblerob_env.arena import ArenaLayout, Obstacle, colour_obstacles, sample_layout
from bubblerob_env.config import EnvConfig

__all__ = ["SCENARIOS", "check_circle_jitter", "check_fits", "free_pose", "sample_world"]

SCENARIOS = ("random", "circle")
"""Where a reset puts the robots: uniformly at free poses, or on a circle facing its centre."""
_MAX_TRIES = 200

Pose = tuple[float, float, float]


def _keep_out(config: EnvConfig) -> float:
    return config.robot.radius + config.start_clearance


def _spacing(config: EnvConfig) -> float:
    """Centre distance two robots keep at the start: both radii and the clearance."""
    return 2 * config.robot.radius + config.start_clearance


def _grid(config: EnvConfig) -> list[tuple[float, float]]:
    """Free start positions on a square grid: the fallback that always holds the robots."""
    limit = config.arena_size / 2 - _keep_out(config)
    if limit < 0:
        return []
    per_side = int(math.floor(2 * limit / _spacing(config) + 1e-9)) + 1
    step = 2 * limit / (per_side - 1) if per_side > 1 else 0.0
    return [
        (-limit + a * step, -limit + b * step) for a in range(per_side) for b in range(per_side)
    ]


def check_fits(config: EnvConfig, num_robots: int, scenario: str) -> None:
    """One ``ValueError`` line if ``num_robots`` cannot all start free in ``scenario``."""
    if scenario not in SCENARIOS:
        raise ValueError(f"scenario must be one of {list(SCENARIOS)}, got {scenario!r}")
    if num_robots > 1 and config.start_pose is not None:
        raise ValueError(
            f"start_pose places one robot; with num_robots={num_robots} leave it None "
            "(scenario='random' or 'circle' places them)"
        )
    where = (
        f"a {config.arena_size} m arena with start_clearance {config.start_clearance} m "
        f"(robot radius {config.robot.radius} m)"
    )
    if scenario == "random":
        room = len(_grid(config))
        if num_robots > room:
            raise ValueError(
                f"num_robots={num_robots} do not fit in {where}: at most {room}; use a larger "
                "arena_size or a smaller start_clearance"
            )
        return
    radius = config.arena_size / 2 - _keep_out(config)
    chord = 2 * radius * math.sin(math.pi / num_robots) if num_robots > 1 else math.inf
    if radius <= 0 or chord < _spacing(config):
        room = _circle_room(radius, _spacing(config))
        raise ValueError(
            f"num_robots={num_robots} do not fit on the circle of {where}: at most {room}; "
            "use a larger arena_size or a smaller start_clearance"
        )


def _circle_room(radius: float, spacing: float) -> int:
    if radius <= 0:
        return 0
    if spacing >= 2 * radius:
        return 1 if spacing > 2 * radius else 2
    return int(math.floor(math.pi / math.asin(spacing / (2 * radius)) + 1e-9))


def _random_poses(rng: np.random.Generator, config: EnvConfig, num_robots: int) -> list[Pose]:
    limit = config.arena_size / 2 - _keep_out(config)
    spacing = _spacing(config)
    poses: list[Pose] = []
    for _ in range(num_robots):
        for _ in range(_MAX_TRIES):
            # The single env's draw (arena.sample_layout): x and y, then the yaw.
            x, y = (float(v) for v in rng.uniform(-limit, limit, size=2))
            pose = (x, y, float(rng.uniform(-math.pi, math.pi)))
            if all(math.hypot(x - px, y - py) >= spacing for px, py, _ in poses):
                poses.append(pose)
                break
        else:
            return _grid_poses(rng, config, num_robots)
    return poses


def _grid_poses(rng: np.random.Generator, config: EnvConfig, num_robots: int) -> list[Pose]:
    """A crowded arena: ``num_robots`` grid cells drawn at random, random headings."""
    cells = _grid(config)
    picks = rng.permutation(len(cells))[:num_robots]
    yaws = rng.uniform(-math.pi, math.pi, size=num_robots)
    return [(*cells[int(p)], float(yaw)) for p, yaw in zip(picks, yaws, strict=True)]


def check_circle_jitter(config: EnvConfig, num_robots: int, scenario: str, jitter: Any) -> float:
    """``circle_jitter`` in metres of arc, or one ``ValueError`` line.

    At most what keeps two neighbours moved towards each other ``2r + start_clearance`` apart.
    """
    if isinstance(jitter, bool) or not isinstance(jitter, (int, float)) or not jitter >= 0:
        raise ValueError(f"circle_jitter must be a number of metres >= 0, got {jitter!r}")
    if jitter and scenario != "circle":
        raise ValueError(f"circle_jitter moves the robots of scenario='circle', not {scenario!r}")
    radius = config.arena_size / 2 - _keep_out(config)
    if jitter and num_robots > 1:
        half_gap = math.pi / num_robots - math.asin(min(1.0, _spacing(config) / (2 * radius)))
        most = max(0.0, half_gap * radius)
        if jitter > most:
            raise ValueError(
                f"circle_jitter {jitter!r} m would bring {num_robots} robots on a circle of "
                f"radius {radius:.2f} m closer than {_spacing(config):.2f} m: at most {most:.3f}"
            )
    return float(jitter)


def _circle_poses(
    config: EnvConfig, num_robots: int, rng: np.random.Generator, jitter: float
) -> list[Pose]:
    radius = config.arena_size / 2 - _keep_out(config)
    turn, shifts = 0.0, np.zeros(num_robots)
    if jitter > 0:  # drawn only then: a jitter-free circle draws nothing, as before
        turn = float(rng.uniform(0.0, 2 * math.pi))
        shifts = rng.uniform(-jitter, jitter, size=num_robots) / radius
    poses = []
    for k in range(num_robots):
        angle = turn + 2 * math.pi * k / num_robots + float(shifts[k])
        facing = math.atan2(-math.sin(angle), -math.cos(angle))
        poses.append((radius * math.cos(angle), radius * math.sin(angle), facing))
    return poses


def sample_world(
    rng: np.random.Generator,
    config: EnvConfig,
    num_robots: int,
    scenario: str,
    circle_jitter: float = 0.0,
) -> tuple[ArenaLayout, list[Pose]]:
    """The obstacles (robot 0's start in the layout) and every robot's start pose."""
    if scenario == "circle":
        poses = _circle_poses(config, num_robots, rng, circle_jitter)
    else:
        poses = _random_poses(rng, config, num_robots)
    layout = sample_layout(
        rng,
        config.arena_size,
        config.num_obstacles,
        config.obstacle_size,
        config.start_clearance,
        poses[0],
        config.robot.radius,
    )
    keep_out = _keep_out(config)
    obstacles = tuple(
        obstacle
        for obstacle in layout.obstacles
        if all(
            math.hypot(obstacle.x - x, obstacle.y - y) - obstacle.bounding_radius >= keep_out
            for x, y, _ in poses[1:]
        )
    )
    layout = ArenaLayout(obstacles, poses[0])
    if config.obstacle_colours:
        layout = colour_obstacles(rng, layout)
    return layout, poses


def free_pose(
    rng: np.random.Generator,
    config: EnvConfig,
    obstacles: tuple[Obstacle, ...],
    others: list[tuple[float, float]],
) -> Pose:
    """A start pose clear of the walls, ``obstacles`` and the robots at ``others`` (x, y).

    Where none is found in a bounded number of draws, the drawn pose farthest from everything.
    """
    limit = config.arena_size / 2 - _keep_out(config)
    keep_out, spacing = _keep_out(config), _spacing(config)
    best, best_margin = (0.0, 0.0, 0.0), -math.inf
    for _ in range(_MAX_TRIES):
        x, y = (float(v) for v in rng.uniform(-limit, limit, size=2))
        pose = (x, y, float(rng.uniform(-math.pi, math.pi)))
        margin = min(
            [math.hypot(o.x - x, o.y - y) - o.bounding_radius - keep_out for o in obstacles]
            + [math.hypot(ox - x, oy - y) - spacing for ox, oy in others]
            + [math.inf]
        )
        if margin >= 0:
            return pose
        if margin > best_margin:
            best, best_margin = pose, margin
    return best
