"""``bubblerob map BAG``: a bag's scans mapped beside the truth (library: ``ros.map_bag``)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from bubblerob_cli.args import env_kwargs_json
from bubblerob_cli.errors import report
from bubblerob_cli.outputs import Output, add_overwrite_option, check_outputs
from bubblerob_env.mapping import DEFAULT_RESOLUTION, check_resolution
from bubblerob_env.ros.map_bag import MapError, map_bag, map_png

__all__ = ["add_subcommands"]


def add_subcommands(subparsers: Any) -> None:
    """Add ``map`` to the ``bubblerob`` command."""
    parser = subparsers.add_parser(
        "map",
        help="occupancy grid from a bag's /scan and /tf, beside the ground truth, with the IoU",
        description="Build an occupancy grid from a recorded bag's /scan and /tf (log odds), "
        "write a PNG of it beside the episode's ground-truth grid and print the IoU of the "
        "occupied cells over the cells the scans observed (and over all cells).",
    )
    parser.add_argument("bag", help="the bag (ROS 1 .bag file or ROS 2 directory)")
    parser.add_argument("--episode", type=int, default=0, help="index of the episode to map")
    parser.add_argument("--resolution", default=DEFAULT_RESOLUTION, help="m/cell, 0.005 to 1")
    parser.add_argument("--out", default="map.png", help="PNG to write")
    add_overwrite_option(parser)
    parser.add_argument(
        "--robot", default=None, help="a record --robots bag: the robot to map (robot_1)"
    )
    parser.add_argument(
        "--env",
        metavar="ID",
        help="re-simulate the ground truth in this env id instead of the one the episode's "
        "metadata names (instead of the bag's /map too)",
    )
    parser.add_argument(
        "--env-kwargs",
        type=env_kwargs_json,
        metavar="JSON",
        help="re-simulate the ground truth with these gym.make keyword arguments instead of "
        "the metadata's (instead of the bag's /map too), e.g. '{\"arena_size\": 3.0}'",
    )
    parser.set_defaults(handler=_run)


def _run(args: argparse.Namespace) -> int:
    try:
        resolution = check_resolution(args.resolution)
        if args.episode < 0:
            raise MapError(f"--episode must be an episode index >= 0, got {args.episode}")
        check_outputs(
            [Output("--out", Path(args.out), (".png",))], args.overwrite, inputs=[args.bag]
        )
    except ValueError as error:  # OutputError too
        report("map", str(error))
        return 2
    try:
        result = map_bag(
            args.bag, args.episode, resolution, args.env, args.env_kwargs, robot=args.robot
        )
    except (OSError, MapError) as error:
        report("map", str(error))
        return 2
    try:
        out = map_png(result, args.out)
    except (OSError, ValueError) as error:  # imageio: ValueError for an unknown extension
        reason = error.strerror if isinstance(error, OSError) and error.strerror else error
        report("map", f"cannot write --out {args.out}: {reason}")
        return 1
    print(f"ground truth: {result.truth_source}")
    print(f"scans: {result.scans}")
    for label, iou in (("observed cells", result.iou), ("all cells", result.iou_all)):
        shown = f"n/a ({result.missing})" if iou is None else f"{iou:.3f}"
        print(f"IoU of occupied cells ({label}): {shown}")
    print(f"wrote {out} (mapped left, ground truth right)")
    if result.missing:
        report("map", f"no IoU: {result.missing}")
        return 1
    return 0
