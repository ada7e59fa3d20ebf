"""``load_policy``: built-in controllers by name, trained policies as ONNX or SB3 ``.zip`` files."""

from __future__ import annotations

import json
import zipfile
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from bubblerob_env import BubbleRobEnv
from bubblerob_env.wrappers import laser_pooling, min_pool
from policies.base import ActionMapper, Policy
from policies.handwritten import LaserPolicy, RandomPolicy, ReactivePolicy
from policies.observations import (
    FlatObservationPolicy,
    ObservationAdapter,
    PolicyEnvMismatchError,
    check_observations,
    dict_view,
)
from policies.residual import residual_scale

__all__ = [
    "BUILTIN_POLICIES",
    "SHIPPED_POLICIES",
    "PolicyEnvMismatchError",
    "check_env",
    "env_signature",
    "load_policy",
    "recorded_pooling",
]

BUILTIN_POLICIES = ("reactive", "laser", "random")
TRAINED_DIR = Path(__file__).resolve().parent / "trained"
SHIPPED_POLICIES = {"ppo": TRAINED_DIR / "ppo_bubblerob_v0.onnx"}
"""Trained policies shipped with the package, exported to ONNX from the SB3 ``.zip`` beside them
(``python -m policies.export_onnx``) and run with onnxruntime, without torch. They were trained for
``gym.make("BubbleRob-v0")`` with no kwargs."""

NORMALIZATION_SUFFIX = "_vecnormalize.pkl"
"""A model ``NAME.zip`` trained with ``normalize: true`` keeps its statistics in
``NAME_vecnormalize.pkl`` beside it (written by ``python -m train``)."""


def _unwrap(env: gym.Env[Any, Any] | None) -> BubbleRobEnv:
    if env is None:
        return BubbleRobEnv()
    base = env.unwrapped
    if not isinstance(base, BubbleRobEnv):
        raise TypeError(f"expected a BubbleRob env, got {type(base).__name__}")
    return base


def env_signature(env: gym.Env[Any, Any]) -> dict[str, Any]:
    """What a trained policy depends on: action type, laser rays and camera size (or None)."""
    base = _unwrap(env)
    camera = base.camera_spec
    return {
        "action_type": base.action_type,
        "laser_num_rays": 0 if base.laser_spec is None else int(base.laser_spec.num_rays),
        "camera": None if camera is None else [int(camera.height), int(camera.width)],
    }


def _describe(signature: dict[str, Any]) -> str:
    camera = signature.get("camera")
    return (
        f"action_type={signature.get('action_type')!r}, "
        f"laser_num_rays={signature.get('laser_num_rays')}, "
        f"camera={'off' if not camera else 'x'.join(map(str, camera))}"
    )


def check_env(
    name: str, trained: dict[str, Any], env: gym.Env[Any, Any], trained_kwargs: Any = None
) -> None:
    """Raise a one-line :class:`PolicyEnvMismatchError` if ``env`` differs from ``trained``."""
    actual = env_signature(env)
    differing = [key for key in ("action_type", "laser_num_rays", "camera") if key in trained]
    if all(trained[key] == actual[key] for key in differing):
        return
    kwargs = "" if trained_kwargs is None else f" (gym.make kwargs {trained_kwargs})"
    raise PolicyEnvMismatchError(
        f"policy {name!r} was trained for an env with {_describe(trained)}{kwargs}, "
        f"but this env has {_describe(actual)}: make the env it was trained for, or train one "
        "for this env"
    )


def load_policy(
    name_or_path: str | Path, env: gym.Env[Any, Any] | None = None, seed: int = 0
) -> Policy:
    """A policy for ``env`` (default: ``BubbleRob-v0`` with default kwargs).

    Args:
        name_or_path: ``"reactive"``, ``"laser"``, ``"random"``, ``"ppo"`` (the shipped trained
            policy, run with onnxruntime), the path of an ONNX file written by
            ``python -m policies.export_onnx``, or the path of an SB3 ``.zip`` (PPO or SAC; needs
            the [train] extra). A model whose run's ``config.yml`` has an ``env_wrapper`` of
            :class:`~bubblerob_env.wrappers.LaserPooling` is fed the env's scan min-pooled the
            same way (:class:`PooledPolicy`; ONNX exports do it inside the graph).
        env: The env (or a wrapper of it) the policy will act in: its action type, speed limits
            and laser geometry shape the built-in controllers' actions, and a trained policy is
            checked against the env it was trained for.
        seed: Seed of the ``random`` policy.

    Raises:
        ValueError: For an unknown name or a file that is not a policy.
        PolicyEnvMismatchError: (a ``ValueError``) when a trained policy's env (action type,
            laser rays, camera) differs from ``env``.
    """
    name = str(name_or_path)
    space, layout = (None, None) if env is None else dict_view(env, name)
    policy = _load(name, env, space, seed)
    if layout is None or not _takes_dict(policy):
        return policy
    return FlatObservationPolicy(policy, layout)


def _takes_dict(policy: Policy) -> bool:
    """False for an SB3 model trained on ``obs_mode="flat"`` observations: it takes them as is."""
    model = getattr(policy, "model", None)
    return model is None or isinstance(model.observation_space, gym.spaces.Dict)


def _load(
    name: str, env: gym.Env[Any, Any] | None, space: gym.spaces.Dict | None, seed: int
) -> Policy:
    """The policy ``name`` for ``env``, whose (``Dict``) observation space is ``space``."""
    if name in SHIPPED_POLICIES:
        return _load_onnx(SHIPPED_POLICIES[name], env, name, space)
    if name in BUILTIN_POLICIES:
        return _builtin(name, _unwrap(env), space, seed)
    path = Path(name)
    if path.suffix in (".zip", ".onnx"):
        if not path.is_file():
            raise ValueError(f"policy file {path} does not exist")
        if path.suffix == ".onnx":
            return _load_onnx(path, env, name, space)
        return _load_sb3(path, env, name, space)
    raise ValueError(
        f"unknown policy {name!r}: use one of {[*BUILTIN_POLICIES, *SHIPPED_POLICIES]} "
        "or a path to an exported .onnx or an SB3 .zip"
    )


def _builtin(name: str, base: BubbleRobEnv, space: gym.spaces.Dict | None, seed: int) -> Policy:
    # Every built-in reads proximity (a batch's size too); the laser policy, the whole scan.
    needed: dict[str, tuple[int, ...] | None] = {"proximity": (1,)}
    if name == "laser":
        if base.laser_spec is None:
            raise ValueError("the laser policy needs an env with a laser (laser_num_rays > 0)")
        needed["laser"] = (base.laser_spec.num_rays,)
    if space is not None:
        check_observations(name, needed, space)
    mapper = ActionMapper(
        base.drive, base.action_type, base.max_linear_speed, base.max_angular_speed
    )
    if name == "reactive":
        return ReactivePolicy(mapper, base.proximity_spec.trigger_distance, dt=base.dt)
    if name == "laser" and base.laser_spec is not None:
        return LaserPolicy.for_robot(mapper, base.laser_spec, base.robot.radius)
    return RandomPolicy(mapper, seed)


def _load_onnx(
    path: Path, env: gym.Env[Any, Any] | None, name: str, space: gym.spaces.Dict | None
) -> Policy:
    from policies.onnx_policy import OnnxPolicy

    policy = OnnxPolicy(path)
    trained = policy.metadata.get("env")
    if env is not None and trained is not None:
        check_env(name, trained, env, policy.metadata.get("env_kwargs"))
    if space is not None:
        _check_exact_keys(name, list(policy.input_names), space)
        check_observations(name, policy.observation_shapes, space)
    residual = policy.metadata.get("residual")
    if residual is None:
        return policy
    return _on_gap_follower(policy, env, space, float(residual["scale"]))


def _on_gap_follower(
    learnt: Policy, env: gym.Env[Any, Any] | None, space: gym.spaces.Dict | None, scale: float
) -> Policy:
    """``learnt``, a residual trained on the gap follower, with the gap follower for ``env``."""
    from policies.residual import ResidualPolicy

    return ResidualPolicy(learnt, _builtin("laser", _unwrap(env), space, 0), scale)


def _check_exact_keys(name: str, keys: list[str], space: gym.spaces.Dict) -> None:
    """A trained model takes exactly the env's keys: another set means another env."""
    if sorted(keys) != sorted(space.spaces):
        raise PolicyEnvMismatchError(
            f"policy {name!r} takes observation keys {sorted(keys)}, "
            f"but this env gives {sorted(space.spaces)}"
        )


class NormalizedPolicy:
    """An SB3 model whose observations are normalised with its training statistics first."""

    def __init__(self, model: Any, normalizer: Any) -> None:
        self.model = model
        self.normalizer = normalizer

    def predict(
        self,
        observation: Any,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> Any:
        """SB3's ``predict`` on the normalised observation."""
        normalized = self.normalizer.normalize_obs(observation)
        return self.model.predict(normalized, state, episode_start, deterministic)

    def reset(self) -> None:
        """Nothing to forget: the model is stateless."""


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


class _SB3Policy:
    """An SB3 model with ``reset`` (the ``Policy`` protocol)."""

    def __init__(self, model: Any) -> None:
        self.model = model

    def predict(
        self,
        observation: Any,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> Any:
        """SB3's ``predict``."""
        return self.model.predict(observation, state, episode_start, deterministic)

    def reset(self) -> None:
        """Nothing to forget: the model is stateless."""


def sb3_algorithm(path: Path) -> str:
    """``"PPO"`` or ``"SAC"``: which algorithm saved the SB3 model ``path``."""
    with zipfile.ZipFile(path) as archive:
        data = archive.read("data").decode() if "data" in archive.namelist() else ""
    if not data:
        raise ValueError(f"{path} is not a stable-baselines3 model (no 'data' entry)")
    policy_class = json.loads(data).get("policy_class", {})
    module = policy_class.get("__module__", "") if isinstance(policy_class, dict) else ""
    return (
        "SAC" if module.startswith("stable_baselines3.sac") or '"log_ent_coef"' in data else "PPO"
    )


def _recorded_env_kwargs(path: Path) -> dict[str, Any] | None:
    """The ``env_kwargs`` of the run's ``config.yml`` beside the model, if there is one."""
    config = _recorded_config(path)
    return None if config is None else dict(config.get("env_kwargs") or {})


def _recorded_config(path: Path) -> dict[str, Any] | None:
    """The hyperparameters in the run's ``config.yml`` beside the model, if there is one."""
    config = path.with_name("config.yml")
    if not config.is_file():
        return None
    import yaml

    table = yaml.safe_load(config.read_text()) or {}
    if not isinstance(table, dict) or len(table) != 1:
        return None
    (entry,) = table.values()
    return dict(entry or {})


def recorded_pooling(path: Path) -> list[tuple[str, int]]:
    """The laser pooling (``env_wrapper``) of the run's ``config.yml`` beside the model.

    ``[(key, pool), ...]``, empty without a config or an ``env_wrapper``; ``ValueError`` for a
    wrapper other than :class:`~bubblerob_env.wrappers.LaserPooling`.
    """
    config = _recorded_config(path)
    return [] if config is None else laser_pooling(config.get("env_wrapper"))


def _pooled_shape(shape: tuple[int, ...], key: str, pooling: list[tuple[str, int]]) -> Any:
    for pooled_key, size in pooling:
        if pooled_key == key:
            if not shape or shape[-1] % size:
                return shape  # the shape check below reports the mismatch
            shape = (*shape[:-1], shape[-1] // size)
    return shape


def _load_sb3(
    path: Path,
    env: gym.Env[Any, Any] | None = None,
    name: str = "",
    space: gym.spaces.Dict | None = None,
) -> Policy:
    import pickle

    try:
        from stable_baselines3 import PPO, SAC  # imported here: SB3 pulls in torch
    except ModuleNotFoundError:
        raise SystemExit(
            f"loading the SB3 model {path} needs the [train] extra: pip install 'bubblerob[train]' "
            "(or export it with python -m policies.export_onnx and load the .onnx)"
        ) from None

    config = _recorded_config(path) or {}
    if config.get("frame_stack"):
        raise ValueError(
            f"{path} was trained on {config['frame_stack']} stacked frames (frame_stack); "
            "load_policy runs policies of single observations only"
        )
    model: Any = (SAC if sb3_algorithm(path) == "SAC" else PPO).load(path, device="cpu")
    pooling = recorded_pooling(path)
    if env is not None and space is not None:
        kwargs = _recorded_env_kwargs(path)
        if kwargs is not None:
            trained_env = gym.make("BubbleRob-v0", **kwargs)
            check_env(name or str(path), env_signature(trained_env), env, kwargs)
            trained_env.close()
        _check_sb3_spaces(name or str(path), model.observation_space, env, space, pooling)
    stats = path.with_name(path.stem + NORMALIZATION_SUFFIX)
    policy: Policy
    if not stats.is_file():
        policy = _SB3Policy(model)
    else:
        with stats.open("rb") as handle:
            normalizer = pickle.load(handle)  # noqa: S301 - our own training output
        normalizer.training = False
        policy = NormalizedPolicy(model, normalizer)
    if pooling:
        policy = PooledPolicy(policy, pooling)
    scale = residual_scale(config.get("env_wrapper"))
    return policy if scale is None else _on_gap_follower(policy, env, space, scale)


def _check_sb3_spaces(
    name: str,
    trained: gym.Space[Any],
    env: gym.Env[Any, Any],
    space: gym.spaces.Dict,
    pooling: list[tuple[str, int]],
) -> None:
    """The model's observation space against the env's (its ``Dict``, after laser pooling)."""
    if not isinstance(trained, gym.spaces.Dict):  # trained on obs_mode="flat": fed as it is
        if trained != env.observation_space:
            raise PolicyEnvMismatchError(
                f"policy {name} was trained on flat observations of shape {trained.shape}, but "
                f"this env gives {type(env.observation_space).__name__} observations of shape "
                f"{env.observation_space.shape}: make the env with obs_mode='flat' as in training"
            )
        return
    _check_exact_keys(name, list(trained.spaces), space)
    for key, trained_space in trained.spaces.items():
        given = _pooled_shape(tuple(space[key].shape or ()), key, pooling)
        if given != trained_space.shape:
            pooled = " after its laser pooling" if given != space[key].shape else ""
            raise PolicyEnvMismatchError(
                f"policy {name} takes {key} of shape {trained_space.shape}, "
                f"but this env gives {space[key].shape}{pooled}"
            )
