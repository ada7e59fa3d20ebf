"""Monte Carlo localisation on the occupancy grid, in the manner of ROS's ``amcl`` (issue #27).

- :mod:`.field`: the likelihood field (distance to the nearest obstacle) of a grid.
- :mod:`.motion`: AMCL's odometry motion model.
- :mod:`.laser_model`: AMCL's likelihood-field laser model on a subsample of the beams.
- :mod:`.resampling`: low-variance resampling and KLD-sampling's particle count.
- :mod:`.filter`: :class:`ParticleFilter`, tracking from a pose or global localisation.
- :mod:`.evaluation`: recorded episodes and the filter's errors on them.
"""

from __future__ import annotations

from bubblerob_env.localisation.field import LikelihoodField
from bubblerob_env.localisation.filter import FilterConfig, ParticleFilter
from bubblerob_env.localisation.laser_model import LaserModel, ScanGeometry
from bubblerob_env.localisation.motion import MotionNoise

__all__ = [
    "FilterConfig",
    "LaserModel",
    "LikelihoodField",
    "MotionNoise",
    "ParticleFilter",
    "ScanGeometry",
]
