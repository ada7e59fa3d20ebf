"""What one ``predict`` of a shipped network costs, against the env step it drives (the anchor).

The float64 computation a zip and its ONNX export share (policies/sb3_action.py) costs more than
float32's; this says how much, per single observation as ``evaluate`` and ``demo`` call it, each
in the same run as the engine's own step::

    python bench/policy_speed.py [--calls 2000] [--policy nav]

Prints one row per path (ms per call, and the ratio to one env step), the float32 paths for
reference: SB3's own ``predict`` on the zip, and onnxruntime on a float32 export written here
with the export of 2026-11-27 (the graph without the float64 cast). One thread each (torch and
onnxruntime), as evaluation runs them.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import bubblerob_env  # noqa: F401  (registers the ids)
from policies import load_policy
from policies.loading import SHIPPED_POLICIES


def per_call(function: Callable[[], Any], calls: int) -> float:
    """Milliseconds per call of ``function``, the best of three runs of ``calls`` calls."""
    best = float("inf")
    for _ in range(3):
        start = time.perf_counter()
        for _ in range(calls):
            function()
        best = min(best, (time.perf_counter() - start) / calls * 1e3)
    return best


def float32_export(zip_path: Path, out: Path) -> Path:
    """The zip's graph in float32 (the module before this round's float64 cast)."""
    import torch
    from stable_baselines3 import PPO

    model = PPO.load(zip_path, device="cpu")
    policy: Any = model.policy
    space: Any = model.observation_space
    keys = list(space.spaces)

    class Float32Actor(torch.nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.policy = policy

        def forward(self, *observations: Any) -> Any:
            obs = dict(zip(keys, observations, strict=True))
            features = self.policy.extract_features(obs, self.policy.pi_features_extractor)
            return self.policy.action_net(self.policy.mlp_extractor.forward_actor(features))

    dummy = tuple(torch.as_tensor(np.stack([space[k].sample()] * 2)) for k in keys)
    torch.onnx.export(
        Float32Actor().eval(), dummy, str(out), input_names=keys, output_names=["action"],
        dynamic_axes={**{k: {0: "batch"} for k in keys}, "action": {0: "batch"}},
        opset_version=17, dynamo=False,
    )  # fmt: skip
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=2000)
    parser.add_argument("--policy", default="nav", choices=["nav"])
    args = parser.parse_args(argv)
    import onnxruntime as ort
    import torch
    from stable_baselines3 import PPO

    torch.set_num_threads(1)
    onnx_path = SHIPPED_POLICIES[args.policy]
    zip_path = onnx_path.with_suffix(".zip")
    env = gym.make("BubbleRobNav-v0")
    obs, _ = env.reset(seed=1000)
    zero = np.zeros(2, dtype=np.float32)
    sb3 = PPO.load(zip_path, device="cpu")
    with tempfile.TemporaryDirectory() as folder:
        options = ort.SessionOptions()
        options.intra_op_num_threads = options.inter_op_num_threads = 1
        exported = float32_export(zip_path, Path(folder) / "f32.onnx")
        session = ort.InferenceSession(str(exported), options)
        keys: Any = sb3.observation_space
        feed = {k: np.asarray(obs[k], np.float32)[None] for k in keys.spaces}
        shipped, zipped = load_policy(args.policy, env), load_policy(zip_path, env)
        rows = {
            "env step (anchor)": per_call(lambda: env.step(zero), args.calls),
            "ONNX, float64 (shipped)": per_call(lambda: shipped.predict(obs), args.calls),
            "zip, float64 (load_policy)": per_call(lambda: zipped.predict(obs), args.calls),
            "ONNX, float32 (reference)": per_call(lambda: session.run(None, feed), args.calls),
            "zip, SB3's predict, float32": per_call(
                lambda: sb3.predict(obs, deterministic=True), args.calls
            ),
        }
    anchor = rows["env step (anchor)"]
    print("| path | ms per call | x env step |\n|---|--:|--:|")
    for name, ms in rows.items():
        print(f"| {name} | {ms:.3f} | {ms / anchor:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
