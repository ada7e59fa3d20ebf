"""The ground-truth occupancy grid against MuJoCo itself, and the log-odds mapper."""

from __future__ import annotations

import math

import gymnasium as gym
import mujoco
import numpy as np
import pytest
from cli_usage import run

import bubblerob_env  # noqa: F401 - registers BubbleRob-v0
from bubblerob_env.arena import ArenaLayout, Obstacle
from bubblerob_env.mapping import (
    OCCUPIED,
    Grid,
    LogOddsMapper,
    episode_grid,
    ground_truth_grid,
    occupied_iou,
)


def _raycast_grid(env: gym.Env, grid: Grid) -> np.ndarray:
    """Independently: a ray straight down onto each cell's centre; occupied if it meets no floor."""
    base = env.unwrapped
    model, data = base.model, base.data
    floor = model.geom("floor").id
    # Only the groups of the floor, the walls and the obstacles: the robot is not the map.
    groups = {int(model.geom_group[model.geom(n).id]) for n in ("floor", "wall_north")}
    groups |= {int(model.geom_group[g]) for g in base.scene.slots.geom_ids}
    robot_groups = {int(model.geom_group[model.geom("right_wheel").id])}
    assert not groups & robot_groups
    geomgroup = np.array([int(g in groups) for g in range(6)], dtype=np.uint8)
    x, y = grid.centres
    out = np.zeros(grid.data.shape, dtype=np.int8)
    geomid = np.zeros(1, dtype=np.int32)
    down = np.array([0.0, 0.0, -1.0])
    for index in np.ndindex(grid.data.shape):
        start = np.array([x[index], y[index], 1.0])
        mujoco.mj_ray(model, data, start, down, geomgroup, 1, -1, geomid)
        out[index] = OCCUPIED if geomid[0] not in (-1, floor) else 0
    return out


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_ground_truth_agrees_with_the_scene_cell_by_cell(seed):
    env = gym.make("BubbleRob-v0", laser_num_rays=0)
    try:
        env.reset(seed=seed)
        grid = episode_grid(env)
        assert grid.resolution == 0.05
        rows, cols = grid.data.shape
        assert rows == cols == 84  # 4 m inside + 2 x 0.1 m walls
        assert grid.origin == pytest.approx((-2.1, -2.1))
        expected = _raycast_grid(env, grid)
        wrong = np.argwhere(grid.data != expected)
        assert len(wrong) == 0, wrong[:10]
        assert np.count_nonzero(grid.data == OCCUPIED) > 4 * 2 * 80  # walls and obstacles
    finally:
        env.close()


def _every_cell_grid(
    layout: ArenaLayout, arena: float, wall: float, resolution: float
) -> Grid | None:
    """The grid's rule applied to every cell (ground_truth_grid looks near each obstacle only):
    occupied where the centre is in a wall or a footprint. None where a footprint holds no
    centre (that obstacle takes the cells it touches: another rule)."""
    cells = math.ceil(round((arena + 2 * wall) / resolution, 9))
    origin = (-cells * resolution / 2.0, -cells * resolution / 2.0)
    x, y = Grid(np.zeros((cells, cells), np.int8), origin, resolution).centres
    half, edge = arena / 2.0, resolution / 2.0
    occupied = np.zeros((cells, cells), dtype=bool)
    for axis, side in ((x, 1.0), (x, -1.0), (y, 1.0), (y, -1.0)):
        wall_cells = side * axis > half
        occupied |= wall_cells if wall_cells.any() else side * axis + edge > half
    for o in layout.obstacles:
        dx, dy = x - o.x, y - o.y
        if o.kind == "cylinder":
            inside = np.hypot(dx, dy) <= o.size[0]
        else:
            c, s = math.cos(o.yaw), math.sin(o.yaw)
            local_x, local_y = c * dx + s * dy, -s * dx + c * dy
            inside = (np.abs(local_x) <= o.size[0]) & (np.abs(local_y) <= o.size[1])
        if not inside.any():
            return None
        occupied |= inside
    return Grid(np.where(occupied, OCCUPIED, 0).astype(np.int8), origin, resolution)


def test_ground_truth_looks_near_each_obstacle_and_finds_what_every_cell_does() -> None:
    env = gym.make("BubbleRob-v0", laser_num_rays=0, num_obstacles=(8, 12))
    layouts: list[ArenaLayout] = []
    for seed in range(12):
        env.reset(seed=seed)
        layouts.append(getattr(env.unwrapped, "layout"))  # noqa: B009 - typed as gym.Env
    env.close()
    # Obstacles across the grid's edge, large and rotated.
    layouts.append(ArenaLayout(
        obstacles=(
            Obstacle("box", 2.05, 0.3, 0.7, (0.45, 0.2)),
            Obstacle("cylinder", -1.95, -2.02, 0.0, (0.4, 0.2)),
        ),
        start_pose=(0.0, 0.0, 0.0),
    ))  # fmt: skip
    compared = 0
    for layout in layouts:
        for resolution in (0.05, 0.013, 0.3):
            for wall in (0.1, 0.0):
                expected = _every_cell_grid(layout, 4.0, wall, resolution)
                if expected is None:
                    continue
                grid = ground_truth_grid(layout, 4.0, wall, resolution)
                assert grid.origin == expected.origin
                np.testing.assert_array_equal(grid.data, expected.data)
                compared += 1
    assert compared >= 13 * 2 * 2


def test_mapper_marks_a_wall_hit_occupied_and_the_beam_free():
    like = Grid(np.zeros((40, 40), dtype=np.int8), (-1.0, -1.0), 0.05)
    mapper = LogOddsMapper(like)
    for _ in range(3):  # one beam along +x from the centre, hitting at x = 0.5
        mapper.add_scan((0.0, 0.0, 0.0), np.array([0.0]), np.array([0.5]), range_max=5.0)
    grid = mapper.grid()
    row = 20
    assert grid.data[row, 30] == OCCUPIED  # x = 0.5 lies in column (0.5 + 1) / 0.05 = 30
    assert (grid.data[row, 21:29] == 0).all()
    assert grid.data[row + 5, 30] == -1
    assert occupied_iou(grid, grid) == 1.0
    assert math.isclose(occupied_iou(grid, Grid(grid.data * 0, grid.origin, 0.05)), 0.0)


def test_map_of_a_recorded_laser_episode(tmp_path, capsys):
    """README's commands for docs/images/map.png, run into tmp_path: IoU >= 0.9."""
    pytest.importorskip("rosbags")
    from bubblerob_cli.main import main

    bags = tmp_path / "bags"
    assert (
        main(["record", "--policy", "laser", "--episodes", "1", "--seed", "0", "--out", str(bags)])
        == 0
    )
    capsys.readouterr()
    png = tmp_path / "map.png"
    assert main(["map", str(bags / "bubblerob_laser_seed0"), "--out", str(png)]) == 0
    out = capsys.readouterr().out
    assert "ground truth: the bag's /map" in out  # the recorder wrote the episode's /map
    iou = float(out.split("IoU of occupied cells (observed cells): ")[1].split()[0])
    print(out)
    assert iou >= 0.9, out
    assert int(out.split("scans: ")[1].split()[0]) > 500, out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_map_of_a_bag_without_map_re_simulates_the_episode(tmp_path):
    pytest.importorskip("rosbags")
    from bubblerob_env.ros import RosBagRecorder
    from bubblerob_env.ros.map_bag import map_bag
    from bubblerob_env.ros.messages.topics import Topics

    for name, topics in (("with", Topics()), ("without", Topics(map=None))):
        env = gym.make("BubbleRob-v0", max_episode_steps=20)
        with RosBagRecorder(env, tmp_path / name, topics=topics) as recorder:
            recorder.reset(seed=3)
            for _ in range(20):
                recorder.step(np.array([0.0, 0.5], dtype=np.float32))  # turn on the spot
    with_map, without = map_bag(tmp_path / "with"), map_bag(tmp_path / "without")
    assert with_map.truth_source == "the bag's /map"
    assert without.truth_source == "the re-simulated episode"
    assert np.array_equal(with_map.truth.data, without.truth.data)
    assert with_map.truth.origin == without.truth.origin
    assert with_map.iou == without.iou


def test_map_re_simulates_with_the_env_the_user_names(tmp_path, capsys):
    # A bag without /map of an env with a 3 m arena: the truth re-simulated from the metadata is
    # that arena (the oracle: a fresh env of the same kwargs and seed); --env-kwargs another
    # arena gives that one's; an env that cannot be made is one line, exit 2.
    pytest.importorskip("rosbags")
    from bubblerob_env.ros import RosBagRecorder
    from bubblerob_env.ros.map_bag import map_bag
    from bubblerob_env.ros.messages.topics import Topics

    env = gym.make("BubbleRob-v0", arena_size=3.0, max_episode_steps=5)
    with RosBagRecorder(env, tmp_path / "bag", topics=Topics(map=None)) as recorder:
        recorder.reset(seed=4)
        for _ in range(5):
            recorder.step(np.array([0.0, 0.5], dtype=np.float32))

    def truth(**kwargs: object) -> Grid:
        oracle = gym.make("BubbleRob-v0", **kwargs)
        oracle.reset(seed=4)
        return episode_grid(oracle, 0.05)

    own, other = (
        map_bag(tmp_path / "bag"),
        map_bag(tmp_path / "bag", env_kwargs={"arena_size": 4.0}),
    )
    assert np.array_equal(own.truth.data, truth(arena_size=3.0).data)
    assert np.array_equal(other.truth.data, truth(arena_size=4.0).data)
    assert own.truth.data.shape != other.truth.data.shape
    result = run(  # in process (cli_usage): an exception would fail the test
        ["map", str(tmp_path / "bag"), "--env", "Nope-v0", "--out", str(tmp_path / "m.png")],
        capsys,
    )
    assert result.code == 2 and "Traceback" not in result.err, result.err
    (line,) = result.err.strip().splitlines()
    assert "'Nope-v0'" in line and "--env ID" in line, line


@pytest.mark.parametrize("value", ["0", "abc"])
def test_map_with_a_bad_resolution_is_one_line(tmp_path, capsys, value):
    result = run(["map", str(tmp_path), "--resolution", value], capsys)
    assert result.code == 2 and "Traceback" not in result.err, result.err
    (line,) = result.err.strip().splitlines()
    assert value in line and "0.005" in line, line


def test_a_scene_without_the_arenas_walls_says_it_has_no_map(tmp_path):
    # xml_file scenes may lack the arena's walls: no ground truth, and the user is told once.
    import warnings

    from rosbags.highlevel import AnyReader

    from bubblerob_env.arena import ASSETS_DIR
    from bubblerob_env.ros import RosBagRecorder

    scene = ASSETS_DIR / "scenes" / "wall_test.xml"
    env = gym.make("BubbleRob-v0", xml_file=str(scene), num_obstacles=(0, 0),
                   start_pose=(0.0, 0.0, 0.0), max_episode_steps=3)  # fmt: skip
    bag = tmp_path / "bag"
    recorder = RosBagRecorder(env, bag)
    with pytest.warns(UserWarning, match=r"wall_test\.xml has no arena walls .*no /map"):
        recorder.reset(seed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # once per recording, not every episode
        recorder.reset(seed=1)
    recorder.close()
    with AnyReader([bag]) as reader:
        counts = {connection.topic: connection.msgcount for connection in reader.connections}
    assert counts["/scan"] == 2 and counts.get("/map", 0) == 0, counts
