"""AMCL's odometry motion model (``odom_model_type: diff``): particles move by noisy odometry.

Between two odometry poses the robot is taken to turn by ``rot1``, drive ``trans`` and turn by
``rot2`` (Thrun, Burgard and Fox, *Probabilistic Robotics*, 2005, table 5.6). Each particle
moves by those three, each perturbed by zero-mean Gaussian noise whose standard deviation grows
with the motion: ``alpha1`` (rotation from rotation), ``alpha2`` (rotation from translation),
``alpha3`` (translation from translation) and ``alpha4`` (translation from rotation), as AMCL's
``odom_alpha1..4``. A motion backwards is modelled as one forwards with turned headings, as AMCL
does, so reversing does not read as two half-turns.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["MotionNoise", "angle_difference", "compose", "relative_motion", "sample_motion"]


@dataclass(frozen=True)
class MotionNoise:
    """AMCL's ``odom_alpha1`` .. ``odom_alpha4`` (dimensionless; see the module)."""

    alpha1: float = 0.2
    alpha2: float = 0.2
    alpha3: float = 0.2
    alpha4: float = 0.2


def angle_difference(
    a: NDArray[np.float64] | float, b: NDArray[np.float64] | float
) -> NDArray[np.float64]:
    """``a - b`` wrapped into [-pi, pi)."""
    return np.asarray((np.asarray(a) - b + math.pi) % (2.0 * math.pi) - math.pi)


def compose(pose: NDArray[np.float64], delta: NDArray[np.float64]) -> NDArray[np.float64]:
    """``pose`` (x, y, yaw, last axis) moved by ``delta`` given in ``pose``'s own frame."""
    c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
    x = pose[..., 0] + c * delta[..., 0] - s * delta[..., 1]
    y = pose[..., 1] + s * delta[..., 0] + c * delta[..., 1]
    yaw = angle_difference(pose[..., 2] + delta[..., 2], 0.0)
    return np.stack([x, y, yaw], axis=-1)


def relative_motion(before: NDArray[np.float64], after: NDArray[np.float64]) -> NDArray[np.float64]:
    """``after`` in the frame of ``before``: what :func:`compose` adds to ``before``."""
    c, s = math.cos(before[2]), math.sin(before[2])
    dx, dy = after[0] - before[0], after[1] - before[1]
    return np.array(
        [c * dx + s * dy, -s * dx + c * dy, float(angle_difference(after[2], before[2]))]
    )


def sample_motion(
    particles: NDArray[np.float64],
    before: NDArray[np.float64],
    after: NDArray[np.float64],
    noise: MotionNoise,
    rng: np.random.Generator,
) -> None:
    """Move ``particles`` (``(n, 3)``, in place) by the odometry motion ``before`` -> ``after``."""
    dx, dy = after[0] - before[0], after[1] - before[1]
    trans = math.hypot(dx, dy)
    # Too short a move has no direction: all of it is rotation then (AMCL's 0.01 m).
    rot1 = 0.0 if trans < 0.01 else float(angle_difference(math.atan2(dy, dx), before[2]))
    rot2 = float(angle_difference(float(angle_difference(after[2], before[2])), rot1))
    # Noise of a backwards move: the turns measured from the reversed heading.
    rot1_size = min(abs(rot1), abs(float(angle_difference(rot1, math.pi))))
    rot2_size = min(abs(rot2), abs(float(angle_difference(rot2, math.pi))))
    n = len(particles)
    rot1_std = math.sqrt(noise.alpha1 * rot1_size**2 + noise.alpha2 * trans**2)
    trans_std = math.sqrt(noise.alpha3 * trans**2 + noise.alpha4 * (rot1_size**2 + rot2_size**2))
    rot2_std = math.sqrt(noise.alpha1 * rot2_size**2 + noise.alpha2 * trans**2)
    draws = rng.standard_normal((3, n))
    rot1_hat = rot1 - rot1_std * draws[0]
    trans_hat = trans - trans_std * draws[1]
    rot2_hat = rot2 - rot2_std * draws[2]
    heading = particles[:, 2] + rot1_hat
    particles[:, 0] += trans_hat * np.cos(heading)
    particles[:, 1] += trans_hat * np.sin(heading)
    particles[:, 2] = angle_difference(heading + rot2_hat, 0.0)
