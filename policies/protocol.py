"""The learning protocol: three disjoint seed ranges, and how a success rate is reported.

A policy is trained on **training** arenas, every choice (checkpoint, config, training seed) is
made on **validation** seeds, and the number reported is measured once on **test** seeds that
no choice looked at. Each range is a set of episode seeds (``env.reset(seed=s)``):

- training: the first episode of training env ``i`` is seed ``--seed + i``, with ``--seed +
  n_envs <= 1000``; the later ones are unseeded resets, drawn from those envs' generators;
- validation: 1,000-99,999. ``bubblerob evaluate``'s default (1000 on) and the evaluation
  during training (:data:`VALIDATION`'s first ``--eval-episodes`` seeds, the same ones at every
  evaluation, so evaluations compare);
- test: 100,000-199,999. README's table is its first 1,000 seeds
  (``bubblerob evaluate --split test --episodes 1000``).

Seeds 1000-1099 and 2000-2099 were looked at while choosing policies before this protocol
(docs/LEARNING.md), so they are validation seeds now, never test seeds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["SPLITS", "TEST", "TRAINING", "VALIDATION", "SeedRange", "wilson_interval"]


@dataclass(frozen=True)
class SeedRange:
    """Episode seeds ``start`` to ``stop - 1``, for one use."""

    name: str
    start: int
    stop: int

    def __contains__(self, seed: object) -> bool:
        return isinstance(seed, int) and self.start <= seed < self.stop

    def outside(self, first: int, episodes: int) -> str | None:
        """Why seeds ``first`` on (``episodes`` of them) are not all in range; None if they are."""
        if self.start <= first and first + episodes <= self.stop:
            return None
        return (
            f"{self.name} seeds are {self.start}-{self.stop - 1}; "
            f"seeds {first}-{first + episodes - 1} are not all in it"
        )


TRAINING = SeedRange("training", 0, 1_000)
VALIDATION = SeedRange("validation", 1_000, 100_000)
TEST = SeedRange("test", 100_000, 200_000)
SPLITS = {split.name: split for split in (TRAINING, VALIDATION, TEST)}


def wilson_interval(successes: int, trials: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of a success rate (95% for ``z=1.96``), as fractions.

    Unlike the normal approximation it stays inside [0, 1] and is not zero-width at 0% or
    100%: 1000 of 1000 gives (0.9962, 1.0).
    """
    if trials <= 0:
        raise ValueError(f"trials must be positive, got {trials}")
    p = successes / trials
    denominator = 1.0 + z * z / trials
    centre = (p + z * z / (2 * trials)) / denominator
    half = z * math.sqrt(p * (1 - p) / trials + z * z / (4 * trials * trials)) / denominator
    return max(0.0, centre - half), min(1.0, centre + half)
