"""``load_policy``: built-in controllers by name, trained SB3 models by path."""

from __future__ import annotations

import zipfile
from pathlib import Path
from typing import Any

import gymnasium as gym

from bubblerob_env import BubbleRobEnv
from policies.base import ActionMapper
from policies.handwritten import LaserPolicy, RandomPolicy, ReactivePolicy

__all__ = ["BUILTIN_POLICIES", "SHIPPED_POLICIES", "load_policy"]

BUILTIN_POLICIES = ("reactive", "laser", "random")
TRAINED_DIR = Path(__file__).resolve().parent / "trained"
SHIPPED_POLICIES = {"ppo": TRAINED_DIR / "ppo_bubblerob_v0.zip"}
"""Trained policies shipped with the package, for ``gym.make("BubbleRob-v0")`` with no kwargs."""


def _unwrap(env: gym.Env[Any, Any] | None) -> BubbleRobEnv:
    if env is None:
        return BubbleRobEnv()
    base = env.unwrapped
    if not isinstance(base, BubbleRobEnv):
        raise TypeError(f"expected a BubbleRob env, got {type(base).__name__}")
    return base


def load_policy(name_or_path: str | Path, env: gym.Env[Any, Any] | None = None, seed: int = 0):
    """A policy for ``env`` (default: ``BubbleRob-v0`` with default kwargs).

    Args:
        name_or_path: ``"reactive"``, ``"laser"``, ``"random"``, ``"ppo"`` (the shipped trained
            policy) or a path to an SB3 ``.zip`` (PPO or SAC).
        env: The env (or a wrapper of it) the policy will act in: its action type, speed limits
            and laser geometry shape the built-in controllers' actions.
        seed: Seed of the ``random`` policy.

    Raises:
        ValueError: For an unknown name or a file that is not an SB3 model.
    """
    name = str(name_or_path)
    if name in SHIPPED_POLICIES:
        return _load_sb3(SHIPPED_POLICIES[name])
    if name in BUILTIN_POLICIES:
        base = _unwrap(env)
        mapper = ActionMapper(
            base.drive, base.action_type, base.max_linear_speed, base.max_angular_speed
        )
        if name == "reactive":
            return ReactivePolicy(mapper, base.proximity_spec.trigger_distance, dt=base.dt)
        if name == "laser":
            if base.laser_spec is None:
                raise ValueError("the laser policy needs an env with a laser (laser_num_rays > 0)")
            return LaserPolicy(mapper, base.laser_spec)
        return RandomPolicy(mapper, seed)
    path = Path(name)
    if path.suffix == ".zip":
        if not path.is_file():
            raise ValueError(f"policy file {path} does not exist")
        return _load_sb3(path)
    raise ValueError(
        f"unknown policy {name!r}: use one of {[*BUILTIN_POLICIES, *SHIPPED_POLICIES]} "
        "or a path to an SB3 .zip"
    )


NORMALIZATION_SUFFIX = "_vecnormalize.pkl"
"""A model ``NAME.zip`` trained with ``normalize: true`` keeps its statistics in
``NAME_vecnormalize.pkl`` beside it (written by ``python -m train``)."""


class NormalizedPolicy:
    """An SB3 model whose observations are normalised with its training statistics first."""

    def __init__(self, model: Any, normalizer: Any) -> None:
        self.model = model
        self.normalizer = normalizer

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        """SB3's ``predict`` on the normalised observation."""
        normalized = self.normalizer.normalize_obs(observation)
        return self.model.predict(normalized, state, episode_start, deterministic)

    def reset(self) -> None:
        """Nothing to forget: the model is stateless."""


def _load_sb3(path: Path):
    import pickle

    from stable_baselines3 import PPO, SAC  # imported here: SB3 pulls in torch

    with zipfile.ZipFile(path) as archive:
        data = archive.read("data").decode() if "data" in archive.namelist() else ""
    if not data:
        raise ValueError(f"{path} is not a stable-baselines3 model (no 'data' entry)")
    algo = SAC if '"log_ent_coef"' in data else PPO
    model = algo.load(path, device="cpu")
    stats = path.with_name(path.stem + NORMALIZATION_SUFFIX)
    if not stats.is_file():
        return model
    with stats.open("rb") as handle:
        normalizer = pickle.load(handle)  # noqa: S301 - our own training output
    normalizer.training = False
    return NormalizedPolicy(model, normalizer)
