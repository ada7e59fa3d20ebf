"""The built-in controllers by name: ``reactive``, ``laser`` (the gap follower) and ``random``.

The Nav task's (``BubbleRobNav-v0``) are ``navigator`` and ``pursuit`` (:mod:`policies.navigator`).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym

from bubblerob_env import BubbleRobEnv
from policies.base import ActionMapper, Policy
from policies.handwritten import LaserPolicy, RandomPolicy, ReactivePolicy
from policies.navigator import NAVIGATION_POLICIES, navigation_policy
from policies.observations import (
    FlatObservationPolicy,
    bubblerob_base,
    check_observations,
    dict_view,
)

__all__ = ["BUILTIN_POLICIES", "NAVIGATION_POLICIES", "builtin_policy", "controller"]

BUILTIN_POLICIES = ("reactive", "laser", "random")
"""The controllers of every env; the Nav task's are :data:`NAVIGATION_POLICIES`."""


def builtin_policy(name: str, env: gym.Env[Any, Any] | None = None, seed: int = 0) -> Policy:
    """``load_policy(name, env, seed)`` for a built-in ``name``: fed flat observations too."""
    space, layout = (None, None) if env is None else dict_view(env, name)
    policy = controller(name, bubblerob_base(env), space, seed)
    return policy if layout is None else FlatObservationPolicy(policy, layout)


def controller(name: str, base: BubbleRobEnv, space: gym.spaces.Dict | None, seed: int) -> Policy:
    """The built-in ``name`` for ``base``, checked against its ``Dict`` space (None: unchecked).

    Takes ``Dict`` observations, as ``space`` gives them.
    """
    mapper = ActionMapper(
        base.drive, base.action_type, base.max_linear_speed, base.max_angular_speed
    )
    if name in NAVIGATION_POLICIES:
        return navigation_policy(name, base, space, mapper)
    # Every built-in reads proximity (a batch's size too); the laser policy, the whole scan.
    needed: dict[str, tuple[int, ...] | None] = {"proximity": (1,)}
    if name == "laser":
        if base.laser_spec is None:
            raise ValueError("the laser policy needs an env with a laser (laser_num_rays > 0)")
        needed["laser"] = (base.laser_spec.num_rays,)
    if space is not None:
        check_observations(name, needed, space)
    if name == "reactive":
        return ReactivePolicy(mapper, base.proximity_spec.trigger_distance, dt=base.dt)
    if name == "laser" and base.laser_spec is not None:
        return LaserPolicy.for_robot(mapper, base.laser_spec, base.robot.radius)
    return RandomPolicy(mapper, seed)
