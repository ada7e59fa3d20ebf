"""The analytic laser against MuJoCo's mj_multiRay (identical float32 readings) and a 2D oracle.

Poses are drawn at random over the whole arena (so some scanners sit inside obstacles or walls),
half of them tilted by up to 3 degrees about a random axis, at random heights, plus rays aimed
exactly at box corners and tangent to cylinders (grazing rays), on seeds used nowhere else.
"""

from __future__ import annotations

import math

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import bubblerob_env  # noqa: F401
from bubblerob_env.arena import ASSETS_DIR, Obstacle
from bubblerob_env.core.batch import laser_geoms
from bubblerob_env.core.raycast import cast_prisms, world_rays

SEEDS = range(5000, 5020)


def _place(env, x: float, y: float, yaw: float, tilt: np.ndarray | None, z: float | None) -> None:
    raw = env.unwrapped
    quat = np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])
    if tilt is not None:
        tilted = np.empty(4)
        mujoco.mju_mulQuat(tilted, quat, tilt)
        quat = tilted
    adr = raw.scene.root_qpos
    floor_z = raw.model.body_pos[raw.scene.base_body][2]
    raw.data.qpos[adr : adr + 3] = (x, y, floor_z if z is None else z)
    raw.data.qpos[adr + 3 : adr + 7] = quat
    mujoco.mj_forward(raw.model, raw.data)


def _both(env) -> tuple[np.ndarray, np.ndarray]:
    """Readings of the analytic caster and of mj_multiRay from the current state, same rays."""
    raw = env.unwrapped
    model, data, spec = raw.model, raw.data, raw.laser_spec
    site = model.site("laser_link").id
    pnt, xmat = data.site_xpos[site].copy(), data.site_xmat[site].copy()
    angles = spec.angles()
    local = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1)
    dirs = np.empty((spec.num_rays, 3))
    world_rays(local, xmat, dirs)
    core = raw._core
    core.refresh_geoms(0, model)
    geoms = core.cast_geoms[0][core.cast_geoms[0] >= 0]
    analytic = np.empty(spec.num_rays)
    cast_prisms(
        pnt,
        xmat,
        dirs,
        spec.angle_min,
        spec.angle_increment,
        spec.full_circle,
        spec.range_max,
        geoms,
        model.geom_type.astype(np.int32),
        data.geom_xpos,
        data.geom_xmat,
        model.geom_size,
        model.geom_rbound,
        analytic,
    )
    reference = np.empty(spec.num_rays)
    group = np.zeros(6, np.uint8)
    group[0] = 1
    geomid = np.empty(spec.num_rays, np.int32)
    mujoco.mj_multiRay(
        model,
        data,
        pnt,
        dirs.reshape(-1),
        group,
        1,
        -1,
        geomid,
        reference,
        None,
        spec.num_rays,
        spec.range_max,
    )
    return raw.scene.laser.finish(analytic), raw.scene.laser.finish(reference)


def _random_tilt(rng: np.random.Generator) -> np.ndarray:
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    tilt = np.empty(4)
    mujoco.mju_axisAngle2Quat(tilt, axis, math.radians(rng.uniform(-3.0, 3.0)))
    return tilt


@pytest.mark.parametrize(
    "kwargs",
    [{}, {"laser_num_rays": 901, "laser_fov": math.pi}, {"laser_num_rays": 45, "laser_fov": 3.0}],
    ids=["360-rays", "180-deg-901-rays", "45-rays-3rad"],
)
def test_analytic_equals_mj_multiray_on_random_and_tilted_poses(kwargs):
    env = gym.make("BubbleRob-v0", num_obstacles=(6, 12), **kwargs)
    rng = np.random.default_rng(7)
    rays = hits = inside = 0
    for seed in SEEDS:
        env.reset(seed=seed)
        layout = env.unwrapped.layout
        for k in range(16):
            x, y = rng.uniform(-2.08, 2.08, 2)
            if k == 0 and layout.obstacles:  # the scanner inside an obstacle
                x, y = layout.obstacles[0].x, layout.obstacles[0].y
                inside += 1
            tilt = _random_tilt(rng) if k % 2 else None
            z = rng.uniform(-0.05, 0.35) if k % 4 == 1 else None
            _place(env, x, y, rng.uniform(-math.pi, math.pi), tilt, z)
            analytic, reference = _both(env)
            np.testing.assert_array_equal(analytic, reference, err_msg=f"seed {seed} pose {k}")
            rays += analytic.size
            hits += int((reference < env.unwrapped.laser_spec.range_max).sum())
    assert inside == len(SEEDS)
    if not kwargs:
        assert rays >= 100_000 and hits > rays // 2


def test_grazing_rays_at_box_corners_cylinder_tangents_and_arena_corners():
    env = gym.make("BubbleRob-v0", num_obstacles=(8, 10))
    rng = np.random.default_rng(11)
    spec = env.unwrapped.laser_spec
    checked = 0
    for seed in SEEDS:
        env.reset(seed=seed)
        for obstacle in env.unwrapped.layout.obstacles:
            x, y = rng.uniform(-1.8, 1.8, 2)
            if obstacle.kind == "box":
                c, s = math.cos(obstacle.yaw), math.sin(obstacle.yaw)
                hx, hy = obstacle.size
                targets = [(obstacle.x + c * hx - s * hy, obstacle.y + s * hx + c * hy)]
            else:
                d = math.hypot(obstacle.x - x, obstacle.y - y)
                if d <= obstacle.size[0]:
                    continue
                bearing = math.atan2(obstacle.y - y, obstacle.x - x)
                half = math.asin(obstacle.size[0] / d)
                targets = [
                    (x + math.cos(bearing + half), y + math.sin(bearing + half)),
                    (x + math.cos(bearing - half), y + math.sin(bearing - half)),
                ]
            half = env.unwrapped.arena_size / 2
            thick = half + 0.1  # the walls' outer corners too (their thickness is 0.05 m a side)
            targets += [(sx * c, sy * c) for c in (half, thick) for sx in (-1, 1) for sy in (-1, 1)]
            for tx, ty in targets:
                # Turn the robot so that ray 7 points exactly at the corner or tangent.
                yaw = math.atan2(ty - y, tx - x) - spec.angles()[7]
                _place(env, x, y, yaw, None, None)
                analytic, reference = _both(env)
                np.testing.assert_array_equal(analytic, reference)
                checked += 1
    assert checked > 100


@pytest.mark.parametrize("gap", [-1e-3, 0.0, 1e-9, 1e-7, 1e-5, 1e-3])
def test_geoms_just_behind_nearer_ones_read_as_mj_multiray(gap):
    """The caster tests the nearest geoms first and skips a geom for rays that already hit
    something nearer than it can be: rows of cylinders and boxes each ``gap`` m behind the one
    before (overlapping when negative), scanned from beside and along them, and tilted."""
    env = gym.make("BubbleRob-v0", num_obstacles=(10, 10), laser_num_rays=1440)
    env.reset(seed=5200)
    raw = env.unwrapped
    rows = []
    for kind, size, y in (("cylinder", (0.1,), 0.6), ("box", (0.1, 0.1), -0.6)):
        x = -1.0
        for _ in range(5):
            rows.append(Obstacle(kind, x, y, 0.0, size))
            x += 2 * size[0] + gap
    raw.scene.slots.apply(raw.model, raw.data, tuple(rows))
    rng = np.random.default_rng(int(1e9 * gap) % 1000)
    for k, (x, y) in enumerate([(-1.6, 0.6), (-1.6, -0.6), (-1.6, 0.0), (0.0, 0.0), (1.6, 0.58)]):
        tilt = _random_tilt(rng) if k % 2 else None
        _place(env, x, y, rng.uniform(-math.pi, math.pi), tilt, None)
        analytic, reference = _both(env)
        np.testing.assert_array_equal(analytic, reference, err_msg=f"pose {k}")


def _oracle(env) -> np.ndarray:
    """2D ranges computed here from the layout and the arena size (level scanner only)."""
    raw = env.unwrapped
    spec = raw.laser_spec
    site = raw.model.site("laser_link").id
    ox, oy = raw.data.site_xpos[site][:2]
    yaw = math.atan2(raw.data.site_xmat[site][3], raw.data.site_xmat[site][0])
    angles = yaw + spec.angles()
    dx, dy = np.cos(angles), np.sin(angles)
    best = np.full(angles.size, np.inf)
    half = raw.arena_size / 2
    # Walls: the inner faces of the arena, x = +-half and y = +-half.
    for axis_d, origin in ((dx, ox), (dy, oy)):
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(axis_d > 0, (half - origin) / axis_d, (-half - origin) / axis_d)
        best = np.minimum(best, np.where(np.isfinite(t) & (t >= 0), t, np.inf))
    for ob in raw.layout.obstacles:
        # In the obstacle's frame; boxes by slabs, cylinders by the quadratic.
        c, s = math.cos(ob.yaw), math.sin(ob.yaw)
        px, py = c * (ox - ob.x) + s * (oy - ob.y), -s * (ox - ob.x) + c * (oy - ob.y)
        ux, uy = c * dx + s * dy, -s * dx + c * dy
        if ob.kind == "cylinder":
            b = px * ux + py * uy
            disc = b * b - (px * px + py * py - ob.size[0] ** 2)
            t = np.where(disc >= 0, -b - np.sqrt(np.maximum(disc, 0)), np.inf)
        else:
            with np.errstate(divide="ignore", invalid="ignore"):
                lo = np.maximum((-ob.size[0] - px) / ux, (-ob.size[1] - py) / uy)
                lo = np.maximum(lo, np.minimum((ob.size[0] - px) / ux, (ob.size[1] - py) / uy))
                t1 = np.minimum((-ob.size[0] - px) / ux, (ob.size[0] - px) / ux)
                t2 = np.minimum((-ob.size[1] - py) / uy, (ob.size[1] - py) / uy)
                enter = np.maximum(t1, t2)
                t3 = np.maximum((-ob.size[0] - px) / ux, (ob.size[0] - px) / ux)
                t4 = np.maximum((-ob.size[1] - py) / uy, (ob.size[1] - py) / uy)
                leave = np.minimum(t3, t4)
            t = np.where((enter <= leave) & (enter >= 0), enter, np.inf)
        best = np.minimum(best, np.where(t >= 0, t, np.inf))
    return np.minimum(best, spec.range_max)


def test_readings_equal_a_2d_oracle_for_a_level_scanner():
    env = gym.make("BubbleRob-v0")
    rng = np.random.default_rng(3)
    compared = 0
    for seed in SEEDS:
        obs, _ = env.reset(seed=seed)
        assert env.unwrapped.laser_spec.caster == "analytic"
        np.testing.assert_allclose(obs["laser"], _oracle(env), atol=2e-6)
        obstacles = env.unwrapped.layout.obstacles
        for _ in range(20):
            x, y = rng.uniform(-1.95, 1.95, 2)
            if any(math.hypot(x - o.x, y - o.y) < o.bounding_radius + 0.02 for o in obstacles):
                continue  # the 2D oracle does not cast from inside an obstacle
            _place(env, x, y, rng.uniform(-math.pi, math.pi), None, None)
            analytic, reference = _both(env)
            oracle = _oracle(env)
            np.testing.assert_allclose(analytic, oracle, atol=2e-6)
            np.testing.assert_allclose(reference, oracle, atol=2e-6)
            compared += 1
    assert compared > 300


def test_backends_give_the_same_episode():
    runs = []
    for backend in ("auto", "mujoco"):
        env = gym.make("BubbleRob-v0", laser_backend=backend, action_type="twist")
        assert env.unwrapped.laser_spec.caster == ("analytic" if backend == "auto" else "mujoco")
        rng = np.random.default_rng(5)
        obs, _ = env.reset(seed=5001)
        trace = [obs["laser"]]
        for _ in range(300):
            obs, reward, terminated, truncated, _ = env.step(rng.uniform(-1, 1, 2))
            trace.append(np.append(obs["laser"], reward))
            if terminated or truncated:
                obs, _ = env.reset()
        runs.append(np.concatenate(trace))
    np.testing.assert_array_equal(*runs)


def test_other_geoms_fall_back_to_mj_multiray(tmp_path):
    scene = tmp_path / "sphere.xml"
    scene.write_text(
        f"""<mujoco model="sphere_scene">
  <include file="{ASSETS_DIR / "bubblerob.xml"}"/>
  <include file="{ASSETS_DIR / "common.xml"}"/>
  <worldbody>
    <geom name="floor" type="plane" size="3 3 0.5" group="1" contype="1" conaffinity="1"/>
    <geom name="ball" type="sphere" pos="1 0 0.1" size="0.1" group="0"/>
  </worldbody>
</mujoco>"""
    )
    env = gym.make("BubbleRob-v0", xml_file=str(scene), num_obstacles=(0, 0), start_pose=(0, 0, 0))
    assert env.unwrapped.laser_spec.caster == "mujoco"
    obs, _ = env.reset(seed=0)
    front = obs["laser"][env.unwrapped.laser_spec.num_rays // 2]
    site = env.unwrapped.model.site("laser_link").id
    laser = env.unwrapped.data.site_xpos[site]
    # The ray along the laser's x axis (the robot rests pitched 0.3 mrad, issue #41) meets the
    # ball (centre (1, 0, 0.1), radius 0.1).
    ray = env.unwrapped.data.site_xmat[site].reshape(3, 3)[:, 0]
    offset = laser - np.array([1.0, 0.0, 0.1])
    along = float(offset @ ray)
    expected = -along - math.sqrt(along**2 - (float(offset @ offset) - 0.1**2))
    assert front == pytest.approx(expected, abs=1e-6)
    with pytest.raises(ValueError, match="ball is a sphere"):
        gym.make("BubbleRob-v0", xml_file=str(scene), laser_backend="analytic")
    assert laser_geoms(env.unwrapped.model).size != 0
