"""What the nav tests share."""

from __future__ import annotations

from typing import Any

import numpy as np


def assert_action_ignores_the_state(env: Any, policy: Any, seed: int = 1000) -> None:
    """An observed-memory controller's state only marks a step taken: 30 steps into episode
    ``seed``, the action for a state it did not carry is the action for the one it did."""
    obs, _ = env.reset(seed=seed)
    for _ in range(30):
        obs, *_ = env.step(policy.predict(obs)[0])
    first, _ = policy.predict(obs, state=np.array([1.0]))
    other, _ = policy.predict(obs, state=np.array([7.0]))
    np.testing.assert_array_equal(first, other)
