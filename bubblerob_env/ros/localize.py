"""The particle filter over a recorded bag, scored against the truth (``bubblerob localize BAG``).

Each episode of the bag (:mod:`~bubblerob_env.ros.localize_bag`) is localised as ``amcl`` would
localise it live: tracking from the episode's start pose (where ``odom`` coincides with ``map``,
as the bag's identity ``map -> odom`` on ``/tf_static`` says, and as an ``/initialpose`` from
rviz would give it), or, with ``--global``, from particles spread over the map's free space.
The errors are measured against ``/base_pose_ground_truth`` after convergence
(:mod:`~bubblerob_env.localisation.evaluation`: within 0.1 m and 0.1 rad for 1 s). The PNG shows
each episode's map with the true path (green), the raw odometry (red) and the estimate (blue).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from bubblerob_env.localisation.evaluation import RecordedEpisode, TrackResult, localise
from bubblerob_env.localisation.picture import (
    ESTIMATE,
    ODOMETRY,
    TRUTH,
    draw_paths,
    side_by_side,
)
from bubblerob_env.ros.localize_bag import BagEpisodes

__all__ = [
    "GLOBAL_DEADLINE_S",
    "default_png",
    "localize_bag",
    "localize_problem",
    "picture",
    "report",
]

GLOBAL_DEADLINE_S = 10.0
"""Issue #27's deadline for global localisation to converge (simulated seconds)."""


def localize_problem(env: Any, resolution: float) -> str:
    """Why the particle filter cannot run on ``env``'s maps at ``resolution`` (``""``: it can).

    Every episode's map must keep a free cell for the particles (global localisation draws them
    there): the cell holding the start pose is free of walls and obstacles on every layout
    whenever its diagonal fits inside the start's clearance (the robot's radius plus
    ``start_clearance``: no wall or obstacle comes nearer); a coarser map may have none.
    """
    base = env.unwrapped
    clear = float(base.robot.radius) + float(base.config.start_clearance)
    largest = clear / math.sqrt(2.0)
    if resolution > largest:
        return (
            f"--map-resolution {resolution:g} m is too coarse for the particle filter: a map "
            f"may have no free cell; use at most {math.floor(largest * 1000) / 1000:g} m here "
            f"(a cell whose diagonal fits the start's clearance of {clear:.3f} m)"
        )
    return ""


def default_png(bag: str | Path) -> Path:
    """Where the picture goes by default: beside the bag, ``<bag>.localize.png``.

    A storage file named inside a ROS 2 bag folder counts as its folder: nothing is written into
    a bag.
    """
    path = Path(bag)
    if path.is_file() and (path.parent / "metadata.yaml").is_file():
        path = path.parent
    return path.with_name(path.name.rstrip("/") + ".localize.png")


def localize_bag(bag: BagEpisodes, global_start: bool = False, seed: int = 0) -> list[TrackResult]:
    """The filter over each episode of ``bag`` (seeded ``seed + episode``)."""
    results = []
    for k, episode in enumerate(bag.episodes):
        x, y, yaw = (float(v) for v in episode.odometry[0])
        results.append(
            localise(episode, global_start=global_start, seed=seed + k, start=(x, y, yaw))
        )
    return results


def _converged_s(episode: RecordedEpisode, result: TrackResult) -> float | None:
    step = result.converged_step
    return None if step is None else step * episode.dt


def _finite_mean(values: list[float]) -> float | None:
    finite = [v for v in values if math.isfinite(v)]
    return float(np.mean(finite)) if finite else None


def _finite(value: float) -> float | None:
    return value if math.isfinite(value) else None


def _episode_report(k: int, episode: RecordedEpisode, result: TrackResult) -> dict[str, Any]:
    position, yaw = result.after_convergence()
    return {
        "episode": k,
        "seed": episode.seed,
        "seconds": (len(episode.truth) - 1) * episode.dt,
        "converged_after_s": _converged_s(episode, result),
        "position_error_mean_m": _finite(position),
        "yaw_error_mean_rad": _finite(yaw),
        "lost_fraction": _finite(result.lost_fraction),
        "odometry_error_final_m": episode.odometry_error_final,
    }


def report(bag: BagEpisodes, results: list[TrackResult], global_start: bool) -> dict[str, Any]:
    """The JSON object ``--json`` prints: means over episodes, then each episode.

    The errors are means over the episodes that converged; ``converged_after_s`` too.
    """
    pairs = list(zip(bag.episodes, results, strict=True))
    converged = [s for s in (_converged_s(e, r) for e, r in pairs) if s is not None]
    simulated = sum((len(e.truth) - 1) * e.dt for e in bag.episodes)
    cpu = sum(r.seconds for r in results)
    return {
        "mode": "global" if global_start else "tracking",
        "truth": bag.truth_topic,
        "episodes": len(pairs),
        "converged_episodes": len(converged),
        "converged_within_10s": sum(s <= GLOBAL_DEADLINE_S for s in converged) / len(pairs),
        "converged_after_s": _finite_mean(converged),
        "position_error_mean_m": _finite_mean([r.after_convergence()[0] for r in results]),
        "yaw_error_mean_rad": _finite_mean([r.after_convergence()[1] for r in results]),
        "odometry_error_final_m": float(np.mean([e.odometry_error_final for e in bag.episodes])),
        "realtime_factor": simulated / cpu if cpu > 0 else None,
        "per_episode": [_episode_report(k, e, r) for k, (e, r) in enumerate(pairs)],
    }


def picture(bag: BagEpisodes, results: list[TrackResult]) -> Any:
    """Each episode's map with truth, odometry and estimate, four episodes a row."""
    panels = []
    for episode, result in zip(bag.episodes, results, strict=True):
        scale = max(1, round(0.0125 / episode.grid.resolution * 16))  # ~320 px for a 4.2 m map
        paths = [
            (episode.truth, TRUTH, 5),  # under the estimate, which it shows around
            (episode.odometry, ODOMETRY, 2),
            (result.estimates, ESTIMATE, 2),
        ]
        panels.append(draw_paths(episode.grid, paths, scale=scale))
    return side_by_side(panels)
