"""Policies for BubbleRob-v0, all with SB3's ``predict(obs, state, episode_start, deterministic)``.

``load_policy(name_or_path, env)`` gives a built-in controller by name (``reactive``, ``laser``,
``random``) or a trained SB3 model from a ``.zip`` path.
"""

from __future__ import annotations

from policies.handwritten import LaserPolicy, RandomPolicy, ReactivePolicy
from policies.loading import BUILTIN_POLICIES, load_policy

__all__ = ["BUILTIN_POLICIES", "LaserPolicy", "RandomPolicy", "ReactivePolicy", "load_policy"]
