"""Kind 1 of issue #38: no score over nothing. ``map``, ``detect`` and ``localize`` print ``n/a``
with the reason and exit non-zero where a figure's denominator is zero, and read a bag recorded
with ``--topics vrep`` or ``--namespace`` as they read a default one.

Oracles: the same episode recorded under three topic namings maps to the same IoU; a Hypothesis
property over the scorers' counts: every figure they give as a number has a denominator > 0.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from reliability_helpers import one_line, run

from bubblerob_env.mapping import OCCUPIED, UNKNOWN, Grid
from bubblerob_env.ros.detect import DetectReport
from bubblerob_env.ros.map_bag import MapResult
from bubblerob_env.ros.messages.topics import Topics, topics_preset
from bubblerob_env.vision.scoring import Score


def _iou_line(stdout: str) -> str:
    return next(line for line in stdout.splitlines() if "(observed cells)" in line)


def test_map_reads_vrep_and_namespaced_bags_as_default_ones(short_bag, tmp_path: Path) -> None:
    lines = []
    for topics in (None, topics_preset("vrep"), topics_preset("default", "robot2")):
        status, out, err = run(
            "map", str(short_bag(topics=topics)), "--out", str(tmp_path / "m.png"), "--overwrite"
        )
        assert status == 0, err
        assert "scans: 13" in out
        lines.append(_iou_line(out))
    assert len(set(lines)) == 1 and "n/a" not in lines[0]


def test_map_without_scans_is_na_and_exit_1(short_bag, tmp_path: Path) -> None:
    for bag in (short_bag(laser_num_rays=0), short_bag(topics=Topics(scan=None))):
        status, out, err = run("map", str(bag), "--out", str(tmp_path / "m.png"), "--overwrite")
        assert status == 1, (out, err)
        assert "n/a (no scan was placed" in _iou_line(out)
        assert one_line(err) and "bubblerob map: no IoU" in err


def test_map_env_options_are_honoured_or_refused(short_bag, tmp_path: Path) -> None:
    bag, out = str(short_bag()), str(tmp_path / "m.png")
    status, stdout, _ = run("map", bag, "--out", out, "--env-kwargs", '{"arena_size": 4.0}')
    assert status == 0 and "ground truth: the re-simulated episode" in stdout
    for bad in (
        ["--env", "Bogus-v9"],
        ["--env-kwargs", '{"arena_size": -3}'],
        ["--env-kwargs", '{"foo": 1}'],
    ):
        status, _, err = run("map", bag, "--out", out, "--overwrite", *bad)
        assert status == 2 and one_line(err), (bad, err)


def test_detect_on_a_camera_that_sees_nothing_is_na_and_exit_1(short_bag) -> None:
    bag = short_bag(camera_width=1, camera_height=1)
    status, out, err = run("detect", str(bag))
    assert status == 1
    assert "precision n/a (no detection" in out and "recall n/a (no object" in out
    assert one_line(err) and "1.000" not in out


def test_localize_refuses_drifting_odometry_as_its_truth(short_bag, tmp_path: Path) -> None:
    bag = short_bag(odometry_noise=0.1, topics=Topics(base_pose_ground_truth=None))
    status, out, err = run("localize", str(bag), "--out", str(tmp_path / "l.png"))
    assert status == 2 and out == ""
    assert one_line(err) and "no /base_pose_ground_truth" in err


cells = st.lists(st.sampled_from([UNKNOWN, 0, OCCUPIED]), min_size=16, max_size=16)


@settings(max_examples=60, deadline=None)
@given(
    mapped=cells,
    truth=st.lists(st.sampled_from([0, OCCUPIED]), min_size=16, max_size=16),
    scans=st.integers(0, 3),
)
def test_every_iou_has_a_cell_in_its_union(mapped: list[int], truth: list[int], scans: int) -> None:
    def grid(values: list[int]) -> Grid:
        return Grid(np.array(values, dtype=np.int8).reshape(4, 4), (0.0, 0.0), 0.5)

    result = MapResult(grid(mapped), grid(truth), scans)
    observed = np.array(mapped) != UNKNOWN
    union = (np.array(mapped) == OCCUPIED) | (observed & (np.array(truth) == OCCUPIED))
    if result.iou is not None:
        assert scans > 0 and union.any() and OCCUPIED in truth
    else:
        assert result.missing and result.iou_all is None


@settings(max_examples=60, deadline=None)
@given(
    tp=st.integers(0, 3), fp=st.integers(0, 3), missed=st.integers(0, 3), paired=st.integers(0, 3)
)
def test_every_detection_figure_has_a_denominator(
    tp: int, fp: int, missed: int, paired: int
) -> None:
    score = Score(images=1, true_positives=tp, false_positives=fp, missed=missed)
    score.bearing_errors = [1.0] * min(paired, tp)
    score.distance_errors = [0.1] * min(paired, tp)
    summary = DetectReport(Path("bag"), 1, score).to_dict()
    denominators = {
        "precision": tp + fp,
        "recall": tp + missed,
        "class_accuracy": tp,
        "bearing_error_mean_deg": len(score.bearing_errors),
        "distance_error_mean_relative": len(score.distance_errors),
    }
    for key, count in denominators.items():
        assert (summary[key] is None) == (count == 0), key
