"""PPO from RLlib (new API stack) on BubbleRob-v0: 2 env runners, each stepping the native batch.

Usage: ``python -m train.rllib_ppo [--iterations 5] [--env-runners 2] [--envs-per-runner 4]``

Needs ``ray[rllib]`` and torch, in a venv of their own: ``ray[rllib]`` 2.60 pins
``gymnasium==1.2.2`` (README: Past one machine). RLlib's default model takes no ``Dict``
observations, so the env is made with ``obs_mode="flat"`` (one float32 ``Box``: laser,
proximity, velocity). Each env runner makes its envs with
``gym.make_vec("bubblerob_env:BubbleRob-v0", N, vectorization_mode="vector_entry_point")``: the
native batch, N robots stepped per call, the module form importing the package in the runner.
"""

from __future__ import annotations

from typing import Any

__all__ = ["ENV_ID", "build_config"]

ENV_ID = "bubblerob_env:BubbleRob-v0"
"""The module form: an env runner (a fresh Ray worker) imports the package before the lookup."""


def build_config(
    env_runners: int = 2,
    envs_per_runner: int = 4,
    rollout_length: int = 64,
    env_kwargs: dict[str, Any] | None = None,
    seed: int = 0,
) -> Any:
    """An RLlib ``PPOConfig``: each iteration trains on one rollout of every env of every runner."""
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig

    batch = env_runners * envs_per_runner * rollout_length
    return (
        PPOConfig()  # type: ignore[no-untyped-call]
        .environment(ENV_ID, env_config={"obs_mode": "flat", **(env_kwargs or {})})
        .env_runners(
            num_env_runners=env_runners,
            num_envs_per_env_runner=envs_per_runner,
            gym_env_vectorize_mode="vector_entry_point",
            rollout_fragment_length=rollout_length,
        )
        .training(
            train_batch_size_per_learner=batch,
            minibatch_size=min(batch, 256),
            num_epochs=4,
            lr=3e-4,
            gamma=0.995,
        )
        .rl_module(model_config=DefaultModelConfig(fcnet_hiddens=[64, 64]))
        .debugging(seed=seed)
    )
