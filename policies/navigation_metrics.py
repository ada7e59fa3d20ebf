"""Navigation metrics of a Nav env's episodes (``BubbleRobNav-v0``), as the literature reports them.

- success, collision and timeout rates, each with its Wilson 95% interval;
- SPL (Anderson et al. 2018, "On Evaluation of Embodied Navigation Agents"): the mean over
  episodes of ``success * shortest / max(driven, shortest)``;
- extra time and extra distance (Long et al. 2018), normalised by the ideal: over the successful
  episodes, the mean of ``(time - shortest / v_max) / (shortest / v_max)`` and of
  ``(driven - shortest) / shortest``;
- mean speed (m/s) of the successful episodes: driven distance over time.

Each episode's record (``evaluate --per-episode``) carries what they need: its ``outcome``,
``goal``, ``goal_radius``, ``shortest`` and ``driven`` (m), ``time`` (s), ``v_max`` (m/s) and
``spl``. ``shortest`` is the shortest path to the goal's disc: the env's
``info["shortest_path_length"]`` (to the goal itself) less ``goal_radius``, the least a robot
drives to succeed; so a robot that drives the shortest path scores SPL 1 and no extra distance.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from policies.protocol import wilson_interval

__all__ = ["OUTCOMES", "NavMetrics", "episode_record", "format_nav_table", "nav_metrics", "spl"]

OUTCOMES = ("success", "collision", "timeout")
"""How a Nav episode ends: the goal reached, a touch, or the time limit (or a divergence)."""


def spl(success: bool, shortest: float, driven: float) -> float:
    """One episode's success weighted by path length: ``S * l / max(p, l)``."""
    if not success:
        return 0.0
    return shortest / max(driven, shortest) if shortest > 0 else 1.0


def episode_record(
    info: dict[str, Any], steps: int, dt: float, v_max: float, goal_radius: float
) -> dict[str, Any]:
    """The navigation fields of an episode whose last step's ``info`` is ``info``."""
    if info.get("is_success"):
        outcome = "success"
    elif info.get("collision"):
        outcome = "collision"
    else:
        outcome = "timeout"
    shortest = float(info["shortest_path_length"]) - goal_radius
    driven = float(info["distance_driven"])
    return {
        "outcome": outcome,
        "goal": [float(v) for v in info["goal"]],
        "goal_radius": goal_radius,
        "shortest": shortest,
        "driven": driven,
        "time": steps * dt,
        "v_max": v_max,
        "spl": spl(outcome == "success", shortest, driven),
    }


@dataclass(frozen=True)
class NavMetrics:
    """The navigation metrics of ``episodes`` episodes (see the module's docstring)."""

    episodes: int
    counts: dict[str, int]
    """Episodes per outcome (:data:`OUTCOMES`)."""
    spl: float
    extra_time: float
    """NaN when no episode succeeded (as ``extra_distance`` and ``mean_speed``)."""
    extra_distance: float
    mean_speed: float

    def rate(self, outcome: str) -> float:
        """The fraction of episodes that ended in ``outcome``."""
        return self.counts[outcome] / self.episodes

    def interval(self, outcome: str) -> tuple[float, float]:
        """The Wilson 95% interval of ``outcome``'s rate."""
        return wilson_interval(self.counts[outcome], self.episodes)


def nav_metrics(records: Sequence[dict[str, Any]]) -> NavMetrics | None:
    """The metrics of per-episode records; None unless every record is a Nav episode's."""
    if not records or not all("shortest" in r for r in records):
        return None
    counts = {outcome: sum(r["outcome"] == outcome for r in records) for outcome in OUTCOMES}
    won = [r for r in records if r["outcome"] == "success"]
    nan = math.nan
    ideal = [r["shortest"] / r["v_max"] for r in won]
    return NavMetrics(
        episodes=len(records),
        counts=counts,
        spl=float(np.mean([r["spl"] for r in records])),
        extra_time=float(np.mean([(r["time"] - t) / t for r, t in zip(won, ideal, strict=True)]))
        if won
        else nan,
        extra_distance=float(np.mean([(r["driven"] - r["shortest"]) / r["shortest"] for r in won]))
        if won
        else nan,
        mean_speed=float(np.mean([r["driven"] / r["time"] for r in won])) if won else nan,
    )


def _share(metrics: NavMetrics, outcome: str) -> str:
    low, high = metrics.interval(outcome)
    return f"{metrics.rate(outcome):.1%} ({low:.1%}-{high:.1%})"


def _number(value: float, form: str) -> str:
    return "-" if math.isnan(value) else format(value, form)


def format_nav_table(rows: Sequence[tuple[str, NavMetrics]], markdown: bool = False) -> str:
    """One table, a row per policy: outcomes with their Wilson 95% intervals, SPL and the rest."""
    header = [
        "policy", "episodes", "success (95% CI)", "collision (95% CI)", "timeout (95% CI)",
        "SPL", "extra time", "extra distance", "speed m/s",
    ]  # fmt: skip
    table = [
        [
            name,
            str(m.episodes),
            *(_share(m, outcome) for outcome in OUTCOMES),
            f"{m.spl:.3f}",
            _number(m.extra_time, ".1%"),
            _number(m.extra_distance, ".1%"),
            _number(m.mean_speed, ".2f"),
        ]
        for name, m in rows
    ]
    if markdown:
        lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
        return "\n".join(lines + ["| " + " | ".join(row) + " |" for row in table])
    widths = [max(len(row[i]) for row in [header, *table]) for i in range(len(header))]
    return "\n".join(
        "  ".join(cell.ljust(width) for cell, width in zip(row, widths, strict=True)).rstrip()
        for row in [header, *table]
    )
