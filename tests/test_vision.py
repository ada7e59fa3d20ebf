"""Issue #28: coloured obstacles, the camera's ground truth, the recogniser and its score."""

from __future__ import annotations

import importlib.util
import json
import math
import re
from pathlib import Path
from types import ModuleType

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import bubblerob_env  # noqa: F401
from bubblerob_env.arena import (
    DEFAULT_SCENE,
    OBSTACLE_PALETTE,
    Obstacle,
    ObstacleSlots,
    build_model,
)
from bubblerob_env.sensors import CameraSensor, CameraSpec
from bubblerob_env.vision.evaluation import labelled_frames
from bubblerob_env.vision.geometry import CameraPose, bearing_to_column, column_to_bearing
from bubblerob_env.vision.ground_truth import GroundTruthCamera, LabelledObject
from bubblerob_env.vision.recognise import Detection, Recogniser
from bubblerob_env.vision.scoring import Score, box_iou

ROOT = Path(__file__).resolve().parents[1]


def test_colours_leave_the_layout_and_default_episodes_alone() -> None:
    plain = gym.make("BubbleRob-v0", laser_noise_std=0.01)
    coloured = gym.make("BubbleRob-v0", laser_noise_std=0.01, obstacle_colours=True)
    default_again = gym.make("BubbleRob-v0", laser_noise_std=0.01, obstacle_colours=False)
    for seed in (0, 1):
        obs_plain, _ = plain.reset(seed=seed)
        coloured.reset(seed=seed)
        obs_default, _ = default_again.reset(seed=seed)
        np.testing.assert_array_equal(obs_plain["laser"], obs_default["laser"])
        plain_layout = plain.unwrapped.layout  # type: ignore[attr-defined]
        coloured_layout = coloured.unwrapped.layout  # type: ignore[attr-defined]
        assert all(o.colour is None for o in plain_layout.obstacles)
        assert [o.colour in OBSTACLE_PALETTE for o in coloured_layout.obstacles] == [True] * len(
            coloured_layout.obstacles
        )
        assert [(o.kind, o.x, o.y, o.yaw, o.size) for o in coloured_layout.obstacles] == [
            (o.kind, o.x, o.y, o.yaw, o.size) for o in plain_layout.obstacles
        ]
    with pytest.raises(ValueError, match="obstacle_colours must be True or False, got 'yes'"):
        gym.make("BubbleRob-v0", obstacle_colours="yes")


def test_bearing_and_columns_agree_with_the_pose() -> None:
    env = gym.make("BubbleRob-v0", camera=True, start_pose=(0.0, 0.0, math.pi / 2))
    env.reset(seed=0)
    core = env.unwrapped
    pose = CameraPose.of(core.model, core.data)  # type: ignore[attr-defined]
    assert pose.heading == pytest.approx(math.pi / 2, abs=1e-9)
    ahead = (pose.x, pose.y + 1.0)
    assert pose.bearing(*ahead) == pytest.approx(0.0, abs=1e-9)
    assert pose.bearing(pose.x - 1.0, pose.y + 1.0) == pytest.approx(math.pi / 4)  # left: +
    assert pose.distance(*ahead) == pytest.approx(1.0)
    assert bearing_to_column(column_to_bearing(10.25, 64, 55.4), 64, 55.4) == pytest.approx(10.25)
    assert column_to_bearing(31.5, 64, 55.4) == 0.0
    env.close()


def test_ground_truth_pixels_show_the_obstacles_colour_and_hold_its_bearing() -> None:
    env = gym.make("BubbleRob-v0", camera_width=96, camera_height=96, obstacle_colours=True)
    core = env.unwrapped
    truth = GroundTruthCamera(core.model, core.camera_spec)  # type: ignore[attr-defined]
    checked = 0
    for seed in (1, 4):
        obs, _ = env.reset(seed=seed)
        segmentation = truth.segment(core.data)  # type: ignore[attr-defined]
        for obj in truth.label(core):
            if obj.kind == "wall" or obj.pixels < 50:
                continue
            u_min, v_min, u_max, v_max = obj.box
            patch = obs["camera"][v_min : v_max + 1, u_min : u_max + 1].astype(float)
            mask = segmentation[v_min : v_max + 1, u_min : u_max + 1] == obj.geom_id
            assert int(mask.sum()) == obj.pixels
            colour = patch[mask].mean(axis=0)
            assert obj.colour is not None
            expected = np.array(OBSTACLE_PALETTE[obj.colour], dtype=float)
            cosine = colour @ expected / np.linalg.norm(colour) / np.linalg.norm(expected)
            assert cosine > 0.97, (seed, obj)  # shading scales the palette colour
            if obj.kind == "cylinder" and u_min > 0 and u_max < 95:
                column = bearing_to_column(obj.bearing, 96, core.camera_spec.focal_length)  # type: ignore[attr-defined]
                assert u_min <= column <= u_max, (seed, obj)
            checked += 1
    assert checked >= 3
    truth.close()
    env.close()


def test_recogniser_finds_the_labelled_obstacles() -> None:
    score = Score()
    frames = list(labelled_frames([0, 3], 64, 64, steps=20, every=10))
    for frame, recogniser in frames:
        score.add(recogniser(frame.image), frame.truths)
    summary = score.summary()
    assert summary["objects"] >= 10
    assert summary["precision"] >= 0.9 and summary["recall"] >= 0.9
    assert summary["class_accuracy"] >= 0.9
    assert summary["bearing_error_mean_deg_in_view"] <= 2.0
    recogniser = frames[0][1]
    with pytest.raises(ValueError, match=r"frame shape \(32, 32, 3\) is not the camera's"):
        recogniser(np.zeros((32, 32, 3), np.uint8))
    assert recogniser(np.full((64, 64, 3), 200, np.uint8)) == []  # grey: nothing
    no_camera = gym.make("BubbleRob-v0")
    no_camera.reset(seed=0)
    with pytest.raises(ValueError, match="the env has no camera: make it with camera=True"):
        Recogniser.for_env(no_camera.unwrapped)


@pytest.mark.parametrize("kind", ["cylinder", "box"])
def test_recogniser_tells_a_cylinder_from_a_box_by_shading(kind: str) -> None:
    model, _ = build_model(DEFAULT_SCENE, 4.0, 1)
    data = mujoco.MjData(model)
    size = (0.2,) if kind == "cylinder" else (0.2, 0.15)
    obstacle = Obstacle(kind, 1.0, 0.2, 0.5, size, "green")
    ObstacleSlots(model, 1).apply(model, data, (obstacle,))
    mujoco.mj_forward(model, data)  # the robot at its compiled pose, looking along +x
    spec = CameraSpec(64, 64, 60.0)
    camera = CameraSensor(model, spec)
    pose = CameraPose.of(model, data)
    found = Recogniser(spec, pose.z, 0.3)(camera(model, data))
    camera.close()
    found = [d for d in found if d.kind != "wall"]
    assert [(d.kind, d.colour) for d in found] == [(kind, "green")]
    # A cylinder's silhouette is symmetric about its axis; a box's is not, and the recogniser
    # gives the bearing of the silhouette's middle (here 1.7 degrees off the centre's).
    tolerance = 0.5 if kind == "cylinder" else 2.5
    assert math.degrees(abs(found[0].bearing - pose.bearing(1.0, 0.2))) < tolerance
    assert found[0].distance == pytest.approx(pose.distance(1.0, 0.2), rel=0.15)


def _truth(kind: str, box: tuple[int, int, int, int], pixels: int) -> LabelledObject:
    return LabelledObject(kind, "obstacle_0", "red", box, pixels, 0.0, 1.0)


def _detection(kind: str, box: tuple[int, int, int, int], pixels: int) -> Detection:
    return Detection(kind, "red", box, pixels, math.radians(1.0), 1.1, False)


def test_score_counts_pairs_misses_and_false_positives() -> None:
    assert box_iou((0, 0, 9, 9), (0, 0, 9, 9)) == 1.0
    assert box_iou((0, 0, 9, 9), (5, 0, 14, 9)) == pytest.approx(50 / 150)
    assert box_iou((0, 0, 1, 1), (2, 2, 3, 3)) == 0.0
    score = Score()
    truths = [
        _truth("box", (0, 0, 9, 9), 100),  # found, right class
        _truth("cylinder", (20, 0, 29, 9), 100),  # found as a box
        _truth("box", (40, 0, 49, 9), 100),  # missed
        _truth("box", (60, 0, 62, 2), 9),  # too small to count, found or not
    ]
    detections = [
        _detection("box", (0, 0, 9, 9), 100),
        _detection("box", (21, 0, 29, 9), 90),
        _detection("box", (60, 0, 62, 2), 9),
        _detection("cylinder", (0, 40, 9, 49), 100),  # nothing there
    ]
    score.add(detections, truths)
    summary = score.summary()
    assert (score.true_positives, score.false_positives, score.missed) == (2, 1, 1)
    assert summary["precision"] == pytest.approx(2 / 3)
    assert summary["recall"] == pytest.approx(2 / 3)
    assert summary["class_accuracy"] == pytest.approx(0.5)
    assert summary["bearing_error_mean_deg"] == pytest.approx(1.0)
    assert summary["distance_error_mean_relative"] == pytest.approx(0.1)


def _bench_module() -> ModuleType:
    spec = importlib.util.spec_from_file_location(
        "bench_recognition", ROOT / "bench" / "recognition.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_benchmark_prints_json(capsys: pytest.CaptureFixture[str]) -> None:
    bench = _bench_module()
    assert bench.main(["--seeds", "5-5", "--sizes", "48", "--json"]) == 0
    (row,) = json.loads(capsys.readouterr().out)
    assert row["seeds"] == "5-5" and row["size"] == "48x48" and row["images"] >= 1
    assert row["frames_per_s"] > 0
    with pytest.raises(SystemExit) as exit_info:
        bench.main(["--sizes", "2"])
    assert exit_info.value.code == 2
    assert "--sizes must be in [16, 1024] pixels, got 2" in capsys.readouterr().err


def test_readme_recognise_example_runs(capsys: pytest.CaptureFixture[str]) -> None:
    readme = (ROOT / "README.md").read_text()
    section = readme.split("## Recognise\n", 1)[1].split("\n## ", 1)[0]
    code = section.split("```python\n", 1)[1].split("```", 1)[0]
    exec(compile(code, "README.md", "exec"), {"__name__": "readme"})
    printed = re.search(r"```\n(seen .*?)```", section, flags=re.DOTALL)
    assert printed is not None
    assert capsys.readouterr().out == printed.group(1)


@pytest.mark.parametrize("left_edge", [True, False])
def test_cut_cylinder_is_solved_from_one_edge_and_its_brightest_point(left_edge: bool) -> None:
    # A circle of radius 0.2 m whose axis is 1.2 m ahead and 0.5 m to the side (camera frame:
    # depth forward, lateral positive left); the edge in view is the tangent on the other side.
    from bubblerob_env.vision.recognise import _cylinder_from_edge

    radius, depth, lateral = 0.2, 1.2, (-0.5 if left_edge else 0.5)
    distance = math.hypot(depth, lateral)
    centre_bearing = math.atan2(lateral, depth)
    edge = centre_bearing + (1 if left_edge else -1) * math.asin(radius / distance)
    bright = math.atan2(lateral, depth - radius)  # the point whose normal faces the camera
    bearing, found_distance = _cylinder_from_edge(depth - radius, bright, edge, left_edge)
    assert bearing == pytest.approx(centre_bearing, abs=1e-12)
    assert found_distance == pytest.approx(distance, abs=1e-12)
