"""The particle filter (issue #27) on recorded episodes: accuracy, convergence and speed.

Usage: ``python bench/localisation.py [--seeds A-B ...] [--odometry-noise S] [--quick] [--json]``

Each seed is one episode of ``BubbleRob-v0`` (``odometry_noise`` 0.1, ``laser_noise_std`` 0.01 m)
driven by the ``laser`` policy, recorded once; the filter then runs over it offline twice: tracking
from the true start pose (particles spread by 0.1 m, 0.1 m, 0.1 rad, as an ``/initialpose``
from rviz) and global localisation (particles uniform over the free space). Per seed range, the
table gives the raw odometry's error at the end (the drift the filter has to undo), the mean
position and yaw errors after convergence (mean and spread over episodes), the share of episodes
whose global localisation converged within 10 s of simulated time, and the filter's speed as
simulated seconds per CPU second (one core: ``process_time`` of the filter alone, threads pinned
to 1). The defaults: seeds 0-19 (the ones the parameters were tuned on) and 7000-7049 (held out,
never looked at while tuning). ``--quick`` runs 2 seeds of each.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core: no BLAS threads in the filter's math
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
from typing import Any  # noqa: E402

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402

import bubblerob_env  # noqa: E402, F401  (registers BubbleRob-v0)
from bubblerob_env.localisation.evaluation import localise, record_episode  # noqa: E402
from policies import load_policy  # noqa: E402

GLOBAL_DEADLINE_S = 10.0


def _seed_range(text: str) -> range:
    try:
        first, _, last = text.partition("-")
        seeds = range(int(first), int(last or first) + 1)
    except ValueError:
        seeds = range(0)
    if len(seeds) == 0 or seeds.start < 0:
        raise argparse.ArgumentTypeError(f"seed range {text!r} is not A-B with 0 <= A <= B")
    return seeds


def measure(seeds: range, odometry_noise: float) -> dict[str, Any]:
    """Record each seed's episode and run the filter over it, tracking and global."""
    env = gym.make("BubbleRob-v0", odometry_noise=odometry_noise, laser_noise_std=0.01)
    policy = load_policy("laser", env)
    drift, track, glob, converge_s, cpu, sim = [], [], [], [], 0.0, 0.0
    for seed in seeds:
        episode = record_episode(env, policy, seed)
        drift.append(episode.odometry_error_final)
        tracking = localise(episode, seed=seed)
        global_ = localise(episode, global_start=True, seed=seed)
        track.append((*tracking.after_convergence(), tracking.lost_fraction))
        step = global_.converged_step
        converged = step is not None and step * episode.dt <= GLOBAL_DEADLINE_S
        converge_s.append(step * episode.dt if step is not None else math.inf)
        glob.append((*global_.after_convergence(), float(converged)))
        cpu += tracking.seconds + global_.seconds
        sim += 2 * (len(episode.truth) - 1) * episode.dt
    t, g = np.array(track), np.array(glob)
    return {
        "seeds": f"{seeds.start}-{seeds.stop - 1}",
        "episodes": len(seeds),
        "odometry_error_final_m": _spread(np.array(drift)),
        "odometry_error_final_min_m": float(np.min(drift)),
        "episodes_odometry_off_by_0_2_m": int(np.sum(np.array(drift) >= 0.2)),
        "tracking_position_error_mean_m": _spread(t[:, 0]),
        "tracking_yaw_error_mean_rad": _spread(t[:, 1]),
        "tracking_lost_fraction": float(np.nanmean(t[:, 2])),
        "global_converged_within_10s": float(g[:, 2].mean()),
        "global_converged_after_s_median": float(np.median(converge_s)),
        "global_position_error_mean_m": _spread(g[:, 0]),
        "global_yaw_error_mean_rad": _spread(g[:, 1]),
        "realtime_factor_one_core": sim / cpu,
    }


def _spread(values: np.ndarray) -> dict[str, float]:
    """Mean, standard deviation and maximum over episodes (episodes that never converged: NaN)."""
    return {
        "mean": float(np.nanmean(values)),
        "std": float(np.nanstd(values)),
        "max": float(np.nanmax(values)),
    }


def _print_table(rows: list[dict[str, Any]]) -> None:
    def ms(d: dict[str, float], scale: float = 1.0) -> str:
        return f"{d['mean'] * scale:.1f} ± {d['std'] * scale:.1f} (max {d['max'] * scale:.1f})"

    print(
        "| seeds | episodes | odometry error at end (m) | tracking position (cm) | tracking yaw "
        "(mrad) | global within 10 s | global median (s) | global position (cm) | "
        "sim s per CPU s |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        drift = r["odometry_error_final_m"]
        print(
            f"| {r['seeds']} | {r['episodes']} | {drift['mean']:.2f} ± {drift['std']:.2f} "
            f"(min {r['odometry_error_final_min_m']:.2f}; "
            f"{r['episodes_odometry_off_by_0_2_m']} off by >= 0.2) | "
            f"{ms(r['tracking_position_error_mean_m'], 100)} | "
            f"{ms(r['tracking_yaw_error_mean_rad'], 1000)} | "
            f"{r['global_converged_within_10s']:.0%} | "
            f"{r['global_converged_after_s_median']:.2f} | "
            f"{ms(r['global_position_error_mean_m'], 100)} | "
            f"{r['realtime_factor_one_core']:.0f} |"
        )


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark; print a Markdown table, or one JSON list with ``--json``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=_seed_range, nargs="+", default=None)
    parser.add_argument("--odometry-noise", type=float, default=0.1)
    parser.add_argument("--quick", action="store_true", help="2 seeds of each range")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    ranges = args.seeds or [range(0, 20), range(7000, 7050)]
    if args.quick:
        ranges = [r[:2] for r in ranges]
    if not 0.0 <= args.odometry_noise <= 1.0:
        parser.error(f"--odometry-noise {args.odometry_noise} is not from 0 to 1")
    rows = [measure(seeds, args.odometry_noise) for seeds in ranges]
    if args.json:
        json.dump(rows, sys.stdout, indent=1)
        print()
    else:
        print(f"odometry_noise {args.odometry_noise}, laser_noise_std 0.01 m, laser policy")
        _print_table(rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
