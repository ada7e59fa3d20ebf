"""The real training entry point, for a few hundred steps, and what a run leaves behind."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

from policies import load_policy
from policies.residual import ResidualPolicy
from policies.sb3_policy import NormalizedPolicy, PooledPolicy
from train import load_hyperparams

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_training_script_runs_and_saves_a_reproducible_run(tmp_path, algo):
    out = tmp_path / algo
    command = [
        sys.executable,
        "-m",
        "train",
        "--algo",
        algo,
        "--env",
        "BubbleRob-v0",
        "--timesteps",
        "256",
        "--n-envs",
        "2" if algo == "ppo" else "1",
        "--seed",
        "3",
        "--eval-freq",
        "128",
        "--eval-episodes",
        "1",
        "--out",
        str(out),
    ]
    if algo == "ppo":
        command += ["--set", "n_steps=64", "--set", "batch_size=32", "--set", "normalize=true"]
    else:
        command += ["--set", "learning_starts=64", "--set", "buffer_size=1000"]
    command.append("--no-progress")
    result = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    for name in (
        "model.zip",
        "best_model.zip",
        "config.yml",
        "command.txt",
        "versions.json",
        "evaluations.npz",
        "settings.json",
    ):
        assert (out / name).is_file(), name
    assert list((out / "tb").iterdir()), "no TensorBoard logs"
    config = yaml.safe_load((out / "config.yml").read_text())["BubbleRob-v0"]
    assert config["seed"] == 3
    assert config["n_timesteps"] == 256
    assert config["batch_size"] == 32 if algo == "ppo" else config["buffer_size"] == 1000
    assert "--algo " + algo in (out / "command.txt").read_text()
    if algo == "ppo":  # trained with normalize: true, its statistics travel with the model
        assert config["normalize"] is True
        assert (out / "model_vecnormalize.pkl").is_file()
        residual = load_policy(out / "model.zip")
        # ppo.yml's env_wrapper: a correction to the gap follower (scale 0.5), whose network
        # reads the min-pooled scan: the policy pools, then normalises.
        assert isinstance(residual, ResidualPolicy) and residual.scale == 0.5
        policy = residual.learnt
        assert isinstance(policy, PooledPolicy) and policy.pooling == [("laser", 10)]
        assert isinstance(policy.policy, NormalizedPolicy)
        obs, _ = gym.make("BubbleRob-v0").reset(seed=0)
        pooled = policy.pool(obs)
        assert pooled["laser"].shape == (36,)
        normalized = policy.policy.normalizer.normalize_obs(pooled)
        assert abs(float(normalized["laser"].mean())) < abs(float(pooled["laser"].mean()))
        assert policy.predict(obs)[0].shape == (2,)


def test_trained_model_loads_as_a_policy(tmp_path):
    import gymnasium as gym
    from stable_baselines3 import PPO

    from policies import load_policy

    env = gym.make("BubbleRob-v0")
    model = PPO("MultiInputPolicy", env, n_steps=32, batch_size=16, seed=0, device="cpu")
    model.save(tmp_path / "tiny.zip")
    policy = load_policy(tmp_path / "tiny.zip")
    obs, _ = env.reset(seed=0)
    action, _ = policy.predict(obs, deterministic=True)
    assert env.action_space.contains(action.astype("float32"))


def test_hyperparameters_are_plain_data_for_every_algo():
    for algo in ("ppo", "sac"):
        params = load_hyperparams(algo, "BubbleRob-v0")
        assert params["policy"] == "MultiInputPolicy"
        assert isinstance(params["n_timesteps"], int)


def test_unknown_env_id_names_the_known_ones():
    with pytest.raises(ValueError, match=r"no ppo hyperparameters for 'Nope-v0'.*BubbleRob-v0"):
        load_hyperparams("ppo", "Nope-v0")


def test_best_model_is_the_safest_then_the_highest_return(tmp_path):
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import EvalCallback
    from stable_baselines3.common.env_util import make_vec_env

    from train.validation import keep_best_model

    envs = make_vec_env("BubbleRob-v0", n_envs=1, seed=0)
    model = PPO("MultiInputPolicy", envs, n_steps=64, batch_size=64, seed=0, device="cpu")
    keep = keep_best_model(tmp_path)
    evaluation = EvalCallback(envs, callback_after_eval=keep)
    evaluation.init_callback(model)
    best = tmp_path / "best_model.zip"
    saved = []
    # (successful episodes out of 10, mean return) of successive evaluations: success comes first
    for successes, mean_return in [(9, 50.0), (8, 500.0), (10, 20.0), (10, 10.0), (10, 30.0)]:
        evaluation.evaluations_successes.append([True] * successes + [False] * (10 - successes))
        evaluation.last_mean_reward = mean_return
        keep.on_step()
        saved.append(best.exists())
        best.unlink(missing_ok=True)
    assert saved == [True, False, True, False, True]


def test_hyperparameter_files_hold_only_rl_zoo3_keys():
    # rl_zoo3 passes unknown keys to the algorithm, which rejects them: the project's own
    # settings are command-line options (--vec-env, --torch-threads).
    for algo in ("ppo", "sac"):
        params = load_hyperparams(algo, "BubbleRob-v0")
        assert not {"vec_env", "torch_threads"} & set(params), algo


def test_project_settings_in_the_yaml_are_refused_with_the_option_to_use(tmp_path):
    from train import train

    with pytest.raises(ValueError, match=r"'vec_env' is not an rl_zoo3 hyperparameter.*--vec-env"):
        train("ppo", "BubbleRob-v0", tmp_path, overrides={"vec_env": "dummy"})


# Keys rl_zoo3 (2.9) reads itself from a hyperparameter entry; every other key goes to the
# algorithm's constructor, which rejects what it does not know.
RL_ZOO3_KEYS = {
    "policy",
    "n_timesteps",
    "n_envs",
    "normalize",
    "env_kwargs",
    "env_wrapper",
    "frame_stack",
    "callback",
    "vec_env_wrapper",
    "monitor_kwargs",
    "noise_type",
    "noise_std",
    "policy_kwargs",
}


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_every_yaml_key_is_read_by_rl_zoo3_or_the_algorithm(algo):
    import inspect

    from stable_baselines3 import PPO, SAC

    accepted = set(inspect.signature({"ppo": PPO, "sac": SAC}[algo].__init__).parameters)
    params = load_hyperparams(algo, "BubbleRob-v0")
    unknown = set(params) - RL_ZOO3_KEYS - accepted
    assert not unknown, f"rl_zoo3 would pass {unknown} to {algo.upper()}()"
    for key, value in params.items():  # rl_zoo3's schedules: lin_<float>
        if isinstance(value, str) and key not in ("policy",):
            assert value.startswith("lin_") and float(value[4:]) > 0, key


def test_rl_zoo3_trains_from_the_yaml_as_it_is(tmp_path):
    # rl_zoo3 is not in any extra (it pins pillow < 12 through moviepy); where it is installed,
    # it trains from train/hyperparams/ppo.yml as it is.
    pytest.importorskip("rl_zoo3")
    command = [
        sys.executable,
        "-m",
        "rl_zoo3.train",
        "--algo",
        "ppo",
        "--env",
        "BubbleRob-v0",
        "--gym-packages",
        "bubblerob_env",
        "-conf",
        str(ROOT / "train" / "hyperparams" / "ppo.yml"),
        "-n",
        "256",
        "--eval-freq",
        "-1",
        "-f",
        str(tmp_path),
        "--seed",
        "0",
        "--hyperparams",
        "n_envs:1",
        "n_steps:128",
        "batch_size:64",
    ]
    result = subprocess.run(command, capture_output=True, text=True, timeout=600, check=False)
    assert result.returncode == 0, result.stderr[-3000:]
    assert list(tmp_path.glob("ppo/BubbleRob-v0_*/BubbleRob-v0.zip"))


def test_obstacle_curriculum_grows_the_arenas_obstacles():
    # rl-zoo's ``callback`` key names train.callbacks.ObstacleCurriculum: the layouts the training
    # envs draw (counted from each env's own layout) start empty and end at the env's own range.
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.env_util import make_vec_env

    from train.zoo import configured_callbacks

    class CountObstacles(BaseCallback):
        counts: list[list[int]] = []

        def _on_rollout_start(self) -> None:
            self.counts.append(
                [len(env.unwrapped.layout.obstacles) for env in self.training_env.envs]
            )

        def _on_step(self) -> bool:
            return True

    envs = make_vec_env("BubbleRob-v0", n_envs=4, seed=0, env_kwargs={"max_episode_steps": 8})
    (curriculum,) = configured_callbacks(
        [{"train.callbacks.ObstacleCurriculum": {"start": [0, 0], "ramp_fraction": 0.5}}]
    )
    model = PPO("MultiInputPolicy", envs, n_steps=16, batch_size=64, n_epochs=1, seed=0)
    probe = CountObstacles()
    model.learn(16 * 4 * 10, callback=[curriculum, probe])
    # Rollouts of 16 steps reset every env twice: the second rollout shows the first's range.
    assert max(probe.counts[1]) == 0
    assert all(4 <= count <= 10 for count in probe.counts[-1]), probe.counts
    assert envs.get_attr("num_obstacles") == [(4, 10)] * 4
    assert curriculum.range_at(0.25) == (2, 5)


def test_curriculum_and_frame_stack_train_and_load_refuses_stacked_models(tmp_path):
    from policies import load_policy
    from train import train

    overrides = {
        "n_steps": 64,
        "batch_size": 64,
        "frame_stack": 2,
        "callback": [{"train.callbacks.ObstacleCurriculum": {"start": [1, 2]}}],
    }
    final = train(
        "ppo",
        "BubbleRob-v0",
        tmp_path,
        timesteps=512,
        n_envs=2,
        eval_freq=256,
        eval_episodes=1,
        progress_bar=False,
        overrides=overrides,
    )
    # The final model's VecNormalize statistics are saved from under the VecFrameStack.
    assert (tmp_path / "model_vecnormalize.pkl").is_file()
    with pytest.raises(ValueError, match="trained on 2 stacked frames"):
        load_policy(str(final))


def test_camera_only_training_evaluates_like_it_trains(tmp_path):
    # SB3 transposes the camera's HWC images for the policy; the evaluation env gets the same
    # wrapper, so EvalCallback does not warn and VecNormalize syncs along the same chain.
    import warnings

    from train import train

    overrides = {
        "n_steps": 32,
        "batch_size": 64,
        "n_epochs": 1,
        "env_wrapper": None,
        "normalize": True,  # the vectors only: SB3 scales and transposes the image itself
        "env_kwargs": {"camera": True, "laser_num_rays": 0, "camera_width": 64,
                       "camera_height": 64, "max_episode_steps": 16},
    }  # fmt: skip
    with warnings.catch_warnings():
        warnings.filterwarnings("error", message="Training and eval env are not of the same type")
        final = train("ppo", "BubbleRob-v0", tmp_path, timesteps=128, n_envs=2, eval_freq=64,
                      eval_episodes=1, progress_bar=False, overrides=overrides)  # fmt: skip
    assert final.is_file() and (tmp_path / "evaluations.npz").is_file()
    import pickle

    with (tmp_path / "model_vecnormalize.pkl").open("rb") as handle:
        normalizer = pickle.load(handle)
    assert sorted(normalizer.norm_obs_keys) == ["proximity", "velocity"]


def test_every_evaluation_runs_the_same_validation_seeds():
    # The eval batch is reset to validation seeds 1000, 1001 before each evaluation: its first
    # observations equal gym.make's from those seeds, at the first evaluation and the second.
    import gymnasium as gym
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.logger import configure
    from stable_baselines3.common.vec_env import VecEnvWrapper

    from policies.protocol import VALIDATION
    from train.validation import validation_evaluation

    class FirstObservations(VecEnvWrapper):
        def __init__(self, venv):
            super().__init__(venv)
            self.resets = []

        def reset(self):
            obs = self.venv.reset()
            self.resets.append(obs["laser"].copy())
            return obs

        def step_wait(self):
            return self.venv.step_wait()

    kwargs = {"max_episode_steps": 5}
    eval_env = FirstObservations(make_vec_env("BubbleRob-v0", n_envs=2, seed=0, env_kwargs=kwargs))
    model = PPO("MultiInputPolicy", make_vec_env("BubbleRob-v0", n_envs=1, seed=0), n_steps=64,
                batch_size=64, seed=0, device="cpu")  # fmt: skip
    model.set_logger(configure(None, []))
    evaluation = validation_evaluation(eval_env, n_eval_episodes=2, eval_freq=1, verbose=0)
    evaluation.init_callback(model)
    evaluation.on_step()
    evaluation.on_step()
    expected = [
        gym.make("BubbleRob-v0").reset(seed=VALIDATION.start + i)[0]["laser"] for i in (0, 1)
    ]
    assert len(eval_env.resets) == 2
    for first in eval_env.resets:
        np.testing.assert_array_equal(first, np.stack(expected))
    with pytest.raises(ValueError, match="one eval env per evaluation episode"):
        validation_evaluation(eval_env, n_eval_episodes=3, eval_freq=1)


def test_training_seeds_stay_below_the_validation_seeds():
    from train.validation import check_training_seeds

    check_training_seeds(992, 8)
    with pytest.raises(ValueError, match=r"training seeds are 0-999.*--seed from 0 to 992"):
        check_training_seeds(993, 8)


@pytest.mark.parametrize("at_start", [False, True])
def test_a_warm_started_model_is_evaluated_before_the_first_update(tmp_path, at_start):
    # With at_start (a warm start ran: the trainer passes it for ImitationWarmStart), the first
    # step evaluates too, then every eval_freq-th as before; the evaluations' timesteps say when.
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.logger import configure

    from train.validation import validation_evaluation

    kwargs = {"max_episode_steps": 5}
    eval_env = make_vec_env("BubbleRob-v0", n_envs=2, seed=0, env_kwargs=kwargs)
    model = PPO("MultiInputPolicy", make_vec_env("BubbleRob-v0", n_envs=1, seed=0), n_steps=64,
                batch_size=64, seed=0, device="cpu")  # fmt: skip
    model.set_logger(configure(None, []))
    evaluation = validation_evaluation(
        eval_env, at_start=at_start, n_eval_episodes=2, eval_freq=3, verbose=0, log_path=tmp_path
    )
    evaluation.init_callback(model)
    for step in range(1, 7):
        model.num_timesteps = step
        evaluation.on_step()
    assert evaluation.evaluations_timesteps == ([1, 3, 6] if at_start else [3, 6])
    assert evaluation.n_calls == 6
