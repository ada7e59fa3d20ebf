"""Training speed: time to 90% success with the shipped PPO config, and SB3 throughput.

Usage: ``python bench/train_speed.py [--max-steps N] [--quick]``

Part 1 trains PPO with ``train/hyperparams/ppo.yml`` (its ``env_kwargs`` reward and its
``env_wrapper`` too, seed 0) and evaluates the deterministic policy on 20 held-out episodes every
``--eval-every`` steps; it reports the env steps and wall time at which the success rate (time
limit reached without a collision) first reaches 90%.
Part 2 measures SB3 PPO throughput (env steps/s including updates) with 1 and 2 envs, in-process
(DummyVecEnv) and in subprocesses (SubprocVecEnv), and 8 envs in-process and as the native batch
(``train.sb3_vec``, ``--vec-env batched`` for part 1: it gives the same episodes, so the same
policy after the same steps, and only the wall time differs), beside the same PPO settings on
Gymnasium's ``HalfCheetah-v5`` measured in the same run as the anchor; the ratio column is relative
to it.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import time
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecNormalize

import bubblerob_env  # noqa: F401  (registers BubbleRob-v0)
from train.envs import batched_envs
from train.zoo import load_hyperparams, schedules, wrapper_class

ALGO_KEYS = (
    "n_steps",
    "batch_size",
    "n_epochs",
    "learning_rate",
    "gamma",
    "gae_lambda",
    "clip_range",
    "ent_coef",
    "policy_kwargs",
)


class StopAtSuccess(BaseCallback):
    """Evaluates every ``every`` steps; stops training once the success rate reaches ``target``."""

    def __init__(self, every: int, episodes: int, target: float, wrap: Any = None) -> None:
        super().__init__()
        self.wrap = wrap  # the config's env_wrapper (LaserPooling): the policy sees its output
        self.every, self.episodes, self.target = every, episodes, target
        self.start = time.perf_counter()
        self.next_eval = every
        self.history: list[tuple[int, float, float]] = []
        self.reached: tuple[int, float] | None = None

    def _success_rate(self) -> float:
        env: Any = gym.make("BubbleRob-v0")
        if self.wrap is not None:
            env = self.wrap(env)
        normalizer = self.model.get_vec_normalize_env()
        successes = 0
        for episode in range(self.episodes):
            obs, _ = env.reset(seed=2_000_000 + episode)
            while True:
                if normalizer is not None:
                    obs = normalizer.normalize_obs(obs)
                action, _ = self.model.predict(obs, deterministic=True)
                obs, _, terminated, truncated, info = env.step(action)
                if terminated or truncated:
                    successes += bool(info["is_success"])
                    break
        return successes / self.episodes

    def _on_step(self) -> bool:
        if self.num_timesteps < self.next_eval:
            return True
        self.next_eval += self.every
        rate = self._success_rate()
        elapsed = time.perf_counter() - self.start
        self.history.append((self.num_timesteps, elapsed, rate))
        print(f"  {self.num_timesteps:>8} steps  {elapsed:7.1f} s  success {rate:.0%}", flush=True)
        if rate >= self.target:
            self.reached = (self.num_timesteps, elapsed)
            return False
        return True


def _training_envs(
    n_envs: int, vec_env: str, env_kwargs: dict[str, Any] | None = None, env_wrapper: Any = None
) -> Any:
    """``n_envs`` BubbleRobs seeded 0, 1, ...: SB3's DummyVecEnv, or the native batch."""
    if vec_env == "batched":
        return batched_envs("BubbleRob-v0", n_envs, 0, dict(env_kwargs or {}), env_wrapper)
    return make_vec_env(
        "BubbleRob-v0",
        n_envs=n_envs,
        seed=0,
        vec_env_cls=DummyVecEnv,
        env_kwargs=env_kwargs,
        wrapper_class=wrapper_class(env_wrapper),
    )


def time_to_success(
    max_steps: int, every: int, episodes: int, vec_env: str = "dummy"
) -> StopAtSuccess:
    config = load_hyperparams("ppo", "BubbleRob-v0")
    torch.set_num_threads(int(config.get("torch_threads", 1)))
    # The shipped training setup: the config's reward (env_kwargs) and observation wrapper.
    wrap = wrapper_class(config.get("env_wrapper"))
    envs: Any = _training_envs(
        int(config["n_envs"]), vec_env, config.get("env_kwargs"), config.get("env_wrapper")
    )
    if config.get("normalize"):
        envs = VecNormalize(envs, gamma=float(config["gamma"]))
    kwargs = schedules({k: config[k] for k in ALGO_KEYS if k in config})
    model = PPO(config["policy"], envs, seed=0, device="cpu", verbose=0, **kwargs)
    callback = StopAtSuccess(every, episodes, 0.9, wrap)
    model.learn(min(max_steps, int(config["n_timesteps"])), callback=callback)
    return callback


def throughput(env_id: str, n_envs: int, vec_cls: type | None, steps: int, rollout: int) -> float:
    """PPO env steps/s including updates; ``vec_cls`` None: the native batch."""
    config = load_hyperparams("ppo", "BubbleRob-v0")
    policy = "MultiInputPolicy" if env_id.startswith("BubbleRob") else "MlpPolicy"
    envs = (
        _training_envs(n_envs, "batched")
        if vec_cls is None
        else make_vec_env(env_id, n_envs=n_envs, seed=0, vec_env_cls=vec_cls)
    )
    n_steps = max(16, rollout // n_envs)  # the same samples per update for every row
    model = PPO(
        policy,
        envs,
        n_steps=n_steps,
        batch_size=int(config["batch_size"]),
        n_epochs=int(config["n_epochs"]),
        policy_kwargs=config["policy_kwargs"],
        seed=0,
        device="cpu",
        verbose=0,
    )
    model.learn(n_steps * n_envs)  # warm-up: one rollout and update
    start = time.perf_counter()
    model.learn(steps, reset_num_timesteps=False)
    rate = steps / (time.perf_counter() - start)
    envs.close()
    return rate


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-steps", type=int, default=400_000)
    parser.add_argument("--eval-every", type=int, default=25_000)
    parser.add_argument("--eval-episodes", type=int, default=20)
    parser.add_argument("--throughput-steps", type=int, default=16_384)
    parser.add_argument("--quick", action="store_true", help="smoke test: tiny budgets")
    parser.add_argument(
        "--vec-env",
        choices=("dummy", "batched"),
        default="dummy",
        help="training envs of part 1: SB3's DummyVecEnv or the native batch (same episodes)",
    )
    args = parser.parse_args()
    if args.quick:
        args.max_steps, args.eval_every, args.eval_episodes = 4096, 2048, 1
        args.throughput_steps = 512
    config = load_hyperparams("ppo", "BubbleRob-v0")
    rollout = 128 if args.quick else int(config["n_steps"]) * int(config["n_envs"])
    torch.set_num_threads(1)
    wall = time.perf_counter()
    print(f"time to 90% success (shipped PPO config, seed 0, {args.vec_env} envs):")
    callback = time_to_success(args.max_steps, args.eval_every, args.eval_episodes, args.vec_env)
    rows = []
    for label, env_id, n_envs, vec_cls in (
        ("HalfCheetah-v5, 1 env (anchor)", "HalfCheetah-v5", 1, DummyVecEnv),
        ("BubbleRob-v0, 1 env", "BubbleRob-v0", 1, DummyVecEnv),
        ("BubbleRob-v0, 2 envs, DummyVecEnv", "BubbleRob-v0", 2, DummyVecEnv),
        ("BubbleRob-v0, 2 envs, SubprocVecEnv", "BubbleRob-v0", 2, SubprocVecEnv),
        ("BubbleRob-v0, 8 envs, DummyVecEnv", "BubbleRob-v0", 8, DummyVecEnv),
        ("BubbleRob-v0, 8 envs, native batch", "BubbleRob-v0", 8, None),
    ):
        rows.append((label, throughput(env_id, n_envs, vec_cls, args.throughput_steps, rollout)))
    anchor = rows[0][1]
    print()
    print(f"{'configuration':<40} {'steps/s':>8} {'x anchor':>9}")
    print("-" * 59)
    for label, rate in rows:
        print(f"{label:<40} {rate:>8.0f} {rate / anchor:>9.2f}")
    if callback.reached:
        steps, seconds = callback.reached
        print(f"reached 90% success after {steps} env steps, {seconds:.0f} s wall time")
    else:
        print(f"did not reach 90% success within {args.max_steps} steps")
    load = " ".join(f"{v:.2f}" for v in os.getloadavg())
    print(
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"load {load}; date {datetime.datetime.now().astimezone().isoformat(timespec='seconds')}"
    )
    print(
        f"torch {torch.__version__}, numpy {np.__version__}; bench wall time "
        f"{time.perf_counter() - wall:.0f} s"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
