"""Monte Carlo localisation in the manner of ROS's ``amcl``: odometry in, pose on the map out.

Each :meth:`ParticleFilter.update` takes the odometry pose and a laser scan. The particles move
by the odometry since the last filter update (:mod:`~bubblerob_env.localisation.motion`) once
the robot has moved ``update_min_d`` metres or turned ``update_min_a`` radians (AMCL's
parameters of those names); then the scan weighs them
(:mod:`~bubblerob_env.localisation.laser_model`) and, every ``resample_interval`` updates, they
are resampled (low variance; KLD-sampling sizes the set between ``min_particles`` and
``max_particles``). The estimate is the weighted mean of the particles near the heaviest one (its
cluster, as AMCL reports its best cluster); between updates it follows the odometry, so
``map -> odom`` (:meth:`ParticleFilter.map_to_odom`) changes only at updates, as AMCL's does.

Start it at a pose (:meth:`start_at`, rviz's ``/initialpose``) or everywhere on the map's free
space (:meth:`start_global`, AMCL's ``global_localization`` service). With ``recovery_alpha_slow``
< ``recovery_alpha_fast`` it injects random particles when the scans fit the particles worse than
they used to (Augmented MCL, AMCL's ``recovery_alpha_*``; off by default, as in AMCL).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from bubblerob_env.localisation.field import LikelihoodField
from bubblerob_env.localisation.laser_model import LaserModel, ScanGeometry
from bubblerob_env.localisation.motion import (
    MotionNoise,
    angle_difference,
    compose,
    relative_motion,
    sample_motion,
)
from bubblerob_env.localisation.resampling import kld_particle_count, low_variance_indices

__all__ = ["FilterConfig", "ParticleFilter"]


@dataclass(frozen=True)
class FilterConfig:
    """The filter's parameters, named as AMCL's where AMCL has them."""

    min_particles: int = 300
    max_particles: int = 5000
    global_particles: int = 50000
    update_min_d: float = 0.05
    update_min_a: float = 0.1
    resample_interval: int = 1
    kld_err: float = 0.02
    kld_z: float = 3.0
    cluster_radius: float = 0.3
    robot_clearance: float = 0.1
    recovery_alpha_slow: float = 0.0
    recovery_alpha_fast: float = 0.0
    motion: MotionNoise = field(default_factory=MotionNoise)
    laser: LaserModel = field(default_factory=LaserModel)


class ParticleFilter:
    """Particles ``(n, 3)`` (x, y, yaw in the map frame) with log-weights, on one map."""

    def __init__(
        self,
        field_: LikelihoodField,
        geometry: ScanGeometry,
        config: FilterConfig | None = None,
        seed: int | None = None,
    ) -> None:
        """A filter on ``field_``'s map for scans shaped as ``geometry``; not started yet."""
        self.field = field_
        self.geometry = geometry
        self.config = config or FilterConfig()
        self.rng = np.random.default_rng(seed)
        self.particles = np.zeros((0, 3))
        self.log_weights = np.zeros(0)
        self.updates = 0
        self._odom_at_update: NDArray[np.float64] | None = None
        self._pose_at_update = np.zeros(3)
        self._w_slow = self._w_fast = 0.0
        self._free = field_.free_cells(self.config.robot_clearance)

    def start_at(
        self, pose: tuple[float, float, float], std: tuple[float, float, float] = (0.1, 0.1, 0.1)
    ) -> None:
        """Particles around ``pose`` (Gaussian, ``std`` in m, m, rad): AMCL's initial pose."""
        n = self.config.max_particles
        spread = self.rng.standard_normal((n, 3)) * np.asarray(std)
        self._restart(np.asarray(pose, dtype=np.float64) + spread)

    def start_global(self) -> None:
        """Particles uniform over the free space of the map, headings uniform."""
        self._restart(self._uniform(self.config.global_particles))

    def _uniform(self, n: int) -> NDArray[np.float64]:
        xs, ys = self._free
        cell = self.rng.integers(0, len(xs), n)
        jitter = (self.rng.random((n, 2)) - 0.5) * self.field.resolution
        yaw = self.rng.uniform(-math.pi, math.pi, n)
        return np.column_stack([xs[cell] + jitter[:, 0], ys[cell] + jitter[:, 1], yaw])

    def _restart(self, particles: NDArray[np.float64]) -> None:
        particles[:, 2] = angle_difference(particles[:, 2], 0.0)
        self.particles = particles
        self.log_weights = np.zeros(len(particles))
        self._odom_at_update = None
        self._pose_at_update = self._cluster_mean()
        self._w_slow = self._w_fast = 0.0

    def update(self, odom: NDArray[np.float64], ranges: NDArray[np.float64]) -> bool:
        """Take the odometry pose and the scan at that pose; return whether the filter updated."""
        if len(self.particles) == 0:
            raise RuntimeError("the filter has no particles: call start_at() or start_global()")
        odom = np.asarray(odom, dtype=np.float64)
        if self._odom_at_update is None:  # the first scan: weigh where the particles are
            self._weigh(ranges)
        else:
            moved = relative_motion(self._odom_at_update, odom)
            config = self.config
            if math.hypot(moved[0], moved[1]) < config.update_min_d and abs(moved[2]) < (
                config.update_min_a
            ):
                return False
            sample_motion(self.particles, self._odom_at_update, odom, config.motion, self.rng)
            self._weigh(ranges)
        self._odom_at_update = odom
        self.updates += 1
        if self.updates % self.config.resample_interval == 0:
            self._resample()
        self._pose_at_update = self._cluster_mean()
        return True

    def _weigh(self, ranges: NDArray[np.float64]) -> None:
        log_likelihood = self.config.laser.log_likelihood(
            self.particles, ranges, self.geometry, self.field
        )
        self.log_weights += log_likelihood
        self.log_weights -= self.log_weights.max()
        config = self.config
        if config.recovery_alpha_slow > 0.0:
            # The mean likelihood of this scan, tracked slowly and quickly (Augmented MCL).
            mean = float(np.mean(np.exp(log_likelihood)))
            if self._w_slow == 0.0:
                self._w_slow = self._w_fast = mean
            self._w_slow += config.recovery_alpha_slow * (mean - self._w_slow)
            self._w_fast += config.recovery_alpha_fast * (mean - self._w_fast)

    def _resample(self) -> None:
        config = self.config
        weights = np.exp(self.log_weights)
        count = kld_particle_count(self.particles, epsilon=config.kld_err, z=config.kld_z)
        n = int(np.clip(count, config.min_particles, config.max_particles))
        chosen = self.particles[low_variance_indices(weights, n, self.rng)]
        inject = 0.0
        if config.recovery_alpha_slow > 0.0 and self._w_slow > 0.0:
            inject = max(0.0, 1.0 - self._w_fast / self._w_slow)
        random_count = int(self.rng.binomial(n, inject)) if inject > 0.0 else 0
        if random_count:
            chosen[:random_count] = self._uniform(random_count)
        self.particles = chosen
        self.log_weights = np.zeros(n)

    def _cluster_mean(self) -> NDArray[np.float64]:
        """Weighted mean of the particles within ``cluster_radius`` of the heaviest one."""
        weights = np.exp(self.log_weights - self.log_weights.max())
        best = self.particles[int(np.argmax(weights))]
        near = np.hypot(*(self.particles[:, :2] - best[:2]).T) <= self.config.cluster_radius
        w = weights * near
        x, y = (w @ self.particles[:, :2]) / w.sum()
        yaw = math.atan2(
            float(w @ np.sin(self.particles[:, 2])), float(w @ np.cos(self.particles[:, 2]))
        )
        return np.array([x, y, yaw])

    def estimate(self, odom: NDArray[np.float64]) -> NDArray[np.float64]:
        """The pose on the map now: the last update's estimate moved by the odometry since."""
        if self._odom_at_update is None:
            return np.array(self._pose_at_update)
        return compose(self._pose_at_update, relative_motion(self._odom_at_update, odom))

    def map_to_odom(self) -> NDArray[np.float64]:
        """``map -> odom`` as (x, y, yaw): the estimate composed with the odometry's inverse."""
        if self._odom_at_update is None:
            return np.zeros(3)
        odom = self._odom_at_update
        inverse = relative_motion(odom, np.zeros(3))
        return compose(self._pose_at_update, inverse)

    def covariance(self) -> NDArray[np.float64]:
        """Weighted 3x3 covariance of x, y (m) and yaw (rad, about the mean heading), as AMCL's."""
        weights = np.exp(self.log_weights - self.log_weights.max())
        weights /= weights.sum()
        mean_yaw = math.atan2(
            float(weights @ np.sin(self.particles[:, 2])),
            float(weights @ np.cos(self.particles[:, 2])),
        )
        offsets = np.column_stack(
            [
                self.particles[:, :2] - weights @ self.particles[:, :2],
                angle_difference(self.particles[:, 2], mean_yaw),
            ]
        )
        return np.asarray((offsets * weights[:, None]).T @ offsets)

    def spread(self) -> tuple[float, float]:
        """Weighted standard deviations of position (m) and heading (rad) of all particles."""
        weights = np.exp(self.log_weights - self.log_weights.max())
        weights /= weights.sum()
        mean = weights @ self.particles[:, :2]
        position = math.sqrt(float(weights @ ((self.particles[:, :2] - mean) ** 2).sum(axis=1)))
        resultant = math.hypot(
            float(weights @ np.cos(self.particles[:, 2])),
            float(weights @ np.sin(self.particles[:, 2])),
        )
        return position, math.sqrt(max(0.0, -2.0 * math.log(max(resultant, 1e-12))))
