"""Issue #38, kind 6: a bare SB3 zip's action type, which the zip cannot tell, is said and checked.

Wheels and twist share one normalised action space, so a zip without its run's ``config.yml``
runs only where ``--action-type`` names the type and it is the env's (bubblerob_cli/action_type.py),
in every command that drives the env with a policy; ``--action-type`` beside no bare zip is
refused too. The zip here is trained on twist actions (36 rays), the env made as the test says.
"""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import pytest
from reliability_helpers import one_line, run

TWIST = '{"action_type": "twist", "laser_num_rays": 36, "max_episode_steps": 5}'
WHEELS = '{"laser_num_rays": 36, "max_episode_steps": 5}'


@pytest.fixture(scope="module")
def bare_zip(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An SB3 PPO zip made on a twist env, saved without the run's config.yml."""
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import PPO

    env = gym.make("BubbleRob-v0", action_type="twist", laser_num_rays=36)
    path = tmp_path_factory.mktemp("bare") / "twist.zip"
    PPO("MultiInputPolicy", env, n_steps=8, batch_size=8, device="cpu").save(path)
    return path


def _argv(command: str, policy: str, kwargs: str, tmp: Path) -> list[str]:
    head = {
        "evaluate": ["evaluate", "--episodes", "1"],
        "demo": ["demo", "--episodes", "1", "--no-video", "--out", str(tmp / "d")],
        "record": ["record", "--no-progress", "--out", str(tmp / "bags")],
        "node": ["node", "--steps", "3", "--master-timeout", "1"],
    }[command]
    return [*head, "--policy", policy, "--env-kwargs", kwargs]


@pytest.mark.parametrize("command", ["evaluate", "demo", "record", "node"])
def test_a_bare_zip_runs_only_with_its_action_type_said_and_the_envs(
    command: str, bare_zip: Path, tmp_path: Path
) -> None:
    # node drives the wheels only: the twist zip is refused there whatever is said
    env_type, kwargs = ("wheels", WHEELS) if command == "node" else ("twist", TWIST)
    status, _, err = run(*_argv(command, str(bare_zip), kwargs, tmp_path))
    assert status == 2 and one_line(err) and f"--action-type {env_type}" in err, err
    other = "twist" if env_type == "wheels" else "wheels"
    status, _, err = run(*_argv(command, str(bare_zip), kwargs, tmp_path), "--action-type", other)
    assert status == 2 and one_line(err) and f"the env takes {env_type}" in err, err
    assert not (tmp_path / "d").exists() and not (tmp_path / "bags").exists()


def test_said_and_the_envs_it_runs(bare_zip: Path, tmp_path: Path) -> None:
    argv = _argv("evaluate", str(bare_zip), TWIST, tmp_path)
    status, out, err = run(*argv, "--action-type", "twist")
    assert status == 0 and "twist.zip" in out, err


@pytest.mark.parametrize("command", ["evaluate", "record", "node"])
def test_an_action_type_beside_no_bare_zip_is_refused(command: str, tmp_path: Path) -> None:
    status, _, err = run(*_argv(command, "laser", WHEELS, tmp_path), "--action-type", "wheels")
    assert status == 2 and one_line(err) and "no --policy is one" in err, err
