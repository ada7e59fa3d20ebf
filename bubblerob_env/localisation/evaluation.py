"""Recorded episodes (truth, odometry, scans, map) and the filter run over them, with its errors.

An episode is recorded once (any policy with SB3's ``predict``) and the filter runs over it
offline, as ``amcl`` over a bag: the filter sees only the odometry, the scans and the map; the
truth is kept to score it. The filter converges at the first step from which its estimate stays
within ``CONVERGED_POSITION`` m and ``CONVERGED_YAW`` rad of the truth for ``SETTLE_S`` seconds
(or to the episode's end). The errors after convergence are the means over every later step,
lapses included, and :attr:`TrackResult.lost_fraction` is the share of those steps outside the
bounds.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from bubblerob_env.localisation.field import LikelihoodField
from bubblerob_env.localisation.filter import FilterConfig, ParticleFilter
from bubblerob_env.localisation.laser_model import ScanGeometry
from bubblerob_env.localisation.motion import angle_difference
from bubblerob_env.mapping import Grid, episode_grid

__all__ = [
    "CONVERGED_POSITION",
    "CONVERGED_YAW",
    "RecordedEpisode",
    "TrackResult",
    "localise",
    "record_episode",
    "scan_geometry",
]

CONVERGED_POSITION = 0.1
"""Metres within which an estimate counts as converged."""
CONVERGED_YAW = 0.1
"""Radians within which an estimate counts as converged."""
SETTLE_S = 1.0
"""Seconds of simulated time an estimate stays within the bounds to count as converged."""


@dataclass(frozen=True)
class RecordedEpisode:
    """One episode, a row per control step (the reset's first): poses are (x, y, yaw)."""

    seed: int
    dt: float
    truth: NDArray[np.float64]
    odometry: NDArray[np.float64]
    scans: NDArray[np.float32]
    grid: Grid
    geometry: ScanGeometry

    @property
    def odometry_error_final(self) -> float:
        """Raw odometry's distance from the truth at the episode's end (m)."""
        return float(np.hypot(*(self.odometry[-1, :2] - self.truth[-1, :2])))


@dataclass(frozen=True)
class TrackResult:
    """The filter over one episode: estimates, errors per step, convergence, time taken."""

    estimates: NDArray[np.float64]
    position_error: NDArray[np.float64]
    yaw_error: NDArray[np.float64]
    converged_step: int | None
    seconds: float

    @property
    def lost_fraction(self) -> float:
        """Share of the steps after convergence with the estimate out of bounds; NaN if none."""
        if self.converged_step is None:
            return math.nan
        start = self.converged_step
        off = (self.position_error[start:] > CONVERGED_POSITION) | (
            self.yaw_error[start:] > CONVERGED_YAW
        )
        return float(off.mean())

    def after_convergence(self) -> tuple[float, float]:
        """Mean position (m) and yaw (rad) errors from convergence on; NaN if it never did."""
        if self.converged_step is None:
            return math.nan, math.nan
        start = self.converged_step
        return float(self.position_error[start:].mean()), float(self.yaw_error[start:].mean())


def scan_geometry(env: gym.Env[Any, Any]) -> ScanGeometry:
    """The laser's beam angles, ranges and pose on ``base_link`` of ``env``."""
    base: Any = env.unwrapped
    spec = base.laser_spec
    if spec is None:
        raise ValueError("localisation needs the laser: make the env with laser_num_rays > 0")
    laser = next(t for t in base.static_transforms if t.child == spec.frame_id)
    qx, qy, qz, qw = laser.rotation_xyzw
    yaw = math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
    pose = (laser.translation[0], laser.translation[1], yaw)
    return ScanGeometry(spec.angles(), spec.range_min, spec.range_max, pose)


def record_episode(
    env: gym.Env[Any, Any], policy: Any, seed: int, max_steps: int | None = None
) -> RecordedEpisode:
    """Run ``policy`` in ``env`` from ``reset(seed=seed)`` to the episode's end or ``max_steps``."""
    obs, info = env.reset(seed=seed)
    grid = episode_grid(env, resolution=0.02)
    truth, odometry, scans = [], [], []
    steps = 0
    while True:
        truth.append((info["x"], info["y"], info["yaw"]))
        odometry.append((info["odom_x"], info["odom_y"], info["odom_yaw"]))
        scans.append(obs["laser"])
        if max_steps is not None and steps >= max_steps:
            break
        action, _ = policy.predict(obs, deterministic=True)
        obs, _, terminated, truncated, info = env.step(action)
        steps += 1
        if terminated or truncated:
            truth.append((info["x"], info["y"], info["yaw"]))
            odometry.append((info["odom_x"], info["odom_y"], info["odom_yaw"]))
            scans.append(obs["laser"])
            break
    return RecordedEpisode(
        seed,
        float(env.unwrapped.dt),  # type: ignore[attr-defined]
        np.array(truth),
        np.array(odometry),
        np.array(scans, dtype=np.float32),
        grid,
        scan_geometry(env),
    )


def localise(
    episode: RecordedEpisode,
    global_start: bool = False,
    config: FilterConfig | None = None,
    seed: int = 0,
    start_std: tuple[float, float, float] = (0.1, 0.1, 0.1),
    start: tuple[float, float, float] | None = None,
) -> TrackResult:
    """Run the filter over ``episode``: from a start pose (``start_std``) or globally.

    ``start``: the pose tracking starts from (an ``/initialpose``); default the true start pose.
    """
    started = time.process_time()
    pf = ParticleFilter(LikelihoodField(episode.grid), episode.geometry, config, seed)
    if global_start:
        pf.start_global()
    else:
        x, y, yaw = episode.truth[0] if start is None else start
        pf.start_at((float(x), float(y), float(yaw)), start_std)
    estimates = np.empty_like(episode.truth)
    for t, (odom, scan) in enumerate(zip(episode.odometry, episode.scans, strict=True)):
        pf.update(odom, scan)
        estimates[t] = pf.estimate(odom)
    seconds = time.process_time() - started
    position_error = np.hypot(*(estimates[:, :2] - episode.truth[:, :2]).T)
    yaw_error = np.abs(angle_difference(estimates[:, 2], episode.truth[:, 2]))
    within = (position_error <= CONVERGED_POSITION) & (yaw_error <= CONVERGED_YAW)
    converged = first_settled(within, max(1, round(SETTLE_S / episode.dt)))
    return TrackResult(estimates, position_error, yaw_error, converged, seconds)


def first_settled(within: NDArray[np.bool_], steps: int) -> int | None:
    """The first index from which ``within`` holds for ``steps`` entries (or to the end)."""
    # Length of the run of True starting at each index, from the end backwards.
    run = np.zeros(len(within) + 1, dtype=np.int64)
    for i in range(len(within) - 1, -1, -1):
        run[i] = run[i + 1] + 1 if within[i] else 0
    settled = (run[:-1] >= steps) | (run[:-1] == len(within) - np.arange(len(within)))
    settled &= within
    hits = np.flatnonzero(settled)
    return int(hits[0]) if len(hits) else None
