"""Trained SB3 models (``.zip``, PPO or SAC) as policies, as their run trained them.

A model is fed what it saw in training: the env's scan min-pooled as the run's ``env_wrapper``
pooled it (:class:`PooledPolicy`), normalised with the statistics saved beside the model
(:class:`NormalizedPolicy`), and, for a residual, added to the gap follower's action. Loading
needs the [train] extra (SB3 pulls in torch); an ONNX export of the model does not.
"""

from __future__ import annotations

import json
import pickle
import warnings
import zipfile
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from bubblerob_env.extras import MissingExtraError
from bubblerob_env.wrappers import min_pool
from policies.base import Policy, as_batch
from policies.observations import (
    ObservationAdapter,
    check_env,
    check_model_actions,
    check_model_spaces,
    env_signature,
)
from policies.residual import on_gap_follower
from policies.runs import (
    normalization_path,
    recorded_config,
    recorded_env_kwargs,
    recorded_pooling,
    residual_scale,
)

__all__ = [
    "NormalizedPolicy",
    "PooledPolicy",
    "SB3Policy",
    "UncheckedPolicyWarning",
    "load_sb3",
    "sb3_algorithm",
]


class SB3Policy:
    """An SB3 model's deterministic action, in float64 (the ``Policy`` protocol).

    ``predict`` is SB3's ``predict(obs, deterministic=True)`` computed by
    :class:`~policies.sb3_action.DeterministicActor`, the module the ONNX export traces: the zip
    and its export run one computation, in float64, and agree to ~1e-15 (float32's ~1e-6 made
    some closed-loop episodes end differently). One observation gives one action, a batch a batch.
    Always the deterministic action, as the ONNX export's :class:`~policies.onnx_policy.OnnxPolicy`
    (sampled actions: SB3's own ``model.predict(obs, deterministic=False)``, in float32).
    """

    def __init__(self, model: Any) -> None:
        from policies.sb3_action import DeterministicActor

        self.model = model
        self.actor = DeterministicActor(model)
        self.shapes = {key: space.shape for key, space in model.observation_space.spaces.items()}

    def predict(
        self,
        observation: Any,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> Any:
        """Action(s) for one observation or a batch; ``state`` is always None (no memory)."""
        batch, single = as_batch(observation, self.shapes)
        actions = self.actor.act(batch)
        return (actions[0] if single else actions), None

    def reset(self) -> None:
        """Nothing to forget: the model is stateless."""


class NormalizedPolicy(ObservationAdapter):
    """An SB3 model whose observations are normalised with its training statistics first."""

    def __init__(self, model: Any, normalizer: Any) -> None:
        super().__init__(SB3Policy(model))
        self.model = model
        self.normalizer = normalizer

    def adapt(self, observation: Any) -> Any:
        """The observation normalised as in training."""
        return self.normalizer.normalize_obs(observation)


class PooledPolicy(ObservationAdapter):
    """A policy trained behind :class:`~bubblerob_env.wrappers.LaserPooling`, fed the full scan.

    Min-pools each ``(key, pool)`` of ``pooling`` (in order) of the env's observation, one or a
    batch, then asks ``policy``: the same observations the model saw in training.
    """

    def __init__(self, policy: Policy, pooling: list[tuple[str, int]]) -> None:
        super().__init__(policy)
        self.pooling = list(pooling)

    def pool(self, observation: dict[str, Any]) -> dict[str, Any]:
        """The observation as the model saw it in training."""
        pooled = dict(observation)
        for key, size in self.pooling:
            pooled[key] = min_pool(np.asarray(pooled[key]), size)
        return pooled

    adapt = pool


def sb3_algorithm(path: Path) -> str:
    """``"PPO"`` or ``"SAC"``: which algorithm saved the SB3 model ``path``."""
    try:
        with zipfile.ZipFile(path) as archive:
            data = archive.read("data").decode() if "data" in archive.namelist() else ""
    except zipfile.BadZipFile as error:  # a ValueError: one line for the caller, as bad input
        raise ValueError(f"cannot load the policy file {path}: not a zip ({error})") from None
    if not data:
        raise ValueError(f"{path} is not a stable-baselines3 model (no 'data' entry)")
    policy_class = json.loads(data).get("policy_class", {})
    module = policy_class.get("__module__", "") if isinstance(policy_class, dict) else ""
    return (
        "SAC" if module.startswith("stable_baselines3.sac") or '"log_ent_coef"' in data else "PPO"
    )


def _algorithms(path: Path) -> tuple[Any, Any]:
    """SB3's ``PPO`` and ``SAC`` (imported here: SB3 pulls in torch)."""
    try:
        from stable_baselines3 import PPO, SAC
    except ModuleNotFoundError:
        raise MissingExtraError(
            f"loading the SB3 model {path} needs the [train] extra: pip install 'bubblerob[train]' "
            "(or export it with python -m policies.export_onnx and load the .onnx)"
        ) from None
    return PPO, SAC


def load_sb3(
    path: Path,
    env: gym.Env[Any, Any] | None = None,
    name: str = "",
    space: gym.spaces.Dict | None = None,
) -> Policy:
    """The SB3 model ``path`` as a policy for ``env`` (whose ``Dict`` space is ``space``).

    Checked against ``env`` when both are given (the env of the run's ``config.yml``, the model's
    observation space); fed ``Dict`` observations.
    """
    ppo, sac = _algorithms(path)
    config = recorded_config(path) or {}
    if config.get("frame_stack"):
        raise ValueError(
            f"{path} was trained on {config['frame_stack']} stacked frames (frame_stack); "
            "load_policy runs policies of single observations only"
        )
    model: Any = (sac if sb3_algorithm(path) == "SAC" else ppo).load(path, device="cpu")
    pooling = recorded_pooling(path)
    scale = residual_scale(config.get("env_wrapper"))
    if not config and env is not None:
        warnings.warn(
            f"{path} has no config.yml beside it: its observation and action spaces are checked, "
            "but not its action_type (wheels and twist share one action space)",
            UncheckedPolicyWarning,
            stacklevel=2,
        )
    if env is not None and space is not None:
        _check_trained_env(path, model, env, name or str(path), space, pooling)
        if scale is None:  # a residual's model acts in the residual's own space
            check_model_actions(name or str(path), model.action_space, env)
    policy: Policy = _normalized(model, normalization_path(path))
    if pooling:
        policy = PooledPolicy(policy, pooling)
    return policy if scale is None else on_gap_follower(policy, env, space, scale)


class UncheckedPolicyWarning(UserWarning):
    """A policy file says too little about its env for every check (a bare SB3 zip)."""


def _check_trained_env(
    path: Path,
    model: Any,
    env: gym.Env[Any, Any],
    name: str,
    space: gym.spaces.Dict,
    pooling: list[tuple[str, int]],
) -> None:
    """``env`` against the run's env (its ``config.yml``) and the model's observation space."""
    kwargs = recorded_env_kwargs(path)
    if kwargs is not None:
        trained_env = gym.make("BubbleRob-v0", **kwargs)
        check_env(name, env_signature(trained_env), env, kwargs)
        trained_env.close()
    check_model_spaces(name, model.observation_space, env, space, pooling)


def _normalized(model: Any, stats: Path) -> Policy:
    """``model``, normalised with the statistics ``stats`` where there are any."""
    if not stats.is_file():
        return SB3Policy(model)
    with stats.open("rb") as handle:
        normalizer = pickle.load(handle)  # noqa: S301 - our own training output
    normalizer.training = False
    return NormalizedPolicy(model, normalizer)
