"""Export a trained SB3 policy, with its VecNormalize statistics, to ONNX (needs the [train] extra).

``python -m policies.export_onnx`` re-exports the shipped policy: it reads
``policies/trained/ppo_bubblerob_v0.zip`` and ``ppo_bubblerob_v0_vecnormalize.pkl`` beside it, and
writes ``policies/trained/ppo_bubblerob_v0.onnx``, which ``load_policy("ppo", env)`` runs with
onnxruntime, without torch. Run it again whenever the shipped model is retrained. Any other
model: ``python -m policies.export_onnx runs/quick/best_model.zip`` (writes
``runs/quick/best_model.onnx``).

The graph follows SB3's ONNX export recipe (a ``torch.nn.Module`` around the policy, exported with
``torch.onnx.export``) and adds what ``predict(obs, deterministic=True)`` does around it:

- one input per observation key, named by the key, each ``(batch, *shape)`` float32 (uint8 for an
  image); SB3's ``CombinedExtractor`` concatenates them in the observation space's (sorted) key
  order, and the graph does the same because it runs the policy's own feature extractor;
- the laser pooling the model was trained behind (rl-zoo's ``env_wrapper`` with
  :class:`bubblerob_env.wrappers.LaserPooling` in the run's ``config.yml``): the minimum over
  each group of ``pool`` consecutive rays, so the input stays the env's full scan;
- VecNormalize's observation normalisation, in float64 as NumPy does it:
  ``clip((obs - mean) / sqrt(var + epsilon), -clip_obs, clip_obs)``, then float32;
- the deterministic action (the Gaussian's mean for PPO, SAC's squashed mean), clipped to the
  action space (PPO) or rescaled to it (SAC) as ``predict`` does, computed in float64 by the
  module the zip loader runs (:mod:`policies.sb3_action`: why float64);
- one output, ``action`` ``(batch, action_dim)`` float32.

The model's metadata (``bubblerob`` key, JSON) records the env it was trained for (env id, env
kwargs, action type, laser rays, camera), the observation keys and shapes (the env's), the
pooling baked in and the source files' SHA-256, so
``load_policy`` can refuse a mismatched env and a test can tell a stale export.
"""

from __future__ import annotations

import hashlib
import json
import pickle
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from policies.observations import env_signature
from policies.onnx_policy import METADATA_KEY
from policies.runs import (
    SHIPPED_MODEL,
    normalization_path,
    recorded_config,
    recorded_env,
    recorded_pooling,
    residual_scale,
)
from policies.sb3_policy import sb3_algorithm

__all__ = ["METADATA_KEY", "OPSET", "SHIPPED_MODEL", "export_onnx", "sha256"]

OPSET = 17


def sha256(path: Path) -> str:
    """Hex SHA-256 of a file."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _load_model(path: Path) -> Any:
    from stable_baselines3 import PPO, SAC

    return (SAC if sb3_algorithm(path) == "SAC" else PPO).load(path, device="cpu")


def _normalization_stats(normalizer: Any) -> dict[str, tuple[Any, Any, float]]:
    """VecNormalize's ``(mean, std, clip)`` of each normalised key, as float64 tensors."""
    import torch

    stats: dict[str, tuple[Any, Any, float]] = {}
    if normalizer is not None and normalizer.norm_obs:
        for key in normalizer.norm_obs_keys:
            rms = normalizer.obs_rms[key]
            mean = torch.as_tensor(np.asarray(rms.mean, dtype=np.float64))
            var = np.asarray(rms.var, dtype=np.float64)
            std = torch.as_tensor(np.sqrt(var + normalizer.epsilon))
            stats[key] = (mean, std, float(normalizer.clip_obs))
    return stats


def _model_inputs(
    keys: list[str],
    observations: Sequence[Any],
    pooling: Sequence[tuple[str, int]],
    stats: dict[str, tuple[Any, Any, float]],
) -> dict[str, Any]:
    """The env's observation tensors (in ``keys`` order) pooled and normalised as in training."""
    obs = {}
    for key, value in zip(keys, observations, strict=True):
        for pooled_key, size in pooling:
            if pooled_key == key:  # LaserPooling: min over groups of `size` rays
                value = value.unflatten(-1, (-1, size)).amin(dim=-1)
        if key in stats:
            mean, std, clip = stats[key]
            value = ((value.double() - mean) / std).clamp(-clip, clip).float()
        obs[key] = value
    return obs


def _build_module(
    model: Any, normalizer: Any, pooling: Sequence[tuple[str, int]] = ()
) -> tuple[Any, list[str]]:
    """The torch module (raw observations in key order -> action) and the key order.

    ``pooling`` (``[(key, pool), ...]``) min-pools those inputs first, as ``LaserPooling`` did in
    training: the module takes the env's full scan. The action is
    :class:`~policies.sb3_action.DeterministicActor`'s, the computation the zip loader runs, in
    float64; the graph's output is float32, as ``predict``'s.
    """
    import torch

    from policies.sb3_action import DeterministicActor

    actor = DeterministicActor(model)
    keys = list(model.observation_space.spaces)  # gymnasium sorts a Dict's keys, as SB3 does
    stats = _normalization_stats(normalizer)

    class OnnxablePolicy(torch.nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.actor = actor

        def forward(self, *observations: Any) -> Any:
            obs = _model_inputs(keys, observations, pooling, stats)
            return self.actor(obs).float()

    return OnnxablePolicy().eval(), keys


def export_onnx(model_path: Path, out: Path | None = None) -> Path:
    """Export ``model_path`` (and ``<stem>_vecnormalize.pkl`` beside it, if any) to ONNX."""
    import gymnasium as gym
    import torch

    import bubblerob_env  # noqa: F401  (registers BubbleRob-v0)

    model_path = Path(model_path)
    out = model_path.with_suffix(".onnx") if out is None else Path(out)
    model = _load_model(model_path)
    stats_path = normalization_path(model_path)
    normalizer = None
    if stats_path.is_file():
        with stats_path.open("rb") as handle:
            normalizer = pickle.load(handle)  # noqa: S301 - our own training output
    pooling = recorded_pooling(model_path)
    module, keys = _build_module(model, normalizer, pooling)
    env_id, env_kwargs = recorded_env(model_path)
    env = gym.make(env_id, **env_kwargs)
    # The graph's inputs are the env's observations (its full scan when the model was trained
    # behind LaserPooling); without pooling they equal the model's observation space.
    obs_space: Any = env.observation_space if pooling else model.observation_space
    dummy = tuple(
        torch.as_tensor(np.stack([obs_space[key].sample()] * 2)) for key in keys
    )  # a batch of 2, so the batch axis stays symbolic
    _trace(module, dummy, keys, out)
    info: dict[str, Any] = {
        "algo": type(model).__name__,
        "env_id": env_id,
        "env_kwargs": env_kwargs,
        "env": env_signature(env),
        "observation_keys": keys,
        "observation_shapes": {key: list(obs_space[key].shape) for key in keys},
        "observation_dtypes": {key: str(obs_space[key].dtype) for key in keys},
        "source": {model_path.name: sha256(model_path)}
        | ({stats_path.name: sha256(stats_path)} if normalizer is not None else {}),
    }
    if pooling:
        info["observation_pooling"] = [[key, size] for key, size in pooling]
    scale = residual_scale((recorded_config(model_path) or {}).get("env_wrapper"))
    if scale is not None:  # the graph's action is a correction to the gap follower's
        info["residual"] = {"base": "laser", "scale": scale}
    env.close()
    _write_metadata(out, info)
    return out


def _trace(module: Any, dummy: tuple[Any, ...], keys: list[str], out: Path) -> None:
    """Write ``module``'s graph, traced on ``dummy``, to ``out``: inputs ``keys``, output action."""
    import torch

    out.parent.mkdir(parents=True, exist_ok=True)
    with torch.no_grad(), warnings.catch_warnings():
        # The TorchScript exporter needs no onnxscript; the new one would give the same graph.
        warnings.simplefilter("ignore", DeprecationWarning)
        torch.onnx.export(
            module,
            dummy,
            str(out),
            input_names=keys,
            output_names=["action"],
            dynamic_axes={**{key: {0: "batch"} for key in keys}, "action": {0: "batch"}},
            opset_version=OPSET,
            dynamo=False,
        )


def _write_metadata(out: Path, info: dict[str, Any]) -> None:
    """Record ``info`` (JSON) in the ONNX file ``out`` under :data:`METADATA_KEY`; check it."""
    import onnx

    graph = onnx.load(str(out))
    graph.producer_name = "bubblerob policies.export_onnx"
    graph.producer_version = ""
    del graph.metadata_props[:]
    entry = graph.metadata_props.add()
    entry.key, entry.value = METADATA_KEY, json.dumps(info, sort_keys=True)
    onnx.checker.check_model(graph)
    onnx.save(graph, str(out))
