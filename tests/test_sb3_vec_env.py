"""The SB3 adapter against SB3's own ``make_vec_env`` (``DummyVecEnv`` over ``gym.make``): same
observations, rewards, dones and infos bit for bit, with SB3's terminal conventions."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
from stable_baselines3.common.env_checker import check_env  # noqa: E402
from stable_baselines3.common.env_util import make_vec_env  # noqa: E402

import bubblerob_env  # noqa: E402,F401
from train.sb3_vec import BubbleRobSB3VecEnv  # noqa: E402


def _same(a, b) -> bool:
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, str):
        return a == b
    return np.asarray(a).tobytes() == np.asarray(b, dtype=np.asarray(a).dtype).tobytes()


def _step_both(ours, theirs, action):
    """One step of both VecEnvs: the same observations, rewards, dones and infos, Monitor's
    ``episode`` compared by return and length (another clock); the dones and the
    ``(info, info_t)`` pairs."""
    obs, rewards, dones, infos = ours.step(action)
    obs_t, rewards_t, dones_t, infos_t = theirs.step(action)
    assert _same(obs, obs_t) and _same(rewards, rewards_t) and _same(dones, dones_t)
    for info, info_t in zip(infos, infos_t, strict=True):
        assert "episode" in info_t or "episode" not in info
        if "episode" in info_t:
            episode, episode_t = info.pop("episode"), info_t.pop("episode")
            assert (episode["r"], episode["l"]) == (episode_t["r"], episode_t["l"])
        assert _same(info, info_t)
    return dones, list(zip(infos, infos_t, strict=True))


@pytest.mark.parametrize("num_threads", [1, 2])
def test_adapter_matches_make_vec_env(num_threads):
    n, limit = 4, 30
    ours = BubbleRobSB3VecEnv(n, num_threads=num_threads, max_episode_steps=limit)
    theirs = make_vec_env("BubbleRob-v0", n_envs=n, seed=3, env_kwargs={"max_episode_steps": limit})
    ours.seed(3)
    assert _same(ours.reset(), theirs.reset())
    actions = np.random.default_rng(0).uniform(-1, 1, size=(100, n, 2)).astype(np.float32)
    actions[..., 0] = np.abs(actions[..., 0])
    dones_seen = 0
    for action in actions:
        dones, _ = _step_both(ours, theirs, action)
        dones_seen += int(dones.sum())
    assert dones_seen >= n * 3
    ours.close()
    theirs.close()


def test_adapter_reports_episodes_as_monitor():
    envs = BubbleRobSB3VecEnv(2, max_episode_steps=5)
    envs.reset()
    for _ in range(5):
        _, _, dones, infos = envs.step(np.zeros((2, 2), np.float32))
    assert dones.all() and all(info["episode"]["l"] == 5 for info in infos)
    assert all(info["is_success"] and info["TimeLimit.truncated"] for info in infos)
    assert envs.get_attr("arena_size") == [4.0, 4.0]
    # So SB3's evaluate_policy takes the returns from info["episode"], as with make_vec_env's.
    from gymnasium.wrappers import TimeLimit
    from stable_baselines3.common.monitor import Monitor

    assert envs.env_is_wrapped(Monitor) == [True, True]
    assert envs.env_is_wrapped(TimeLimit) == [False, False]
    envs.close()


def test_single_env_passes_sb3_check_env():
    import gymnasium as gym

    check_env(gym.make("BubbleRob-v0"), warn=True)


def test_train_with_the_native_batch(tmp_path):
    from train import train

    final = train(
        "ppo",
        "BubbleRob-v0",
        tmp_path,
        timesteps=256,
        n_envs=2,
        seed=3,
        eval_freq=128,
        eval_episodes=1,
        progress_bar=False,
        overrides={"n_steps": 64, "batch_size": 32},
        vec_env="batched",
    )
    assert final.is_file() and (tmp_path / "best_model.zip").is_file()
    from train.envs import native_batch

    with pytest.raises(ValueError, match="BubbleRob-v0 only"):
        native_batch("HalfCheetah-v5", 2, 0, {})


def test_batched_observation_wrappers_match_make_vec_env():
    # LaserPooling on the whole batch against SB3's make_vec_env wrapping each env: the same
    # pooled observations, terminal observations included, bit for bit.
    from bubblerob_env.wrappers import LaserPooling
    from train.envs import native_batch
    from train.sb3_vec import VecObservationWrapper
    from train.zoo import wrapper_class

    n, limit = 3, 20
    kwargs = {"max_episode_steps": limit}
    wrap = wrapper_class([{"bubblerob_env.wrappers.LaserPooling": {"pool": 10}}])
    ours = native_batch("BubbleRob-v0", n, 5, kwargs, wrap)
    assert isinstance(ours, VecObservationWrapper)
    theirs = make_vec_env(
        "BubbleRob-v0", n_envs=n, seed=5, env_kwargs=kwargs, wrapper_class=LaserPooling
    )
    assert ours.observation_space == theirs.observation_space
    assert ours.observation_space["laser"].shape == (36,)
    assert _same(ours.reset(), theirs.reset())
    actions = np.random.default_rng(1).uniform(-1, 1, size=(50, n, 2)).astype(np.float32)
    terminal_seen = 0
    for action in actions:
        _, pairs = _step_both(ours, theirs, action)  # terminal observations compared too
        for info, _ in pairs:
            if "terminal_observation" in info:
                terminal_seen += 1
                assert info["terminal_observation"]["laser"].shape == (36,)
    assert terminal_seen >= n * 2
    ours.close()
    theirs.close()


def test_batched_refuses_wrappers_that_are_not_observation_wrappers():
    from train.envs import native_batch
    from train.zoo import wrapper_class

    wrap = wrapper_class("bubblerob_env.wrappers.EpisodeSuccess")
    with pytest.raises(ValueError, match="observation wrappers only, not EpisodeSuccess"):
        native_batch("BubbleRob-v0", 2, 0, {}, wrap)
