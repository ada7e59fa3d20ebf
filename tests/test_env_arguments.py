"""Env kwargs from issue #23 that were taken silently: each is now one line naming it.

No silent defaults (``max_linear_speed=0`` or ``False`` became the wheels' limit), no truthy
strings (``camera="no"`` turned the camera on), nothing that only fails later (``arena_size=1e12``
truncated every episode at step 1; ``start_clearance=-1`` started robots outside the arena).
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import bubblerob_env  # noqa: F401  (registers BubbleRob-v0)
from bubblerob_env.arena import ASSETS_DIR

REFUSED = [
    ({"start_clearance": -1.0}, r"start_clearance must be >= 0 m .* < 1\.890 m for arena_size 4 m"),
    ({"start_clearance": 1e6}, r"start_clearance must be >= 0 m and leave the robot"),
    ({"start_clearance": 1.9}, r"start_clearance .* got 1\.9"),
    ({"arena_size": 1e12}, r"arena_size must be a finite number from 0 to 10000 m"),
    ({"arena_size": 0.2}, r"arena_size must be > 0\.22 m \(the robot's diameter\)"),
    ({"arena_size": True}, r"arena_size must be a finite number"),
    ({"max_linear_speed": 0}, r"max_linear_speed must be a finite number > 0 and <= 1e\+06"),
    ({"max_linear_speed": False}, r"max_linear_speed must be .* got False"),
    ({"max_linear_speed": 1e308, "action_type": "twist"}, r"max_linear_speed .* got 1e\+308"),
    ({"max_angular_speed": math.inf}, r"max_angular_speed must be a finite number > 0"),
    ({"max_angular_speed": 0.0}, r"max_angular_speed .* got 0\.0"),
    ({"max_wheel_speed": 1e300}, r"max_wheel_speed must be a finite number > 0 and <= 1e\+06"),
    ({"camera": "no"}, r"camera must be True or False, got 'no'"),
    ({"camera": 1}, r"camera must be True or False, got 1"),
    ({"camera_shadows": "yes"}, r"camera_shadows must be True or False"),
    ({"terminate_on_collision": 0}, r"terminate_on_collision must be True or False, got 0"),
    ({"laser_range_max": 1e300}, r"laser_range_max must be a finite number from 0 to 10000 m"),
    ({"laser_range_max": True}, r"laser_range_max must be a finite number .* got True"),
    ({"laser_fov": True}, r"laser_fov must be a finite number, got True"),
    ({"proximity_range_max": math.nan}, r"proximity_range_max must be a finite number"),
    ({"collision_penalty": 1e300}, r"collision_penalty must be a finite number from -1e\+06"),
    ({"physics_substeps": 10**9}, r"physics_substeps must be <= 10000"),
    ({"laser_num_rays": 10**7}, r"laser_num_rays must be an int >= 0 and <= 100000"),
    ({"xml_file": "/nonexistent/scene.xml"}, r"xml_file must be the path of an MJCF scene file"),
]


@pytest.mark.parametrize(("kwargs", "match"), REFUSED, ids=[str(k) for k, _ in REFUSED])
def test_an_absurd_or_mistyped_kwarg_is_one_line(kwargs, match):
    with pytest.raises(ValueError, match=match) as raised:
        gym.make("BubbleRob-v0", **kwargs)
    assert "\n" not in str(raised.value)


def test_a_scene_without_the_robot_names_what_it_lacks(tmp_path):
    scene = tmp_path / "floor_only.xml"
    scene.write_text('<mujoco><worldbody><geom name="floor" type="plane" size="5 5 .1"/>'
                     "</worldbody></mujoco>")  # fmt: skip
    with pytest.raises(ValueError) as raised:
        gym.make("BubbleRob-v0", xml_file=str(scene))
    text = str(raised.value)
    assert "\n" not in text and f"xml_file {scene} is not a BubbleRob scene" in text
    assert "body 'base_link'" in text and "include bubblerob.xml and common.xml" in text


def test_the_largest_accepted_values_still_run():
    # The limits are where things break, not where they stop being usual: the edges work.
    env = gym.make(
        "BubbleRob-v0",
        action_type="twist",
        max_linear_speed=1e6,
        max_angular_speed=1e6,
        max_wheel_speed=1e6,
        laser_range_max=10_000.0,
        arena_size=10_000.0,
        start_clearance=4999.0,
        num_obstacles=(0, 0),
        camera=np.bool_(False),
        max_episode_steps=5,
    )
    obs, _ = env.reset(seed=0)
    for _ in range(5):
        obs, reward, terminated, truncated, info = env.step(np.array([1.0, -1.0], np.float32))
        assert all(np.all(np.isfinite(v)) for v in obs.values()) and math.isfinite(reward)
        assert not info.get("physics_diverged")
    assert np.all(np.isfinite(env.unwrapped.data.ctrl))  # 1e308 gave NaN wheel commands
    env.close()


def test_none_still_means_the_wheels_limit():
    env = gym.make("BubbleRob-v0", action_type="twist")
    base = env.unwrapped
    assert base.max_linear_speed == base.drive.max_linear_speed > 0
    assert base.max_angular_speed == base.drive.max_angular_speed > 0
    env.close()
    assert gym.make("BubbleRob-v0", xml_file=str(ASSETS_DIR / "scenes" / "wall_test.xml"))


def test_the_config_checks_exactly_the_envs_keyword_arguments():
    # EnvConfig.from_kwargs knows the names and defaults (batches check kwargs without an env):
    # they must be the signature's, in its order (the TypeError lists them in that order).
    import inspect

    from bubblerob_env.config import ARGUMENTS
    from bubblerob_env.env import BubbleRobEnv

    parameters = inspect.signature(BubbleRobEnv.__init__).parameters
    signature = {
        name: p.default for name, p in parameters.items() if name not in ("self", "unknown_kwargs")
    }
    assert signature == ARGUMENTS
    assert list(signature) == list(ARGUMENTS)


def test_the_env_reads_its_arguments_from_its_frozen_config():
    env = gym.make("BubbleRob-v0", arena_size=3.0, num_obstacles=(2, 3)).unwrapped
    config = env.config
    assert (env.arena_size, env.num_obstacles) == (config.arena_size, config.num_obstacles)
    with pytest.raises(AttributeError):
        config.arena_size = 5.0  # type: ignore[misc]
    env.collision_penalty = 7.0  # as VectorEnv.set_attr does: a new config with the value
    assert env.config.collision_penalty == 7.0 and config.collision_penalty == 100.0
