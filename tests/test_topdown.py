"""The NumPy top-down renderer against geometry computed here: the layout, the arena, the laser."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import textwrap

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import bubblerob_env  # noqa: F401 - registers BubbleRob-v0
from bubblerob_env.topdown import TopDownRenderer
from bubblerob_env.wrappers import LaserPooling, TopDownView

SIZE = 360
FLOOR_COLOURS = {(232, 232, 226), (205, 205, 198)}  # floor and its metre grid
WALL_THICKNESS = 0.1  # assets/arena.xml: the walls' inner faces are the arena's edges
HEADING = (255, 255, 255)


def _pixel_centres(renderer: TopDownRenderer) -> tuple[np.ndarray, np.ndarray]:
    """World x, y of every pixel centre, from the documented view: centred, +x right, +y up."""
    scale = renderer.pixels_per_metre
    columns, rows = np.meshgrid(np.arange(renderer.width), np.arange(renderer.height))
    return (columns + 0.5 - renderer.width / 2) / scale, (renderer.height / 2 - rows - 0.5) / scale


def _pixel(renderer: TopDownRenderer, x: float, y: float) -> tuple[int, int]:
    scale = renderer.pixels_per_metre
    return int(renderer.height / 2 - y * scale), int(renderer.width / 2 + x * scale)


def _footprint_distance(obstacle, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Signed distance (m) from each point to the obstacle's footprint, negative inside."""
    dx, dy = x - obstacle.x, y - obstacle.y
    if obstacle.kind == "cylinder":
        return np.hypot(dx, dy) - obstacle.size[0]
    cos, sin = math.cos(obstacle.yaw), math.sin(obstacle.yaw)
    u, v = np.abs(cos * dx + sin * dy), np.abs(-sin * dx + cos * dy)
    qu, qv = u - obstacle.size[0], v - obstacle.size[1]
    outside = np.hypot(np.maximum(qu, 0), np.maximum(qv, 0))
    return outside + np.minimum(np.maximum(qu, qv), 0)


@pytest.fixture(scope="module")
def scene():
    env = gym.make("BubbleRob-v0")
    obs, _ = env.reset(seed=3)
    renderer = TopDownRenderer.for_env(env, SIZE, SIZE)
    yield env, obs, renderer
    env.close()


def test_obstacles_walls_and_floor_are_where_the_layout_puts_them(scene) -> None:
    env, _, renderer = scene
    base = env.unwrapped
    frame = renderer.render()
    x, y = _pixel_centres(renderer)
    margin = 1.5 / renderer.pixels_per_metre  # a pixel and a half: edges may go either way
    colours = frame.reshape(-1, 3)
    is_floor = np.array([tuple(c) in FLOOR_COLOURS for c in map(tuple, colours)])
    is_floor = is_floor.reshape(frame.shape[:2])
    obstacles = base.layout.obstacles
    assert len(obstacles) >= 4
    distances = np.stack([_footprint_distance(o, x, y) for o in obstacles])
    for obstacle, distance in zip(obstacles, distances, strict=True):
        inside = distance < -margin
        assert inside.sum() > 20, obstacle
        assert not is_floor[inside].any(), obstacle
        assert len({tuple(c) for c in frame[inside]}) == 1, "an obstacle is drawn in one colour"
    half = base.arena_size / 2
    in_wall = (np.maximum(np.abs(x), np.abs(y)) > half + margin) & (
        np.maximum(np.abs(x), np.abs(y)) < half + WALL_THICKNESS - margin
    )
    assert in_wall.sum() > 1000 and not is_floor[in_wall].any()
    robot = np.hypot(x - base.layout.start_pose[0], y - base.layout.start_pose[1]) < 0.12 + margin
    free = (distances.min(axis=0) > margin) & (np.maximum(np.abs(x), np.abs(y)) < half - margin)
    free &= ~robot
    assert free.sum() > 0.5 * free.size and is_floor[free].all()


def test_robot_is_drawn_at_its_pose_with_its_heading(scene) -> None:
    env, _, renderer = scene
    x, y, yaw = env.unwrapped.layout.start_pose
    frame = renderer.render()
    assert tuple(frame[_pixel(renderer, x, y)]) not in FLOOR_COLOURS
    ahead = _pixel(renderer, x + 0.07 * math.cos(yaw), y + 0.07 * math.sin(yaw))
    behind = _pixel(renderer, x - 0.07 * math.cos(yaw), y - 0.07 * math.sin(yaw))
    assert tuple(frame[ahead]) == HEADING
    assert tuple(frame[behind]) != HEADING


def test_laser_hits_and_rays_are_drawn_where_the_scan_says(scene) -> None:
    env, obs, renderer = scene
    base = env.unwrapped
    scan = obs["laser"]
    plain, drawn = renderer.render(), renderer.render(scan)
    # Laser origin from the model's site; ray i at angle_min + i * increment from the robot's +x.
    site = base.model.site("laser_link").id
    ox, oy = base.data.site_xpos[site][:2]
    yaw = base.layout.start_pose[2]
    spec = base.laser_spec
    angles = yaw + spec.angle_min + spec.angle_increment * np.arange(spec.num_rays)
    hits = np.flatnonzero(scan < spec.range_max)
    assert hits.size > 300
    for ray in hits[::7]:
        px = ox + scan[ray] * math.cos(angles[ray])
        py = oy + scan[ray] * math.sin(angles[ray])
        assert tuple(drawn[_pixel(renderer, px, py)]) == (230, 25, 25), ray
    # Every fourth ray of 360 is drawn (90 rays): halfway along one, the floor is tinted.
    tinted = 0
    for ray in range(0, spec.num_rays, 4):
        middle = 0.5 * max(scan[ray], 0.3)
        pixel = _pixel(
            renderer, ox + middle * math.cos(angles[ray]), oy + middle * math.sin(angles[ray])
        )
        if tuple(plain[pixel]) in FLOOR_COLOURS:
            tinted += tuple(drawn[pixel]) != tuple(plain[pixel])
    assert tinted > 60
    with pytest.raises(ValueError, match="one reading per ray"):
        renderer.render(scan[:10])


def test_background_follows_a_reset(scene) -> None:
    env, _, renderer = scene
    before = renderer.render()
    env.reset(seed=4)
    after = renderer.render()
    env.reset(seed=3)
    assert (before != after).any(axis=2).sum() > 1000
    assert np.array_equal(renderer.render(), before)


_TILTED = """
<mujoco>
  <worldbody>
    <geom type="box" size="0.3 0.15 0.1" pos="-0.8 0.8 0.5" euler="30 40 20"/>
    <geom type="cylinder" size="0.15 0.3" pos="0.8 0.8 0.5" euler="50 20 0"/>
    <geom type="capsule" size="0.12 0.25" pos="-0.8 -0.8 0.5" euler="0 60 30"/>
    <geom type="ellipsoid" size="0.3 0.15 0.2" pos="0.8 -0.8 0.5" euler="20 30 40"/>
  </worldbody>
</mujoco>
"""


def _inside_geom(model, data, geom: int, points: np.ndarray) -> np.ndarray:
    """Whether each 3D point lies in the geom: its local coordinates against its size."""
    local = (points - data.geom_xpos[geom]) @ data.geom_xmat[geom].reshape(3, 3)
    size, kind = model.geom_size[geom], model.geom_type[geom]
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        return (np.abs(local) <= size).all(axis=-1)
    if kind == mujoco.mjtGeom.mjGEOM_ELLIPSOID:
        return ((local / size) ** 2).sum(axis=-1) <= 1
    radial = np.hypot(local[..., 0], local[..., 1])
    if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return (radial <= size[0]) & (np.abs(local[..., 2]) <= size[1])
    along = np.clip(local[..., 2], -size[1], size[1])  # capsule: distance to its segment
    return np.hypot(radial, local[..., 2] - along) <= size[0]


def test_tilted_shapes_match_a_brute_force_silhouette() -> None:
    model = mujoco.MjModel.from_xml_string(_TILTED)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    renderer = TopDownRenderer(model, data, 200, 200, view_size=2.4)
    frame = renderer.render()
    x, y = _pixel_centres(renderer)
    drawn = np.array([tuple(c) not in FLOOR_COLOURS for c in frame.reshape(-1, 3)])
    drawn = drawn.reshape(frame.shape[:2])
    expected = np.zeros_like(drawn)
    for geom in range(model.ngeom):  # sample each pixel's vertical line through the geom
        (cx, cy, cz), reach = data.geom_xpos[geom], model.geom_rbound[geom]
        near = np.hypot(x - cx, y - cy) <= reach
        heights = np.linspace(cz - reach, cz + reach, 301)  # under 2.5 mm apart
        points = np.stack(np.broadcast_arrays(x[near][:, None], y[near][:, None], heights), -1)
        expected[near] |= _inside_geom(model, data, geom, points).any(axis=-1)
    assert expected.sum() > 4000
    assert (drawn != expected).sum() <= 0.01 * expected.sum()


def test_wrapper_renders_the_last_scan_without_opengl() -> None:
    script = textwrap.dedent(
        """
        import json, time
        import gymnasium as gym
        import numpy as np
        import bubblerob_env
        from bubblerob_env.topdown import TopDownRenderer
        from bubblerob_env.wrappers import TopDownView

        env = TopDownView(gym.make("BubbleRob-v0"), 360, 360)
        obs, _ = env.reset(seed=5)
        for _ in range(20):
            obs, *_ = env.step([0.6, 0.4])
        frame = env.render()
        same = TopDownRenderer.for_env(env).render(obs["laser"])
        times = []
        for _ in range(30):
            start = time.perf_counter()
            env.render()
            times.append(time.perf_counter() - start)
        maps = open("/proc/self/maps").read()
        print(json.dumps({
            "shape": list(frame.shape), "same": bool(np.array_equal(frame, same)),
            "mode": env.render_mode, "ms": 1000 * min(times),
            "gl": "/dri/" in maps or "libOSMesa" in maps,
        }))
        """
    )
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True)
    result = json.loads(out.stdout.strip().splitlines()[-1])
    assert result["shape"] == [360, 360, 3] and result["same"] and result["mode"] == "rgb_array"
    # An OpenGL context loads Mesa's driver (dri/swrast_dri.so); importing MuJoCo loads only libEGL.
    assert not result["gl"], "the top-down view made an OpenGL context"
    assert result["ms"] < 10.0, result  # about 1 ms here; MuJoCo's renderer on llvmpipe: ~48 ms


def test_wrapper_outside_pooling_draws_no_rays() -> None:
    env = TopDownView(LaserPooling(gym.make("BubbleRob-v0"), pool=10))
    env.reset(seed=3)
    plain = TopDownRenderer.for_env(env).render()
    assert np.array_equal(env.render(), plain)
    env.close()


def test_wrapper_draws_the_scan_of_a_flat_env_as_of_a_dict_env() -> None:
    frames = []
    for obs_mode in ("dict", "flat"):
        env = TopDownView(gym.make("BubbleRob-v0", obs_mode=obs_mode))
        env.reset(seed=3)
        for _ in range(10):
            env.step([0.5, 0.3])
        frames.append(env.render())
        env.close()
    assert np.array_equal(*frames)
    assert (frames[0] != TopDownRenderer.for_env(env).render()).any()  # rays were drawn
