"""``load_policy``: built-in controllers by name, trained policies as ONNX or SB3 ``.zip`` files.

Dispatch only: the built-ins are :mod:`policies.builtin`, the ONNX exports
:mod:`policies.onnx_policy`, the SB3 models :mod:`policies.sb3_policy`, and every check of a
policy against an env :mod:`policies.observations`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym

from policies.base import Policy
from policies.builtin import BUILTIN_POLICIES, NAVIGATION_POLICIES, builtin_policy
from policies.crowd_policy import CROWD_MODEL, one_robot_env
from policies.observations import FlatObservationPolicy, PolicyEnvMismatchError, dict_view
from policies.onnx_policy import load_onnx
from policies.runs import TRAINED_DIR
from policies.sb3_policy import load_sb3

__all__ = [
    "BUILTIN_POLICIES",
    "SHIPPED_POLICIES",
    "PolicyEnvMismatchError",
    "load_policy",
]

SHIPPED_POLICIES = {
    "ppo": TRAINED_DIR / "ppo_bubblerob_v0.onnx",
    "nav": TRAINED_DIR / "nav" / "ppo_bubblerob_nav_v0.onnx",
    "crowd": CROWD_MODEL,
}
"""Trained policies shipped with the package, exported to ONNX from the SB3 ``.zip`` beside them
(``python -m policies.export_onnx``) and run with onnxruntime, without torch. ``ppo`` was trained
for ``gym.make("BubbleRob-v0")``, ``nav`` for ``gym.make("BubbleRobNav-v0")``, both with no
kwargs."""


def load_policy(
    name_or_path: str | Path, env: gym.Env[Any, Any] | None = None, seed: int = 0
) -> Policy:
    """A policy for ``env`` (default: ``BubbleRob-v0`` with default kwargs).

    Args:
        name_or_path: ``"reactive"``, ``"laser"``, ``"random"``, ``"navigator"`` and
            ``"pursuit"`` (Nav envs only), ``"ppo"`` and ``"nav"`` (the shipped trained
            policies, run with onnxruntime; ``nav`` drives to a goal), the path of an ONNX
            file written by ``python -m policies.export_onnx``, or the path of an SB3 ``.zip``
            (PPO or SAC; needs the [train] extra). A model whose run's ``config.yml`` has an
            ``env_wrapper`` of :class:`~bubblerob_env.wrappers.LaserPooling` is fed the env's
            scan min-pooled the same way (:class:`~policies.sb3_policy.PooledPolicy`; ONNX
            exports do it inside the graph).
        env: The env (or a wrapper of it) the policy will act in: its action type, speed limits
            and laser geometry shape the built-in controllers' actions, and a trained policy is
            checked against the env it was trained for. A world of
            ``parallel_env(task="nav")`` stands for one of its robots' Nav env (``crowd``,
            ``navigator`` ...; ``predict`` takes one robot's observation, or a row per robot).
        seed: Seed of the ``random`` policy.

    Raises:
        ValueError: For an unknown name or a file that is not a policy.
        PolicyEnvMismatchError: (a ``ValueError``) when a trained policy's env (action type,
            laser rays, camera) differs from ``env``.
    """
    name = str(name_or_path)
    env = one_robot_env(env)  # a world of parallel_env(task="nav"): one robot's Nav env
    if name in (*BUILTIN_POLICIES, *NAVIGATION_POLICIES) and name not in SHIPPED_POLICIES:
        return builtin_policy(name, env, seed)
    space, layout = (None, None) if env is None else dict_view(env, name)
    policy = _load_trained(name, env, space)
    if layout is None or not _takes_dict(policy):
        return policy
    return FlatObservationPolicy(policy, layout)


def _takes_dict(policy: Policy) -> bool:
    """False for an SB3 model trained on ``obs_mode="flat"`` observations: it takes them as is."""
    model = getattr(policy, "model", None)
    return model is None or isinstance(model.observation_space, gym.spaces.Dict)


def _load_trained(
    name: str, env: gym.Env[Any, Any] | None, space: gym.spaces.Dict | None
) -> Policy:
    """The trained policy ``name`` for ``env``, whose (``Dict``) observation space is ``space``."""
    if name in SHIPPED_POLICIES:
        return load_onnx(SHIPPED_POLICIES[name], env, name, space)
    path = Path(name)
    if path.suffix in (".zip", ".onnx"):
        if not path.is_file():
            raise ValueError(f"policy file {path} does not exist")
        if path.suffix == ".onnx":
            return load_onnx(path, env, name, space)
        return load_sb3(path, env, name, space)
    raise ValueError(
        f"unknown policy {name!r}: use one of "
        f"{[*BUILTIN_POLICIES, *NAVIGATION_POLICIES, *SHIPPED_POLICIES]} "
        "or a path to an exported .onnx or an SB3 .zip"
    )
