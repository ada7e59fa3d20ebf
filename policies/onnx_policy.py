"""A trained policy exported by :mod:`policies.export_onnx`, run with onnxruntime (no torch).

:func:`load_onnx` checks the export against the env (the env it was trained for, recorded in its
metadata, and the observation keys and shapes it takes) and replays a residual on the gap
follower.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from bubblerob_env.extras import MissingExtraError
from policies.base import Policy, as_batch
from policies.observations import check_env, check_exact_keys, check_observations
from policies.residual import check_scale, on_gap_follower

__all__ = ["METADATA_KEY", "OnnxPolicy", "load_onnx", "read_metadata"]

METADATA_KEY = "bubblerob"


def _session(path: Path) -> Any:
    try:
        import onnxruntime as ort
    except ModuleNotFoundError:
        raise MissingExtraError(
            f"running {path.name} needs onnxruntime, from the [demo] extra: "
            "pip install 'bubblerob[demo]'"
        ) from None
    options = ort.SessionOptions()
    options.intra_op_num_threads = 1  # a 64x64 MLP: more threads only steal the env's CPU
    options.inter_op_num_threads = 1
    return ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])


def read_metadata(session: Any) -> dict[str, Any]:
    """The export's record (env, observation keys, sources) from an onnxruntime session."""
    text = session.get_modelmeta().custom_metadata_map.get(METADATA_KEY)
    return json.loads(text) if text else {}


class OnnxPolicy:
    """SB3's ``predict`` on an exported policy: deterministic actions, normalisation included.

    Single observations (``proximity`` of shape (1,)) give one action of shape (2,), batches of
    shape (n, ...) give (n, 2), as SB3's ``predict`` does. The policy is stateless.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.session = _session(self.path)
        self.metadata = read_metadata(self.session)
        self.input_names = [node.name for node in self.session.get_inputs()]
        self._dtypes = {
            node.name: np.uint8 if node.type == "tensor(uint8)" else np.float32
            for node in self.session.get_inputs()
        }
        shapes = self.metadata.get("observation_shapes") or {
            node.name: list(node.shape[1:]) for node in self.session.get_inputs()
        }
        self.observation_shapes = {key: tuple(shape) for key, shape in shapes.items()}
        self._input_shapes = {key: self.observation_shapes[key] for key in self.input_names}

    def predict(
        self,
        observation: dict[str, Any],
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[NDArray[np.float32], None]:
        """Action(s) for one observation or a batch; ``state`` is always None (no memory)."""
        missing = [key for key in self.input_names if key not in observation]
        if missing:
            raise ValueError(f"{self.path.name} needs observation keys {missing}")
        batch, single = as_batch(observation, self._input_shapes)
        feed = {key: value.astype(self._dtypes[key], copy=False) for key, value in batch.items()}
        (actions,) = self.session.run(["action"], feed)
        return (actions[0] if single else actions), None

    def reset(self) -> None:
        """Nothing to forget: the policy is stateless."""


def load_onnx(
    path: Path, env: gym.Env[Any, Any] | None, name: str, space: gym.spaces.Dict | None
) -> Policy:
    """The export ``path`` as a policy for ``env`` (whose ``Dict`` space is ``space``), checked.

    Fed ``Dict`` observations.
    """
    policy = OnnxPolicy(path)
    trained = policy.metadata.get("env")
    if env is not None and trained is not None:
        check_env(name, trained, env, policy.metadata.get("env_kwargs"))
    if space is not None:
        check_exact_keys(name, list(policy.input_names), space)
        check_observations(name, policy.observation_shapes, space)
    residual = policy.metadata.get("residual")
    if residual is None:
        return policy
    return on_gap_follower(policy, env, space, check_scale(residual.get("scale")))
