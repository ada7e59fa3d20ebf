"""``bubblerob detect BAG``: the recogniser scored on a bag's images (library: ``ros.detect``)."""

from __future__ import annotations

import argparse
import json
from typing import Any

from bubblerob_cli.errors import report
from bubblerob_env.ros.detect import DetectError, detect_bag
from bubblerob_env.ros.messages.topics import MSGTYPES

__all__ = ["add_subcommands"]

_HEADLINE = ("precision", "recall", "class_accuracy")


def add_subcommands(subparsers: Any) -> None:
    """Add ``detect`` to the ``bubblerob`` command."""
    parser = subparsers.add_parser(
        "detect",
        help="score the obstacle recogniser on a recorded bag's camera images",
        description="Run the recogniser over every camera image of a bag and score it "
        "against the ground truth of the same frames, re-simulated from the episodes' metadata: "
        "precision, recall, class accuracy and bearing error over objects of >= 50 pixels. "
        f"The bag needs the camera ({MSGTYPES['image']}); obstacles are recognisable when "
        "the env paints them (--env-kwargs '{\"obstacle_colours\": true}' when recording).",
    )
    parser.add_argument("bag", help="the bag: a ROS 1 .bag or a ROS 2 bag folder")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.set_defaults(handler=_detect)


def _detect(args: argparse.Namespace) -> int:
    try:
        result = detect_bag(args.bag)
    except (DetectError, OSError) as error:
        report("detect", str(error))
        return 2
    print(json.dumps(result.to_dict(), sort_keys=True) if args.json else result)
    if result.headline_missing:
        missing = ", ".join(name for name in result.missing() if name in _HEADLINE)
        report("detect", f"no score: {missing} n/a over nothing (reasons above)")
        return 1
    return 0
