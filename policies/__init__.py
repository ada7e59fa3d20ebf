"""Policies for BubbleRob-v0, all with SB3's ``predict(obs, state, episode_start, deterministic)``.

``load_policy(name_or_path, env)`` gives a built-in controller by name (``reactive``, ``laser``,
``random``), the shipped trained policy (``ppo``) or a trained model from an ``.onnx`` or SB3
``.zip`` path, checked against the env's observations when it loads
(:class:`PolicyEnvMismatchError`). Every policy follows the :class:`Policy` protocol.
"""

from __future__ import annotations

from policies.base import Policy
from policies.handwritten import LaserPolicy, RandomPolicy, ReactivePolicy
from policies.loading import BUILTIN_POLICIES, SHIPPED_POLICIES, load_policy
from policies.observations import FlatObservationPolicy, PolicyEnvMismatchError

__all__ = [
    "BUILTIN_POLICIES",
    "SHIPPED_POLICIES",
    "FlatObservationPolicy",
    "LaserPolicy",
    "Policy",
    "PolicyEnvMismatchError",
    "RandomPolicy",
    "ReactivePolicy",
    "load_policy",
]
