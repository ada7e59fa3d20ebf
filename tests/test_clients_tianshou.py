"""Tianshou's high-level API on ``obs_mode="flat"`` (issue #22, item 1), as its docs use it.

Tianshou is not a dependency of the project (it pins its own pandas, h5py and torch ranges), so
this runs where it is installed: ``make test-clients`` makes that venv (``.venv-clients``) and
runs the client tests in it; elsewhere it skips and says so.
"""

from __future__ import annotations

import gymnasium as gym
import pytest

import bubblerob_env  # noqa: F401 - registers BubbleRob-v0 for Tianshou's gym.make

pytest.importorskip(
    "tianshou",
    reason="Tianshou is not installed with the project: `make test-clients` runs this test "
    "in its own venv (.venv-clients)",
)


def test_tianshou_high_level_ppo_trains_and_tests_on_flat_observations(tmp_path):
    from tianshou.highlevel.config import OnPolicyTrainingConfig
    from tianshou.highlevel.env import EnvFactoryRegistered, VectorEnvType
    from tianshou.highlevel.experiment import ExperimentConfig, PPOExperimentBuilder

    # Tianshou's MuJoCo example, cut to one short epoch: EnvFactoryRegistered makes the env by id
    # with gym.make keyword arguments; its default actor and critic are MLPs on a flat Box.
    env_factory = EnvFactoryRegistered(
        task="BubbleRob-v0",
        venv_type=VectorEnvType.DUMMY,
        obs_mode="flat",
        max_episode_steps=40,
    )
    experiment = PPOExperimentBuilder(
        env_factory,
        ExperimentConfig(
            seed=0, device="cpu", watch=False, persistence_base_dir=str(tmp_path / "log")
        ),
        OnPolicyTrainingConfig(
            max_epochs=1,
            epoch_num_steps=160,
            num_training_envs=2,
            num_test_envs=2,
            test_step_num_episodes=2,
            buffer_size=160,
            collection_step_num_env_steps=80,
            batch_size=40,
        ),
    ).build()
    result = experiment.run()
    stats = result.trainer_result
    assert stats is not None
    assert stats.update_step >= 1 and stats.train_step >= 160
    assert stats.test_episode >= 2 and stats.best_reward is not None
    flat = gym.make("BubbleRob-v0", obs_mode="flat").observation_space
    assert result.world.envs.get_observation_space() == flat
