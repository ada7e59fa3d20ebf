"""The Pioneer 3-DX (``PioneerP3DX-v0``, issue #26): its published figures, its drive, its laser.

The figures below are typed in from the datasheet and the tutorial (see
``bubblerob_env/robots/pioneer_p3dx.py``) and checked against the compiled model and against
what the robot does when driven, not against the description they were written into.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from test_core_laser import _both, _place, _random_tilt
from test_vector_env import _actions, _check

import bubblerob_env  # noqa: F401  (registers PioneerP3DX-v0)
from bubblerob_env.batch.cpu import BubbleRobVectorEnv
from bubblerob_env.robots import PIONEER_P3DX, ROBOTS

ENV_ID = "PioneerP3DX-v0"
# Datasheet: 455 x 381 x 237 mm, 9 kg, 195 mm wheels, 1.2 m/s, 300 deg/s. Tutorial: 180 degrees
# at 5 rays a degree, 50 m.
LENGTH, WIDTH, HEIGHT, MASS, WHEEL_DIAMETER = 0.455, 0.381, 0.237, 9.0, 0.195
TOP_SPEED, TOP_YAW_RATE = 1.2, math.radians(300.0)
LASER_RAYS, LASER_STEP, LASER_RANGE = 901, math.radians(0.2), 50.0


@pytest.fixture(scope="module")
def pioneer():
    env = gym.make(ENV_ID)
    yield env
    env.close()


def test_the_model_has_the_published_size_and_mass(pioneer):
    base = pioneer.unwrapped
    model = base.model
    assert base.robot is PIONEER_P3DX and ROBOTS["pioneer_p3dx"] is PIONEER_P3DX
    assert pioneer.spec.kwargs == {"robot": "pioneer_p3dx"}
    chassis, wheel = model.geom("chassis"), model.geom("left_wheel")
    body_z = model.body("base_link").pos[2]  # base_link is on the axle: wheel radius up
    assert 2 * chassis.size[0] == pytest.approx(LENGTH)
    assert body_z + chassis.pos[2] + chassis.size[2] == pytest.approx(HEIGHT)
    outer = model.body("left_wheel").pos[1] + wheel.size[1]
    assert 2 * outer == pytest.approx(WIDTH)
    assert 2 * wheel.size[0] == pytest.approx(WHEEL_DIAMETER) == pytest.approx(2 * body_z)
    assert model.body_subtreemass[model.body("base_link").id] == pytest.approx(MASS)
    assert base.drive.wheel_radius == pytest.approx(WHEEL_DIAMETER / 2)
    assert base.drive.max_linear_speed == pytest.approx(TOP_SPEED, rel=1e-3)
    assert base.max_angular_speed == pytest.approx(TOP_YAW_RATE)


def test_the_laser_is_the_tutorials(pioneer):
    spec = pioneer.unwrapped.laser_spec
    assert spec.num_rays == LASER_RAYS and spec.range_max == LASER_RANGE
    assert spec.angle_increment == pytest.approx(LASER_STEP, abs=1e-12)
    assert spec.angle_min == pytest.approx(-math.pi / 2) and spec.angle_max == pytest.approx(
        math.pi / 2
    )
    assert spec.caster == "analytic"
    assert pioneer.observation_space["laser"].shape == (LASER_RAYS,)


def _steady(env, action, steps: int = 40) -> dict:
    env.reset(seed=0)
    info: dict = {}
    for _ in range(steps):
        *_, info = env.step(np.asarray(action, dtype=np.float32))
    return info


def test_it_reaches_its_top_speed_and_rests_level():
    env = gym.make(ENV_ID, num_obstacles=(0, 0), start_pose=(-4.0, 0.0, 0.0))
    info = _steady(env, (1.0, 1.0))
    assert info["body_twist"][0] == pytest.approx(TOP_SPEED, rel=0.02)
    w, x, y, z = info["quaternion_wxyz"]
    assert math.degrees(math.asin(2 * (w * y - z * x))) == pytest.approx(0.0, abs=0.5)  # pitch
    assert info["position"][2] == pytest.approx(WHEEL_DIAMETER / 2, abs=1e-3)
    env.close()


@pytest.mark.parametrize(("linear", "angular"), [(0.5, 0.5), (0.0, 1.0), (-0.4, -0.3)])
def test_twist_is_differential_drive_inverse_kinematics(linear, angular):
    """Wheel commands are the IK of the twist (not the tutorial's placeholder 6v -+ 0.6w), and the
    robot then drives that twist."""
    env = gym.make(ENV_ID, action_type="twist", num_obstacles=(0, 0), start_pose=(0.0, 0.0, 0.0))
    info = _steady(env, (linear, angular), steps=30)
    # An action of 1 is the wheels' top speed (12.31 rad/s: 1.2002 m/s) and 300 degrees/s.
    linear, angular = (float(np.float32(a)) for a in (linear, angular))  # as the env gets them
    v, w = linear * env.unwrapped.max_linear_speed, angular * TOP_YAW_RATE
    half_track = env.unwrapped.drive.wheel_separation / 2
    expected = np.array([v - w * half_track, v + w * half_track]) / (WHEEL_DIAMETER / 2)
    expected *= min(1.0, env.unwrapped.drive.max_wheel_speed / np.abs(expected).max())
    np.testing.assert_allclose(info["wheel_command"], expected, rtol=1e-12)
    twist = info["body_twist"]
    # Within 7% of top speed and 8% of the yaw rate: the centre of mass, 6 cm behind the axle,
    # drags a spin backwards a little.
    assert twist[0] == pytest.approx(v, abs=0.08) and twist[5] == pytest.approx(w, rel=0.08)
    env.close()


@pytest.mark.parametrize("seed", range(6100, 6108))
def test_the_fast_laser_equals_mj_multiray_on_the_901_ray_scan(seed):
    env = gym.make(ENV_ID, num_obstacles=(8, 10))
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    layout = env.unwrapped.layout
    hits = 0
    for k in range(12):
        x, y = rng.uniform(-5.2, 5.2, 2)
        if k == 0:  # the scanner inside an obstacle
            x, y = layout.obstacles[0].x, layout.obstacles[0].y
        tilt = _random_tilt(rng) if k % 2 else None
        z = rng.uniform(-0.2, 0.45) if k % 4 == 1 else None
        _place(env, x, y, rng.uniform(-math.pi, math.pi), tilt, z)
        analytic, reference = _both(env)
        np.testing.assert_array_equal(analytic, reference, err_msg=f"seed {seed} pose {k}")
        hits += int((reference < LASER_RANGE).sum())
    assert hits > 12 * LASER_RAYS // 2  # the walls are in range of every ray
    env.close()


def test_the_native_batch_runs_pioneers_bit_for_bit():
    kwargs = {"robot": "pioneer_p3dx", "action_type": "twist", "laser_noise_std": 0.02}
    envs = gym.make_vec(
        "BubbleRob-v0",
        num_envs=3,
        vectorization_mode="vector_entry_point",
        num_threads=2,
        max_episode_steps=40,
        **kwargs,
    )
    assert isinstance(envs, BubbleRobVectorEnv)
    _check(envs, _actions(90, 3, seed=2), max_episode_steps=40, **kwargs)
    by_id = gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="vector_entry_point")
    assert by_id.single_observation_space["laser"].shape == (LASER_RAYS,)
    by_id.close()


def test_a_bad_robot_name_is_one_line():
    with pytest.raises(ValueError, match=r"robot must be one of \['bubblerob', 'pioneer_p3dx'\]"):
        gym.make("BubbleRob-v0", robot="pioneer")


def test_the_laser_policy_reads_the_180_degree_scan_and_drives_clear():
    from policies import load_policy
    from policies.evaluation import evaluate

    env = gym.make(ENV_ID)
    policy = load_policy("laser", env)
    # Its headings stay 10 degrees inside the scan's edges; its corridor is the robot's width.
    assert np.max(np.abs(policy._headings)) == pytest.approx(math.radians(80))
    assert policy.half_width > PIONEER_P3DX.radius
    env.close()
    # Short episodes on validation seeds: none collides (the full figures: README, BENCHMARKS).
    result = evaluate(
        "laser", episodes=2, seed=2000, env_id=ENV_ID, env_kwargs={"max_episode_steps": 200}
    )
    assert result.success_rate == 1.0 and result.mean_length == 200
    assert result.mean_speed_fraction > 0.2
