"""AMCL's likelihood-field laser model over a subsample of a scan's beams.

A beam of range ``r`` at angle ``a`` ends, for a particle at ``(x, y, yaw)``, at the laser's pose
composed with ``(r cos a, r sin a)``; ``d`` is that point's distance to the nearest obstacle of
the map (:class:`~bubblerob_env.localisation.field.LikelihoodField`). The beam's likelihood is
``z_hit * N(d; 0, sigma_hit) + z_rand / range_max``, a Gaussian around the map's obstacles plus
a uniform part for what the map does not show. Beams at ``range_max`` (no return) and under
``range_min`` are skipped, as AMCL skips them. Like AMCL, only ``max_beams`` beams evenly spread
over the scan are used (``laser_max_beams``, 30 by default there).

The beams of one scan are not independent (neighbouring beams see the same surface, the map is
imperfect), so their log-likelihoods are summed with the weight ``1 / independent_beams``'s
share, a tempered likelihood: without it the posterior is far too sharp and the filter
overconfident. AMCL's own remedy is its ``p += pz**3`` sum, which flattens the likelihood
likewise; the tempering here is the same idea with a knob.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from bubblerob_env.localisation.field import LikelihoodField

__all__ = ["LaserModel", "ScanGeometry"]


@dataclass(frozen=True)
class ScanGeometry:
    """Where a scan's beams point: angles (radians) in the laser frame, and that frame's pose.

    ``laser_pose`` is ``(x, y, yaw)`` of the laser in ``base_link`` (the ``/tf_static`` one).
    """

    angles: NDArray[np.float64]
    range_min: float
    range_max: float
    laser_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class LaserModel:
    """AMCL's ``laser_z_hit``, ``laser_z_rand``, ``laser_sigma_hit``, ``laser_max_beams``.

    ``independent_beams``: how many of the used beams count as independent (see the module).
    """

    z_hit: float = 0.95
    z_rand: float = 0.05
    sigma_hit: float = 0.05
    max_beams: int = 40
    independent_beams: float = 8.0

    def beam_indices(self, num_rays: int) -> NDArray[np.int64]:
        """The ``max_beams`` (or fewer) beams used, evenly spread over the scan."""
        step = max(1, math.ceil(num_rays / self.max_beams))
        return np.arange(0, num_rays, step, dtype=np.int64)

    def log_likelihood(
        self,
        particles: NDArray[np.float64],
        ranges: NDArray[np.float64],
        geometry: ScanGeometry,
        field: LikelihoodField,
    ) -> NDArray[np.float64]:
        """Each particle's tempered log-likelihood of the scan ``ranges`` (all beams given)."""
        used = self.beam_indices(len(ranges))
        r = ranges[used].astype(np.float64)
        valid = (r < geometry.range_max) & (r >= geometry.range_min) & np.isfinite(r)
        r, angles = r[valid], geometry.angles[used][valid]
        if len(r) == 0:
            return np.zeros(len(particles))
        lx, ly, lyaw = geometry.laser_pose
        # Beam end points in base_link, then in the map for each particle: (n, beams).
        bx = lx + r * np.cos(lyaw + angles)
        by = ly + r * np.sin(lyaw + angles)
        c, s = np.cos(particles[:, 2:3]), np.sin(particles[:, 2:3])
        x = particles[:, 0:1] + c * bx - s * by
        y = particles[:, 1:2] + s * bx + c * by
        d = field.lookup(x, y)
        hit = self.z_hit * np.exp(-0.5 * (d / self.sigma_hit) ** 2)
        beams = np.log(hit + self.z_rand / geometry.range_max).sum(axis=1)
        return np.asarray(beams * (self.independent_beams / len(r)))
