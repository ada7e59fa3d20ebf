"""``bubblerob node --ros 2 --localize`` seen by real rclpy (issue #27 item 4), as on ROS 1.

The node drives a 1.4 m circle at 5x real time with drifting odometry; an rclpy client compares
``/amcl_pose`` with ``/base_pose_ground_truth`` at the same stamps (mean errors <= 0.05 m and
0.05 rad), checks ``/particlecloud``, ``map -> odom`` on ``/tf`` and not on ``/tf_static``, sends
malformed ``/initialpose`` messages (CDR too short, NaN, another frame) that the node reports and
ignores, then a valid one 0.5 m off the truth, to which the estimate jumps.
"""

from __future__ import annotations

import pytest
from live_support import (
    INITIALPOSE_REJECTIONS,
    LOCALIZE_NODE_ARGS,
    distances_to_target,
    odometry_drift,
    tracking_errors,
)
from ros2_helpers import client, wait_for


@pytest.fixture(scope="module")
def localised(start_node):
    node = start_node(*LOCALIZE_NODE_ARGS)
    return node, client("localize", "--sim-seconds", "17", timeout=90)


def test_amcl_pose_tracks_the_truth_while_odometry_drifts(localised):
    node, got = localised
    assert node.alive(), node.output
    drift = odometry_drift(got)
    assert drift >= 0.2, drift
    position, yaw = tracking_errors(got)
    assert position.mean() <= 0.05 and yaw.mean() <= 0.05, (position.mean(), yaw.mean())
    assert got["amcl_frame"] == got["cloud_frame"] == "map"
    assert got["clouds"] >= 20 and got["cloud_size"] >= 300
    assert got["tf_map_odom"] >= 20
    assert ["map", "odom"] not in got["tf_static"]
    assert ["base_link", "laser_link"] in got["tf_static"]


def test_initialpose_moves_the_estimate_and_malformed_ones_are_ignored(localised):
    node, got = localised
    assert min(distances_to_target(got)) <= 0.15, (got["after"], got["target"])
    assert node.alive(), node.output
    rejected = INITIALPOSE_REJECTIONS
    assert wait_for(lambda: all(r in node.output for r in rejected), 5), node.output
