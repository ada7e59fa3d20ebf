"""``crowd``: one network shared by every robot of ``parallel_env(task="nav")``.

Trained with the shared-policy batch (``python -m train --env BubbleRobNav-v0 --vec-env crowd``,
:class:`~train.worlds_vec.WorldsSB3VecEnv` over circle crossings and random arenas), exported to
ONNX and run with onnxruntime. Its ``predict`` takes one robot's observation (or a batch, a row
per robot), as the single Nav env gives it; :func:`one_robot_env` turns a world into the single
Nav env a robot of it sees, so that ``load_policy("crowd", world)`` checks the policy against it.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import gymnasium as gym

from policies.observations import PolicyEnvMismatchError
from policies.runs import TRAINED_DIR

__all__ = ["CROWD_DIR", "CROWD_MODEL", "one_robot_env"]

CROWD_DIR = TRAINED_DIR / "crowd"
"""The shipped run's folder (``policies/runs.py``'s format)."""
CROWD_MODEL = CROWD_DIR / "crowd_bubblerob_nav_v0.onnx"


def one_robot_env(env: Any) -> Any:
    """One robot's Nav env of a ``parallel_env(task="nav")`` world; any other env as it is.

    Its arguments are the world's (the arena included), so its spaces are each agent's.
    """
    if not hasattr(env, "possible_agents"):
        return env
    goals = getattr(env, "goals", None)
    if goals is None:
        raise PolicyEnvMismatchError(
            "a policy that drives to a goal needs parallel_env(task='nav'), not task='wander'"
        )
    kwargs = {k: v for k, v in env.robot_kwargs.items() if k != "render_mode"}
    return gym.make("BubbleRobNav-v0", **kwargs, **dataclasses.asdict(goals.settings))
