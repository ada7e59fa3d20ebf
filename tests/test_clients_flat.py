"""obs_mode="flat" in other libraries' documented usage (issue #22, item 1).

CleanRL's ``ppo_continuous_action.py``: its ``make_env`` wrapper chain (FlattenObservation,
RecordEpisodeStatistics, ClipAction, NormalizeObservation, clipping, NormalizeReward) in a
``SyncVectorEnv``, and its rollout and PPO update, cut to a few iterations. RLlib's default
model and Tianshou's high-level API are not installed with the project ([ray] pins another
Gymnasium; Tianshou is not a dependency): README's "Past one machine" covers RLlib.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import bubblerob_env  # noqa: F401

torch = pytest.importorskip("torch")
nn = torch.nn


def _make_env(gamma: float):  # CleanRL's make_env, with the env's flat observations
    def thunk() -> gym.Env:
        env = gym.make("BubbleRob-v0", obs_mode="flat", max_episode_steps=40)
        env = gym.wrappers.FlattenObservation(env)
        env = gym.wrappers.RecordEpisodeStatistics(env)
        env = gym.wrappers.ClipAction(env)
        env = gym.wrappers.NormalizeObservation(env)
        env = gym.wrappers.TransformObservation(
            env, lambda obs: np.clip(obs, -10, 10), env.observation_space
        )
        env = gym.wrappers.NormalizeReward(env, gamma=gamma)
        return gym.wrappers.TransformReward(env, lambda reward: np.clip(reward, -10, 10))

    return thunk


class _Agent(nn.Module):  # CleanRL's Agent (64-unit tanh MLPs, state-independent log std)
    def __init__(self, obs_size: int, act_size: int) -> None:
        super().__init__()
        self.critic = nn.Sequential(nn.Linear(obs_size, 64), nn.Tanh(), nn.Linear(64, 1))
        self.actor_mean = nn.Sequential(nn.Linear(obs_size, 64), nn.Tanh(), nn.Linear(64, act_size))
        self.actor_logstd = nn.Parameter(torch.zeros(1, act_size))

    def get_action_and_value(self, x, action=None):  # noqa: ANN001, ANN201
        mean = self.actor_mean(x)
        dist = torch.distributions.Normal(mean, self.actor_logstd.expand_as(mean).exp())
        if action is None:
            action = dist.sample()
        return action, dist.log_prob(action).sum(1), dist.entropy().sum(1), self.critic(x)


def test_cleanrl_ppo_continuous_loop_runs_on_flat_observations():
    torch.manual_seed(0)
    num_envs, num_steps, gamma = 2, 64, 0.99
    envs = gym.vector.SyncVectorEnv([_make_env(gamma) for _ in range(num_envs)])
    assert isinstance(envs.single_observation_space, gym.spaces.Box)
    obs_size = envs.single_observation_space.shape[0]
    agent = _Agent(obs_size, envs.single_action_space.shape[0])
    optimizer = torch.optim.Adam(agent.parameters(), lr=3e-4, eps=1e-5)
    next_obs, _ = envs.reset(seed=1)
    episodes = 0
    for _ in range(2):  # iterations: rollout, then one PPO epoch
        obs = torch.zeros((num_steps, num_envs, obs_size))
        logprobs = torch.zeros((num_steps, num_envs))
        actions = torch.zeros((num_steps, num_envs, 2))
        rewards = torch.zeros((num_steps, num_envs))
        for step in range(num_steps):
            obs[step] = torch.as_tensor(next_obs, dtype=torch.float32)
            with torch.no_grad():
                action, logprob, _, _ = agent.get_action_and_value(obs[step])
            actions[step], logprobs[step] = action, logprob
            next_obs, reward, _, _, infos = envs.step(action.numpy())
            rewards[step] = torch.as_tensor(reward, dtype=torch.float32)
            if "episode" in infos:
                episodes += int(infos["_episode"].sum())
        returns = rewards.flip(0).cumsum(0).flip(0)  # the update's shape, not CleanRL's GAE
        _, newlogprob, entropy, value = agent.get_action_and_value(
            obs.reshape(-1, obs_size), actions.reshape(-1, 2)
        )
        ratio = (newlogprob - logprobs.reshape(-1)).exp()
        advantages = returns.reshape(-1) - value.view(-1).detach()
        loss = (
            -(ratio * advantages).mean()
            + 0.5 * ((value.view(-1) - returns.reshape(-1)) ** 2).mean()
        )
        loss = loss - 0.01 * entropy.mean()
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        assert torch.isfinite(loss)
    assert next_obs.shape == (num_envs, obs_size) and np.isfinite(next_obs).all()
    assert episodes >= 2  # RecordEpisodeStatistics saw the 40-step episodes end
    envs.close()
