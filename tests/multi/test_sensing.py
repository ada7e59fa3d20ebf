"""Robots see and hit each other: laser windows at the range geometry gives, equal to
mj_multiRay; the camera; a robot driven into another terminates both."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

pytest.importorskip("pettingzoo")
import bubblerob_env  # noqa: E402
from bubblerob_env.arena import Obstacle  # noqa: E402
from bubblerob_env.multi.scene import WINDOW_GROUP  # noqa: E402
from bubblerob_env.robots import ROBOTS  # noqa: E402


def _multiray(env: object, k: int, hits: list[int] | None = None) -> np.ndarray:
    """Robot ``k``'s scan by mj_multiRay: walls, obstacles and the windows, itself excluded.

    ``hits``: gets the ids of the geoms hit appended.
    """
    world = env.world  # type: ignore[attr-defined]
    model, data = world.scene.model, world.scene.data
    spec = world.scene.laser_spec
    site = world.robots[k].laser_site
    angles = spec.angles()
    local = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1)
    dirs = local @ data.site_xmat[site].reshape(3, 3).T
    group = np.zeros(mujoco.mjNGROUP, dtype=np.uint8)
    group[[0, WINDOW_GROUP]] = 1
    dist = np.zeros(len(angles))
    geomid = np.zeros(len(angles), dtype=np.int32)
    mujoco.mj_multiRay(
        model, data, data.site_xpos[site], dirs.ravel(), group, 1,
        world.robots[k].base_body, geomid, dist, None, len(angles), spec.range_max,
    )  # fmt: skip
    hit = (dist >= 0) & (dist < spec.range_max)
    if hits is not None:
        hits.extend(geomid[hit].tolist())
    return np.where(hit, dist, spec.range_max).astype(np.float32)


@pytest.mark.parametrize("robot", ["bubblerob", "pioneer_p3dx"])
def test_laser_reads_the_other_robots_window_at_its_geometric_range(robot: str) -> None:
    description = ROBOTS[robot]
    ahead = 4 * description.radius
    env = bubblerob_env.parallel_env(num_robots=2, robot=robot, num_obstacles=(0, 0))
    obs, _ = env.reset(seed=0, options={"start_poses": [(0, 0, 0), (ahead, 0, 0.2)]})
    spec = env.world.scene.laser_spec
    assert spec.caster == "analytic"
    # Geometry: both laser sites are at the same offset from base_link; B's window is a
    # cylinder of the description's radius about B's laser site.
    model = env.world.scene.model
    offset = model.site_pos[env.world.robots[1].laser_site]
    b_site = np.array([ahead + offset[0] * math.cos(0.2), offset[0] * math.sin(0.2)])
    a_site = np.array([offset[0], 0.0])
    along = b_site[0] - a_site[0]
    across = b_site[1] - a_site[1]
    radius = description.laser.window[0]
    expected = along - math.sqrt(radius**2 - across**2)
    forward = int(np.argmin(np.abs(spec.angles())))  # the ray along +x
    laser = obs[f"{robot}_0"]["laser"]
    assert abs(float(laser[forward]) - expected) < 0.01
    assert np.array_equal(laser, _multiray(env, 0))
    assert np.array_equal(obs[f"{robot}_1"]["laser"], _multiray(env, 1))


@pytest.mark.parametrize("robot", ["bubblerob", "pioneer_p3dx"])
def test_analytic_scan_equals_mj_multiray_while_robots_drive_and_tilt(robot: str) -> None:
    """Full circle (BubbleRob) and a 180-degree fan (Pioneer), robots close and far."""
    env = bubblerob_env.parallel_env(num_robots=4, robot=robot, arena_size=None)
    env.reset(seed=3)
    assert env.world.scene.laser_spec.caster == "analytic"
    rng = np.random.default_rng(1)
    compared = 0
    hits: list[int] = []
    for _ in range(40):
        actions = {agent: rng.uniform(-0.5, 1, 2).astype(np.float32) for agent in env.agents}
        obs, *_ = env.step(actions)
        for agent, agent_obs in obs.items():
            k = env.possible_agents.index(agent)
            assert np.array_equal(agent_obs["laser"], _multiray(env, k, hits))
            compared += 1
        if not env.agents:
            env.reset()
    windows = {robot.window for robot in env.world.robots}
    assert sum(hit in windows for hit in hits) > 100  # the windows were seen, often
    assert compared >= 40


def test_other_robot_only_changes_the_rays_that_hit_its_window() -> None:
    """A's scan with B equals A's scan in the world without B except where B's window is."""
    obstacles = (
        Obstacle("cylinder", -1.0, 0.8, 0.0, (0.2,)),
        Obstacle("box", 1, -1, 0.3, (0.2, 0.1)),
    )
    pose_a, pose_b = (0.0, 0.0, 0.2), (1.0, 0.5, 0.0)
    alone = bubblerob_env.parallel_env(num_robots=1)
    scan_alone = alone.reset(seed=0, options={"start_poses": [pose_a], "obstacles": obstacles})[0]
    both = bubblerob_env.parallel_env(num_robots=2)
    options = {"start_poses": [pose_a, pose_b], "obstacles": obstacles}
    scan_both = both.reset(seed=0, options=options)[0]
    a_alone, a_both = scan_alone["bubblerob_0"]["laser"], scan_both["bubblerob_0"]["laser"]
    changed = np.flatnonzero(a_alone != a_both)
    # B's window seen from A's laser site: a bearing interval of half-width asin(r / d).
    model = both.world.scene.model
    site = both.world.scene.data.site_xpos[both.world.robots[1].laser_site]
    own = both.world.scene.data.site_xpos[both.world.robots[0].laser_site]
    d = math.hypot(*(site - own)[:2])
    bearing = math.atan2(*(site - own)[1::-1]) - pose_a[2]
    half = math.asin(model.geom_size[both.world.robots[1].window][0] / d)
    angles = both.world.scene.laser_spec.angles()
    off = np.abs(np.remainder(angles - bearing + math.pi, 2 * math.pi) - math.pi)
    assert changed.size > 0
    assert set(changed) <= set(np.flatnonzero(off <= half + 1e-9))
    assert np.all(a_both[changed] < a_alone[changed])


def test_camera_sees_the_other_robot_where_geometry_says() -> None:
    env = bubblerob_env.parallel_env(num_robots=2, camera=True, num_obstacles=(0, 0))
    ahead = [(0.0, 0.0, 0.0), (0.6, 0.0, math.pi)]
    behind = [(0.0, 0.0, 0.0), (-0.6, 0.0, math.pi)]
    with_b = env.reset(seed=0, options={"start_poses": ahead})[0]["bubblerob_0"]["camera"]
    without = env.reset(seed=0, options={"start_poses": behind})[0]["bubblerob_0"]["camera"]
    changed = np.any(with_b != without, axis=-1)
    height, width = changed.shape
    # B lies within its bounding circle (radius 0.11 m) about a point 0.548 m ahead of the
    # camera (0.052 m ahead of A's base_link): within asin(0.11 / 0.548) of the image centre,
    # which the 60-degree pinhole camera maps to tan(angle) / tan(30 deg) half-widths.
    half_columns = math.tan(math.asin(0.11 / 0.548)) / math.tan(math.radians(30)) * width / 2
    columns = np.flatnonzero(changed.any(axis=0))
    assert columns.size > 0
    centre = (width - 1) / 2
    assert np.all(np.abs(columns - centre) <= half_columns + 2)
    assert changed[:, int(centre)].sum() > height // 8
    env.close()


def test_driving_into_another_robot_terminates_both_naming_each_other() -> None:
    env = bubblerob_env.parallel_env(num_robots=3, num_obstacles=(0, 0))
    poses = [(0.0, 0.0, 0.0), (0.4, 0.0, math.pi / 2), (0.5, -0.6, math.pi / 2)]
    env.reset(seed=0, options={"start_poses": poses})
    drive = {"bubblerob_0": np.ones(2, np.float32), "bubblerob_1": np.zeros(2, np.float32)}
    for _ in range(100):
        actions = {agent: drive.get(agent, np.zeros(2, np.float32)) for agent in env.agents}
        _, rewards, terminated, _, infos = env.step(actions)
        if any(terminated.values()):
            break
    assert terminated == {"bubblerob_0": True, "bubblerob_1": True, "bubblerob_2": False}
    assert infos["bubblerob_0"]["collided_with"] == "bubblerob_1"
    assert infos["bubblerob_1"]["collided_with"] == "bubblerob_0"
    assert rewards["bubblerob_1"] <= -100.0
    assert env.agents == ["bubblerob_2"]
    # The stopped robots stay where they stopped, an obstacle for the one still driving.
    # Wheels commanded 0: the stopped robots come to rest (A's momentum pushes B a little).
    adr = env.world.robots[1].root_qpos
    for _ in range(20):
        env.step({"bubblerob_2": np.zeros(2, np.float32)})
    still = env.world.scene.data.qpos[adr : adr + 2].copy()
    for _ in range(5):
        env.step({"bubblerob_2": np.zeros(2, np.float32)})
    assert np.allclose(env.world.scene.data.qpos[adr : adr + 2], still, atol=1e-4)
    # The third robot drives into the stopped one: it terminates, naming it.
    for _ in range(60):
        _, _, terminated, _, infos = env.step({"bubblerob_2": np.ones(2, np.float32)})
        if terminated["bubblerob_2"]:
            break
    assert infos["bubblerob_2"]["collided_with"] == "bubblerob_1"
    assert not env.agents


def test_nose_sensor_reads_the_other_robots_chassis() -> None:
    """BubbleRob's rangefinder is at the height of the chassis sphere's centre (0.09 m)."""
    env = bubblerob_env.parallel_env(num_robots=2, num_obstacles=(0, 0))
    obs, _ = env.reset(seed=0, options={"start_poses": [(0, 0, 0), (0.35, 0, math.pi)]})
    # B faces A: its chassis sphere (r 0.075) is centred 0.015 m behind B's base_link, so near
    # x = 0.365; A's rangefinder looks along +x from x = 0.06: about 0.35 + 0.015 - 0.075 - 0.06.
    # Exactly: the ray from A's sensor site along its z axis against B's sphere where the robots
    # rest (sunk 0.26 mm, pitched 0.3 mrad: issue #41), intersected here.
    data, model = env.world.scene.data, env.world.scene.model
    site = model.site("proximity_ray").id
    origin, ray = data.site_xpos[site], data.site_xmat[site].reshape(3, 3)[:, 2]
    centre = data.geom_xpos[model.geom("robot_1/chassis").id]
    offset = origin - centre
    along = float(offset @ ray)
    expected = -along - math.sqrt(along**2 - (float(offset @ offset) - 0.075**2))
    assert abs(expected - (0.35 + 0.015 - 0.075 - 0.06)) < 1e-3
    assert abs(float(obs["bubblerob_0"]["proximity"][0]) - expected) < 1e-6
