"""Laser, proximity sensor and camera against a scene with walls at known distances.

In ``scenes/wall_test.xml`` the robot starts at the origin facing +x; a wall's face is at x = 1.0
and another's at y = 0.7. The laser origin (laser_link) is at x = -0.015 in base_link.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

from bubblerob_env.sensors import CameraSpec, LaserSpec, ProximitySpec

LASER_X = -0.015


def _ray_index(spec: LaserSpec, angle: float) -> int:
    index = int(np.argmin(np.abs(spec.angles() - angle)))
    assert spec.angles()[index] == pytest.approx(angle)
    return index


def test_full_circle_spec_follows_laserscan_conventions():
    spec = LaserSpec(num_rays=360, fov=2 * math.pi, range_min=0.05, range_max=5.0)
    assert spec.angle_min == pytest.approx(-math.pi)
    assert spec.angle_increment == pytest.approx(math.radians(1))
    assert spec.angle_max == pytest.approx(math.pi - math.radians(1))  # no duplicate ray at +pi
    # ROS: len(ranges) == (angle_max - angle_min) / angle_increment + 1
    assert (spec.angle_max - spec.angle_min) / spec.angle_increment + 1 == pytest.approx(360)


def test_partial_fov_puts_rays_on_both_edges():
    spec = LaserSpec(num_rays=901, fov=math.pi, range_min=0.05, range_max=50.0)
    assert spec.angle_min == pytest.approx(-math.pi / 2)
    assert spec.angle_max == pytest.approx(math.pi / 2)
    assert spec.angle_increment == pytest.approx(math.radians(0.2))  # 5 rays per degree


@pytest.mark.parametrize("bad", [{"num_rays": 0}, {"fov": 7.0}, {"range_min": 6.0}])
def test_laser_spec_rejects_bad_values(bad):
    kwargs = {"num_rays": 10, "fov": math.pi, "range_min": 0.05, "range_max": 5.0} | bad
    with pytest.raises(ValueError, match=next(iter(bad)).split("_")[0]):
        LaserSpec(**kwargs)


@pytest.mark.parametrize(("num_rays", "fov"), [(360, 2 * math.pi), (181, math.pi)])
def test_laser_reads_wall_ahead_and_wall_to_the_left(wall_env_factory, num_rays, fov):
    env = wall_env_factory(laser_num_rays=num_rays, laser_fov=fov)
    obs, _ = env.reset(seed=0)
    spec = env.unwrapped.laser_spec
    ahead = obs["laser"][_ray_index(spec, 0.0)]
    left = obs["laser"][_ray_index(spec, math.pi / 2)]
    assert ahead == pytest.approx(1.0 - LASER_X, abs=1e-4)
    assert left == pytest.approx(0.7, abs=1e-4)


def test_laser_ray_to_the_right_sees_nothing_and_reads_range_max(wall_env_factory):
    env = wall_env_factory(laser_range_max=2.0)
    obs, _ = env.reset(seed=0)
    spec = env.unwrapped.laser_spec
    # Nothing to the right (-y) nor behind: not even the robot's own body.
    assert obs["laser"][_ray_index(spec, -math.pi / 2)] == 2.0
    assert obs["laser"][_ray_index(spec, -math.pi)] == 2.0


def test_laser_follows_the_robots_heading(wall_env_factory):
    env = wall_env_factory(start_pose=(0.0, 0.0, math.pi / 2))  # facing +y
    obs, _ = env.reset(seed=0)
    spec = env.unwrapped.laser_spec
    # laser_link is 0.015 m behind base_link, now along -y.
    assert obs["laser"][_ray_index(spec, 0.0)] == pytest.approx(0.7 + 0.015, abs=1e-4)


def test_laser_noise_is_seeded_and_has_the_asked_spread(wall_env_factory):
    env = wall_env_factory(laser_noise_std=0.01)
    readings = []
    for _ in range(2):
        obs, _ = env.reset(seed=7)
        readings.append(obs["laser"])
    np.testing.assert_array_equal(readings[0], readings[1])
    spec_index = _ray_index(env.unwrapped.laser_spec, 0.0)
    samples = [env.step(np.zeros(2, np.float32))[0]["laser"][spec_index] for _ in range(200)]
    assert np.std(samples) == pytest.approx(0.01, rel=0.25)
    assert np.mean(samples) == pytest.approx(1.0 - LASER_X, abs=0.003)


def test_proximity_reads_range_max_when_nothing_is_near(wall_env_factory):
    env = wall_env_factory()
    obs, info = env.reset(seed=0)
    assert obs["proximity"][0] == env.unwrapped.proximity_spec.range_max
    assert not info["proximity_triggered"]


@pytest.mark.parametrize(("x", "triggered"), [(0.5, False), (0.8, True)])
def test_proximity_measures_the_wall_ahead_and_triggers_when_close(wall_env_factory, x, triggered):
    env = wall_env_factory(start_pose=(x, 0.0, 0.0))
    obs, info = env.reset(seed=0)
    nose_x = x + 0.06  # proximity_link is 0.06 m ahead of base_link
    assert obs["proximity"][0] == pytest.approx(1.0 - nose_x, abs=1e-4)
    assert info["proximity_triggered"] is triggered


def test_proximity_spec_rejects_trigger_beyond_range():
    with pytest.raises(ValueError, match="trigger_distance"):
        ProximitySpec(range_max=0.5, trigger_distance=0.8)


def test_proximity_radiation_type_must_be_one_ros_knows():
    allowed = r"\['ULTRASOUND', 'INFRARED'\], got 'LIDAR'"
    with pytest.raises(ValueError, match="proximity_radiation_type must be one of " + allowed):
        gym.make("BubbleRob-v0", proximity_radiation_type="LIDAR")
    with pytest.raises(ValueError, match="radiation_type must be one of " + allowed):
        ProximitySpec(range_max=0.5, trigger_distance=0.3, radiation_type="LIDAR")


def test_camera_is_off_by_default(wall_env_factory):
    env = wall_env_factory()
    assert "camera" not in env.observation_space.spaces
    assert env.unwrapped.camera_spec is None


def test_camera_image_has_the_asked_shape_and_dtype(wall_env_factory):
    env = wall_env_factory(camera_width=80, camera_height=60)
    obs, _ = env.reset(seed=0)
    assert obs["camera"].shape == (60, 80, 3)
    assert obs["camera"].dtype == np.uint8
    assert env.observation_space["camera"].contains(obs["camera"])
    assert not env.unwrapped.camera_spec.shadows


def test_camera_image_changes_when_the_robot_turns(wall_env_factory):
    env = wall_env_factory(camera=True, action_type="twist")
    before, _ = env.reset(seed=0)
    for _ in range(10):
        after, *_ = env.step(np.array([0.0, 0.5], np.float32))
    difference = np.abs(before["camera"].astype(int) - after["camera"].astype(int)).mean()
    assert difference > 5.0


def test_camera_sees_the_wall_ahead(wall_env_factory):
    # The wall ahead (x = 1.0) fills the image centre with the wall colour; from farther away the
    # same pixel shows floor or background instead.
    near = wall_env_factory(camera=True, start_pose=(0.6, 0.0, 0.0))
    far = wall_env_factory(camera=True, start_pose=(0.0, 0.0, math.pi))
    centre_near = near.reset(seed=0)[0]["camera"][32, 32].astype(int)
    centre_far = far.reset(seed=0)[0]["camera"][32, 32].astype(int)
    wall_rgb = np.array([0.55, 0.45, 0.35]) * 255
    assert np.abs(centre_near - wall_rgb).max() < 60
    assert np.abs(centre_far - wall_rgb).max() > np.abs(centre_near - wall_rgb).max()


def test_camera_intrinsics_match_the_vertical_field_of_view():
    spec = CameraSpec(width=64, height=48, fovy=60.0)
    k = spec.intrinsics()
    assert k[1, 1] == pytest.approx(24 / math.tan(math.radians(30)))
    assert k[0, 0] == k[1, 1]
    assert (k[0, 2], k[1, 2]) == (31.5, 23.5)
