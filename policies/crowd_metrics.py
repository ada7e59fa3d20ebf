"""Crowd-navigation metrics of robot-episodes, as Long et al. (ICRA 2018) report circle crossings.

Per robot-episode of ``parallel_env(task="nav")`` (:func:`policies.multi_evaluation.
run_world_episode`): success (its goal reached, nothing touched), robot-robot and obstacle (or
wall) collisions, each with its Wilson 95% interval; over the successful robot-episodes, the
extra time ``time - shortest / v_max`` (s) and extra distance ``driven - shortest`` (m), raw as
Long et al. give them and normalised by the straight-line values (``shortest / v_max`` and
``shortest``), and the mean speed ``driven / time`` (m/s). ``shortest`` is the shortest path to
the goal's disc (:mod:`policies.navigation_metrics`): on an obstacle-free circle, the straight
line ``2R`` less ``goal_radius``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from policies.protocol import wilson_interval

__all__ = ["CROWD_OUTCOMES", "CrowdMetrics", "crowd_metrics", "format_crowd_table"]

CROWD_OUTCOMES = ("success", "robot", "obstacle", "timeout")
"""How a robot-episode ends: its goal, another robot, a wall or obstacle, or the time limit."""


def outcome_of(record: dict[str, Any]) -> str:
    """A robot-episode record's outcome (:data:`CROWD_OUTCOMES`)."""
    if record["succeeded"]:
        return "success"
    touched = record["collided_with"]
    if touched == "obstacle":
        return "obstacle"
    return "robot" if touched else "timeout"


@dataclass(frozen=True)
class CrowdMetrics:
    """The metrics of ``episodes`` robot-episodes (see the module's docstring)."""

    episodes: int
    counts: dict[str, int]
    extra_time: float
    """Seconds, mean over the successes; NaN without one (as every mean below)."""
    extra_time_ratio: float
    extra_distance: float
    """Metres."""
    extra_distance_ratio: float
    mean_speed: float
    """m/s."""
    straight_time: float
    """Mean ``shortest / v_max`` (s) over every robot-episode: the ideal."""

    def rate(self, outcome: str) -> tuple[float, float, float]:
        """``outcome``'s rate and its Wilson 95% interval, as fractions."""
        hits = self.counts[outcome]
        return (hits / self.episodes, *wilson_interval(hits, self.episodes))


def crowd_metrics(records: Sequence[dict[str, Any]]) -> CrowdMetrics:
    """The metrics of Nav robot-episode records (each with ``shortest``, ``driven``, ``time``)."""
    if not records:
        raise ValueError("crowd_metrics needs at least one robot-episode")
    counts = {outcome: 0 for outcome in CROWD_OUTCOMES}
    for record in records:
        counts[outcome_of(record)] += 1
    won = [r for r in records if r["succeeded"]]
    ideal = np.array([r["shortest"] / r["v_max"] for r in won])
    time = np.array([r["time"] for r in won])
    shortest = np.array([r["shortest"] for r in won])
    driven = np.array([r["driven"] for r in won])

    def mean(values: Any) -> float:
        return float(np.mean(values)) if won else math.nan

    return CrowdMetrics(
        episodes=len(records),
        counts=counts,
        extra_time=mean(time - ideal),
        extra_time_ratio=mean((time - ideal) / ideal),
        extra_distance=mean(driven - shortest),
        extra_distance_ratio=mean((driven - shortest) / shortest),
        mean_speed=mean(driven / time),
        straight_time=float(np.mean([r["shortest"] / r["v_max"] for r in records])),
    )


def _number(value: float, form: str) -> str:
    return "-" if math.isnan(value) else format(value, form)


def format_crowd_table(
    rows: Sequence[tuple[str, int, str, CrowdMetrics]], markdown: bool = False
) -> str:
    """A row per (policy, robots, scenario, metrics): rates with Wilson 95% intervals, the rest."""
    header = [
        "policy", "robots", "scenario", "robot-episodes", "success (95% CI)", "robot hit",
        "obstacle hit", "straight s", "extra time s (x)", "extra dist m (x)", "speed m/s",
    ]  # fmt: skip

    def share(m: CrowdMetrics, outcome: str) -> str:
        rate, low, high = m.rate(outcome)
        return f"{rate:.1%} ({low:.1%}-{high:.1%})"

    table = [
        [
            policy, str(robots), scenario, str(m.episodes), share(m, "success"),
            share(m, "robot"), share(m, "obstacle"), f"{m.straight_time:.1f}",
            f"{_number(m.extra_time, '.2f')} ({_number(m.extra_time_ratio, '.1%')})",
            f"{_number(m.extra_distance, '.2f')} ({_number(m.extra_distance_ratio, '.1%')})",
            _number(m.mean_speed, ".2f"),
        ]
        for policy, robots, scenario, m in rows
    ]  # fmt: skip
    if markdown:
        lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
        return "\n".join(lines + ["| " + " | ".join(row) + " |" for row in table])
    widths = [max(len(row[i]) for row in [header, *table]) for i in range(len(header))]
    return "\n".join(
        "  ".join(cell.ljust(width) for cell, width in zip(row, widths, strict=True)).rstrip()
        for row in [header, *table]
    )
