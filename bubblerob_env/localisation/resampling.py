"""Resampling: low-variance (systematic) draws, and KLD-sampling's particle count.

Low-variance resampling (*Probabilistic Robotics*, table 4.4) draws ``n`` particles with one
random number: the copies of each particle differ from ``n * weight`` by less than one, so a
resampling step adds little variance. KLD-sampling (Fox, 2003; AMCL's ``kld_err``, ``kld_z``)
chooses ``n`` so that, with probability ``1 - delta``, the sample approximates the posterior
within Kullback-Leibler distance ``epsilon``: ``n`` grows with the number of histogram bins the
particles occupy (AMCL's bins: 0.5 m and 10 degrees).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ["kld_particle_count", "low_variance_indices"]


def low_variance_indices(
    weights: NDArray[np.float64], n: int, rng: np.random.Generator
) -> NDArray[np.int64]:
    """Indices of ``n`` particles drawn in proportion to ``weights`` (they need not sum to 1)."""
    cumulative = np.cumsum(weights)
    cumulative /= cumulative[-1]
    positions = (rng.random() + np.arange(n)) / n
    indices = np.searchsorted(cumulative, positions, side="right")
    return np.minimum(indices, len(weights) - 1).astype(np.int64)


def kld_particle_count(
    particles: NDArray[np.float64],
    bin_size: tuple[float, float, float] = (0.5, 0.5, math.radians(10.0)),
    epsilon: float = 0.01,
    z: float = 3.0,
) -> int:
    """KLD-sampling's number of particles for the bins ``particles`` (``(n, 3)``) occupy.

    ``epsilon`` and ``z`` are AMCL's ``kld_err`` and ``kld_z`` (defaults 0.01 and 0.99's
    quantile, 2.33; here 3.0, a little more cautious). Wilson-Hilferty's chi-square quantile.
    """
    cells = np.floor(particles / np.asarray(bin_size)).astype(np.int64)
    k = len(np.unique(cells, axis=0))
    if k <= 1:
        return 1
    a = 2.0 / (9.0 * (k - 1))
    return math.ceil((k - 1) / (2.0 * epsilon) * (1.0 - a + math.sqrt(a) * z) ** 3)
