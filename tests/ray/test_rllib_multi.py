"""RLlib's ``ParallelPettingZooEnv`` trains one PPO policy shared by every robot (#36 item 6).

Runs where ``ray[rllib]`` and torch are installed: their own venv (``make test-clients``), as
RLlib 2.60 pins gymnasium 1.2.2; skipped elsewhere. The training runs in a child process in a
loopback-only network namespace (ray_helpers.py), on one remote env runner, so the env is built
from its registered creator in a fresh Ray worker, as users run it.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import pytest
from ray_helpers import ROOT, in_netns, need_netns

ROBOTS, ROLLOUT, ITERATIONS = 3, 120, 2

SCRIPT = """
import json, sys
import ray
from ray.rllib.algorithms.ppo import PPOConfig
from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig
from ray.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv
from ray.tune.registry import register_env

ROBOTS, ROLLOUT, ITERATIONS = (int(a) for a in sys.argv[2:5])


def make(env_config):
    import bubblerob_env

    return ParallelPettingZooEnv(bubblerob_env.parallel_env(**env_config))


def world_of(runner):
    env = runner.env.envs[0]  # the runner's vector of one multi-agent env
    while not hasattr(env, "par_env"):
        env = env.env
    return [type(env.par_env).__name__, list(env.par_env.possible_agents)]


register_env("bubblerob_multi", make)
env_config = {"num_robots": ROBOTS, "obs_mode": "flat", "max_episode_steps": 40,
              "laser_num_rays": 36}
config = (
    PPOConfig()
    .environment("bubblerob_multi", env_config=env_config)
    .multi_agent(policies={"shared"}, policy_mapping_fn=lambda agent_id, *args, **kw: "shared")
    .env_runners(num_env_runners=1, rollout_fragment_length=ROLLOUT)
    .training(train_batch_size_per_learner=ROLLOUT, minibatch_size=ROLLOUT, num_epochs=2)
    .rl_module(model_config=DefaultModelConfig(fcnet_hiddens=[32, 32]))
    .debugging(seed=0)
)
ray.init(num_cpus=2, include_dashboard=False)
algo = config.build_algo()
try:
    module = algo.get_module("shared")
    before = [p.detach().clone() for p in module.parameters()]
    runs = [algo.train() for _ in range(ITERATIONS)]
    after = list(module.parameters())
    worlds = algo.env_runner_group.foreach_env_runner(world_of, local_env_runner=False)
finally:
    algo.stop()
    ray.shutdown()
json.dump({
    "modules": sorted(runs[-1]["learners"].keys()),
    "env_steps": [r["env_runners"]["num_env_steps_sampled_lifetime"] for r in runs],
    "agent_steps": [r["env_runners"]["num_agent_steps_sampled_lifetime"] for r in runs],
    "returns": [r["env_runners"].get("episode_return_mean") for r in runs],
    "module_steps": [r["env_runners"]["num_module_steps_sampled_lifetime"] for r in runs],
    "worlds": worlds,
    "changed": any(bool((a != b).any()) for a, b in zip(after, before)),
}, open(sys.argv[1], "w"))
"""


def test_ppo_trains_one_shared_policy_on_every_robot_of_parallel_env(tmp_path: Path) -> None:
    pytest.importorskip(
        "ray.rllib",
        reason="ray[rllib] is not installed with the project: `make test-clients` runs this "
        "test in its own venv (.venv-clients)",
    )
    pytest.importorskip("torch", reason="RLlib's PPO here needs torch")
    pytest.importorskip("pettingzoo", reason="the [multi] extra is not installed")
    need_netns()
    script, result = tmp_path / "train_shared.py", tmp_path / "result.json"
    script.write_text(SCRIPT)
    argv = [sys.executable, str(script), str(result), str(ROBOTS), str(ROLLOUT), str(ITERATIONS)]
    done = in_netns(argv, timeout_s=400, cwd=ROOT)
    assert done.returncode == 0, f"{done.stdout[-3000:]}\n{done.stderr[-6000:]}"
    run = json.loads(result.read_text())
    assert "shared" in run["modules"]  # one module learned, every robot mapped to it
    agents = [f"bubblerob_{k}" for k in range(ROBOTS)]
    assert run["worlds"] == [["MultiRobotEnv", agents]]  # the remote runner's env
    # Each iteration samples at least one fragment of env steps, and every robot's steps went
    # to the one shared module: each world step moves 1..N robots.
    steps = run["env_steps"]
    assert steps[0] >= ROLLOUT and steps[1] >= steps[0] + ROLLOUT, steps
    for env_steps, per_robot, modules in zip(
        steps, run["agent_steps"], run["module_steps"], strict=True
    ):
        assert sorted(per_robot) == agents and list(modules) == ["shared"]
        assert modules["shared"] == sum(per_robot.values())
        assert env_steps <= modules["shared"] <= ROBOTS * env_steps
    assert run["changed"]  # PPO updated the shared module's weights
    assert all(r is not None and math.isfinite(r) for r in run["returns"])
