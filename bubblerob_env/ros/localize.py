"""``bubblerob localize BAG``: the particle filter over a recorded bag, scored against the truth.

Each episode of the bag (:mod:`~bubblerob_env.ros.localize_bag`) is localised as ``amcl`` would
localise it live: tracking from the episode's start pose (where ``odom`` coincides with ``map``,
as the bag's identity ``map -> odom`` on ``/tf_static`` says, and as an ``/initialpose`` from
rviz would give it), or, with ``--global``, from particles spread over the map's free space.
The errors are measured against ``/base_pose_ground_truth`` after convergence
(:mod:`~bubblerob_env.localisation.evaluation`: within 0.1 m and 0.1 rad for 1 s). The PNG shows
each episode's map with the true path (green), the raw odometry (red) and the estimate (blue).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
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
from bubblerob_env.png import write_png
from bubblerob_env.ros.localize_bag import BagEpisodes, LocalizeBagError, read_bag_episodes

__all__ = ["GLOBAL_DEADLINE_S", "add_subcommands", "default_png", "localize_bag", "report"]

GLOBAL_DEADLINE_S = 10.0
"""Issue #27's deadline for global localisation to converge (simulated seconds)."""


def default_png(bag: str | Path) -> Path:
    """Where the picture goes by default: beside the bag, ``<bag>.localize.png``."""
    path = Path(bag)
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


def _text(summary: dict[str, Any]) -> str:
    def metres(v: float | None, unit: str, scale: float) -> str:
        return "-" if v is None else f"{v * scale:.1f} {unit}"

    lines = [f"{summary['episodes']} episode(s), {summary['mode']}; truth: {summary['truth']}"]
    lines.append("episode  seed  converged after  position error  yaw error  odometry off at end")
    for e in summary["per_episode"]:
        after = e["converged_after_s"]
        lines.append(
            f"{e['episode']:>7}  {e['seed']:>4}  "
            f"{'never' if after is None else f'{after:.2f} s':>15}  "
            f"{metres(e['position_error_mean_m'], 'cm', 100):>14}  "
            f"{metres(e['yaw_error_mean_rad'], 'mrad', 1000):>9}  "
            f"{e['odometry_error_final_m']:.2f} m"
        )
    lines.append(
        f"mean: position {metres(summary['position_error_mean_m'], 'cm', 100)}, yaw "
        f"{metres(summary['yaw_error_mean_rad'], 'mrad', 1000)} after convergence; converged "
        f"within 10 s in {summary['converged_within_10s']:.0%}; raw odometry off by "
        f"{summary['odometry_error_final_m']:.2f} m at the end"
    )
    return "\n".join(lines)


def _check_out(args: argparse.Namespace) -> Path:
    out = Path(args.out) if args.out is not None else default_png(args.bag)
    if out.is_dir():
        raise LocalizeBagError(f"--out {out} is a directory: name the PNG file to write")
    if out.suffix.lower() != ".png":
        raise LocalizeBagError(f"--out {out}: the picture is a PNG, name a .png file")
    return out


def _run(args: argparse.Namespace) -> int:
    try:
        if not 0 <= args.seed <= 2**63 - 1:
            raise LocalizeBagError(f"--seed must be an int from 0 to {2**63 - 1}, got {args.seed}")
        out = _check_out(args)
        bag = read_bag_episodes(args.bag)
    except (OSError, LocalizeBagError) as error:
        print(f"bubblerob localize: {error}", file=sys.stderr)
        return 2
    results = localize_bag(bag, args.global_start, args.seed)
    summary = report(bag, results, args.global_start)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        write_png(out, picture(bag, results))
    except OSError as error:
        print(f"bubblerob localize: cannot write --out {out}: {error.strerror}", file=sys.stderr)
        return 1
    summary["png"] = str(out)
    if args.json:
        print(json.dumps(summary))
    else:
        print(_text(summary))
        print(f"wrote {out} (green: truth, red: odometry, blue: estimate)")
    return 0


def add_subcommands(subparsers: Any) -> None:
    """Add ``localize`` to the ``bubblerob`` command."""
    parser = subparsers.add_parser(
        "localize",
        help="run the particle filter (AMCL-like) over a bag and score it against the truth",
        description="Localise the robot of every episode of a bag on its /map with the particle "
        "filter, from /scan, odom -> base_link on /tf (or /odom) and /tf_static, and compare "
        "with /base_pose_ground_truth (record with --env-kwargs '{\"odometry_noise\": 0.1}' "
        "for odometry that drifts). Prints the errors after convergence and writes a PNG of "
        "the true path (green), the odometry (red) and the estimate (blue) on the map.",
    )
    parser.add_argument("bag", help="a .bag, .mcap or .db3 file, or a ROS 2 bag folder")
    parser.add_argument(
        "--global",
        dest="global_start",
        action="store_true",
        help="global localisation: particles over all the free space instead of at the start",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument(
        "--out", default=None, help="PNG to write (default: beside the bag, BAG.localize.png)"
    )
    parser.add_argument("--seed", type=int, default=0, help="the filter's seed (episode k: +k)")
    parser.set_defaults(handler=_run)
