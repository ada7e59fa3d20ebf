"""BubbleRob-v0 as a Gymnasium env: API checks, episodes, rewards, bad input, rendering."""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env

import bubblerob_env
from bubblerob_env import BubbleRobEnv
from bubblerob_env.arena import ROBOT_RADIUS


def test_make_by_id_and_by_module_path():
    for env_id in ("BubbleRob-v0", "bubblerob_env:BubbleRob-v0"):
        env = gym.make(env_id)
        obs, _ = env.reset(seed=0)
        assert set(obs) == {"laser", "proximity", "velocity"}
        assert env.spec.max_episode_steps == 1000
        env.close()


@pytest.mark.parametrize("kwargs", [{}, {"action_type": "twist", "camera": True}])
def test_gymnasium_env_checker_passes_without_warnings(kwargs):
    # The render check also opens a "human" window: that part runs under Xvfb below.
    env = gym.make("BubbleRob-v0", render_mode="rgb_array", **kwargs)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        gym_check_env(env.unwrapped, skip_render_check=True)
    env.close()


HUMAN_SCRIPT = """
import warnings
import gymnasium as gym, numpy as np
import bubblerob_env
from gymnasium.utils.env_checker import check_env
env = gym.make("BubbleRob-v0", render_mode="human")
env.reset(seed=0)
for _ in range(5):
    env.step(np.ones(2, np.float32))
env.close()
with warnings.catch_warnings():
    warnings.simplefilter("error")
    check_env(gym.make("BubbleRob-v0", render_mode="rgb_array").unwrapped)
print("checked")
"""


@pytest.mark.skipif(shutil.which("xvfb-run") is None, reason="needs xvfb-run (Debian xvfb)")
def test_env_checker_render_modes_and_human_window_under_xvfb():
    result = subprocess.run(
        ["xvfb-run", "-a", sys.executable, "-c", HUMAN_SCRIPT],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    assert "checked" in result.stdout


def test_stable_baselines3_env_checker_passes_without_warnings():
    sb3_check_env = pytest.importorskip("stable_baselines3.common.env_checker").check_env

    env = gym.make("BubbleRob-v0", camera=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sb3_check_env(env, warn=True)
    env.close()


def test_unknown_kwarg_raises_with_the_valid_names():
    with pytest.raises(
        TypeError, match=r"got an unexpected keyword argument 'lazer_num_rays'.*laser_num_rays"
    ):
        gym.make("BubbleRob-v0", lazer_num_rays=10)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"action_type": "tank"}, r"action_type must be one of \['wheels', 'twist'\], got 'tank'"),
        ({"render_mode": "ascii"}, "render_mode must be one of"),
        ({"physics_substeps": 0}, "physics_substeps must be an int >= 1, got 0"),
        ({"num_obstacles": (5, 2)}, "num_obstacles"),
        ({"control_timestep": -0.1}, "control_timestep must be a finite number > 0"),
    ],
)
def test_bad_kwarg_values_raise_naming_the_value(kwargs, match):
    with pytest.raises(ValueError, match=match):
        BubbleRobEnv(**kwargs)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_action_raises_naming_the_value(bad):
    env = gym.make("BubbleRob-v0")
    env.reset(seed=0)
    with pytest.raises(ValueError, match=rf"action \[0\.5, {bad}\] contains NaN or infinity"):
        env.step(np.array([0.5, bad], dtype=np.float32))


def test_wrong_action_shape_raises():
    env = BubbleRobEnv()
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"shape \(2,\), got shape \(3,\)"):
        env.step(np.zeros(3, np.float32))


def test_out_of_range_action_is_clipped_and_counted():
    clipped_env, plain_env = BubbleRobEnv(), BubbleRobEnv()
    clipped_env.reset(seed=3)
    plain_env.reset(seed=3)
    for step in range(1, 4):
        obs_c, *_, info_c = clipped_env.step(np.array([5.0, -1.0], np.float32))
        obs_p, *_, info_p = plain_env.step(np.array([1.0, -1.0], np.float32))
        assert info_c["action_clipped"] and not info_p["action_clipped"]
        assert info_c["clipped_actions"] == step
        np.testing.assert_array_equal(obs_c["laser"], obs_p["laser"])
    assert clipped_env.reset(seed=3)[1]["clipped_actions"] == 0


def test_reward_is_the_sum_of_its_parts_and_rewards_driving_forward():
    env = BubbleRobEnv(start_pose=(0.0, 0.0, 0.0), num_obstacles=(0, 0))
    env.reset(seed=0)
    for _ in range(15):
        _, reward, _, _, info = env.step(np.array([1.0, 1.0], np.float32))
    parts = sum(
        info[k] for k in ("reward_forward", "reward_spin", "reward_clearance", "reward_collision")
    )
    assert reward == pytest.approx(parts)
    assert info["reward_clearance"] == 0.0  # nothing within 0.35 m
    assert info["reward_forward"] == pytest.approx(1.0, abs=0.02)  # at full speed
    assert info["reward_spin"] == pytest.approx(0.0, abs=0.01)


@pytest.mark.parametrize(("x", "expected"), [(0.2, 0.0), (0.7, -0.5 * (0.35 - 0.315) / 0.24)])
def test_driving_close_to_a_wall_costs_clearance(wall_env_factory, x, expected):
    # The wall ahead is 1.0 - x - 0.015 (laser offset) from the laser; the left wall 0.7 m away.
    env = wall_env_factory(start_pose=(x, -0.5, 0.0))
    env.reset(seed=0)
    info = env.step(np.zeros(2, np.float32))[4]
    assert info["reward_clearance"] == pytest.approx(expected, abs=2e-3)


def test_spinning_in_place_is_penalised():
    env = BubbleRobEnv(start_pose=(0.0, 0.0, 0.0), num_obstacles=(0, 0))
    env.reset(seed=0)
    for _ in range(15):
        _, reward, _, _, info = env.step(np.array([-1.0, 1.0], np.float32))
    assert info["reward_spin"] < -0.15
    assert reward < 0


def test_driving_into_a_wall_terminates_with_the_collision_penalty(wall_env_factory):
    env = wall_env_factory()
    env.reset(seed=0)
    steps = 0
    terminated = False
    while not terminated and steps < 200:
        _, reward, terminated, truncated, info = env.step(np.array([1.0, 1.0], np.float32))
        steps += 1
    assert terminated and not truncated
    assert info["collision"]
    assert info["reward_collision"] == -100.0
    assert reward < -9.0
    # Wheels and chassis reach about 0.1 m ahead of base_link: it stopped at the wall (x = 1.0).
    assert 0.85 < info["x"] < 0.95
    assert steps > 10  # it drove there, it did not start in collision


def test_collision_does_not_terminate_when_asked(wall_env_factory):
    env = wall_env_factory(terminate_on_collision=False)
    env.reset(seed=0)
    collided = False
    for _ in range(100):
        _, _, terminated, _, info = env.step(np.array([1.0, 1.0], np.float32))
        collided |= info["collision"]
        assert not terminated
    assert collided


def test_time_limit_truncates():
    env = gym.make("BubbleRob-v0", max_episode_steps=5, start_pose=(0, 0, 0), num_obstacles=(0, 0))
    env.reset(seed=0)
    for _ in range(5):
        _, _, terminated, truncated, info = env.step(np.zeros(2, np.float32))
    assert truncated and not terminated
    assert info["sim_time"] == pytest.approx(5 * 0.05)


def test_control_step_and_substeps_are_kwargs():
    env = BubbleRobEnv(control_timestep=0.1, physics_substeps=8)
    env.reset(seed=0)
    assert env.dt == pytest.approx(0.1)
    assert env.model.opt.timestep == pytest.approx(0.0125)
    assert env.step(np.zeros(2, np.float32))[4]["sim_time"] == pytest.approx(0.1)


def _layout_signature(env: BubbleRobEnv) -> list:
    return [(o.kind, o.x, o.y, o.size) for o in env.layout.obstacles] + [env.layout.start_pose]


def test_reset_draws_layouts_from_the_seed():
    env = BubbleRobEnv()
    env.reset(seed=1)
    first = _layout_signature(env)
    env.reset(seed=2)
    assert _layout_signature(env) != first
    env.reset(seed=1)
    assert _layout_signature(env) == first


@pytest.mark.parametrize("seed", range(30))
def test_start_pose_is_free_and_obstacles_are_inside_the_arena(seed):
    env = BubbleRobEnv(arena_size=3.0, num_obstacles=(6, 12))
    obs, info = env.reset(seed=seed)
    assert not info["collision"]
    floor = env.model.geom("floor").id
    pairs = env.data.contact.geom[: env.data.ncon]
    assert np.all((pairs == floor).any(axis=1))  # only wheels and caster on the floor
    assert np.all(obs["laser"] > ROBOT_RADIUS)
    for o in env.layout.obstacles:
        assert abs(o.x) + o.bounding_radius <= 1.5 and abs(o.y) + o.bounding_radius <= 1.5


def test_obstacles_are_where_the_layout_says():
    # One obstacle in an otherwise fixed scene: the laser ray at its bearing reads its surface.
    env = BubbleRobEnv(num_obstacles=(1, 1), start_pose=(0.0, 0.0, 0.0))
    obs, _ = env.reset(seed=5)
    (o,) = env.layout.obstacles
    bearing = math.atan2(o.y, o.x + 0.015)
    index = int(np.argmin(np.abs(env.laser_spec.angles() - bearing)))
    distance = math.hypot(o.x + 0.015, o.y)
    assert distance - o.bounding_radius - 0.01 <= obs["laser"][index] <= distance + 1e-6


def test_arena_size_moves_the_walls():
    env = BubbleRobEnv(arena_size=6.0, num_obstacles=(0, 0), start_pose=(0.0, 0.0, 0.0))
    obs, _ = env.reset(seed=0)
    ahead = obs["laser"][180]  # ray 180 of 360 points along +x
    assert ahead == pytest.approx(3.0 + 0.015, abs=1e-4)


def test_observations_stay_in_the_observation_space_over_an_episode():
    env = gym.make("BubbleRob-v0", max_episode_steps=300)
    env.reset(seed=4)
    env.action_space.seed(4)
    for _ in range(300):
        obs, _, terminated, truncated, info = env.step(env.action_space.sample())
        assert env.observation_space.contains(obs)
        if terminated or truncated:
            env.reset()


def test_info_has_what_the_ros_layer_needs():
    env = BubbleRobEnv()
    _, info = env.reset(seed=0)
    for key, shape in (
        ("position", (3,)),
        ("quaternion_wxyz", (4,)),
        ("body_twist", (6,)),
        ("wheel_speeds", (2,)),
        ("wheel_command", (2,)),
    ):
        assert np.shape(info[key]) == shape, key
    assert np.linalg.norm(info["quaternion_wxyz"]) == pytest.approx(1.0)
    frames = {(t.parent, t.child) for t in env.static_transforms}
    assert frames == {
        ("base_link", "laser_link"),
        ("base_link", "proximity_link"),
        ("base_link", "camera_link"),
        ("camera_link", "camera_optical_frame"),
    }


def test_camera_optical_frame_looks_along_camera_link_x():
    env = BubbleRobEnv()
    (optical,) = [t for t in env.static_transforms if t.child == "camera_optical_frame"]
    # Standard ROS optical rotation: roll -90 deg, yaw -90 deg (z forward, x right, y down).
    assert optical.rotation_xyzw == pytest.approx((-0.5, 0.5, -0.5, 0.5))
    assert optical.translation == pytest.approx((0.0, 0.0, 0.0))


def test_rgb_array_render_shows_the_arena():
    env = gym.make("BubbleRob-v0", render_mode="rgb_array", render_width=200, render_height=160)
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (160, 200, 3) and frame.dtype == np.uint8
    assert frame.std() > 10  # not a blank image
    env.close()


def test_human_render_without_a_display_raises_clearly(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(RuntimeError, match="no display was found.*rgb_array"):
        BubbleRobEnv(render_mode="human")


def test_package_exports():
    assert set(bubblerob_env.__all__) <= set(dir(bubblerob_env))


def test_camera_works_headless_even_when_mujoco_is_imported_first():
    script = (
        "import mujoco, bubblerob_env, gymnasium as gym\n"
        "env = gym.make('BubbleRob-v0', camera=True)\n"
        "print(env.reset(seed=0)[0]['camera'].shape)\n"
    )
    env = {
        k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY", "MUJOCO_GL")
    }
    result = subprocess.run(
        [sys.executable, "-c", script],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    assert "(64, 64, 3)" in result.stdout


def test_resets_start_at_rest_with_every_floor_contact_active():
    """Issue #41: the compiled pose touched the floor at distance 0, where a contact is active
    or not by the sign of rounding noise (seed 3 fell freely for a substep on the CPU only)."""
    env = BubbleRobEnv()
    for seed in range(4):
        env.reset(seed=seed)
        data = env.data
        dists = [data.contact[i].dist for i in range(data.ncon)]
        assert len(dists) == 5 and max(dists) < -1e-4  # the caster and two per wheel, sunk in
        assert all(data.contact[i].exclude == 0 for i in range(data.ncon))
        assert data.nefc == 17
        before = data.qpos.copy()
        env.step(np.zeros(2, dtype=np.float32))
        assert np.abs(data.qpos[:7] - before[:7]).max() < 1e-8  # at rest: a zero action holds
    env.close()
