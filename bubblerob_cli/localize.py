"""``bubblerob localize BAG``: the particle filter over a bag (library: ``ros.localize``)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from bubblerob_cli.errors import report
from bubblerob_cli.outputs import Output, OutputError, add_overwrite_option, check_outputs
from bubblerob_env.png import write_png
from bubblerob_env.ros import localize
from bubblerob_env.ros.localize_bag import LocalizeBagError, read_bag_episodes

__all__ = ["add_subcommands"]


def add_subcommands(subparsers: Any) -> None:
    """Add ``localize`` to the ``bubblerob`` command."""
    parser = subparsers.add_parser(
        "localize",
        help="run the particle filter (AMCL-like) over a bag and score it against the truth",
        description="Localise the robot of every episode of a bag on its /map with the particle "
        "filter, from /scan, odom -> base_link on /tf (or /odom) and /tf_static, and compare "
        "with /base_pose_ground_truth (record with --env-kwargs '{\"odometry_noise\": 0.1}' "
        "for odometry that drifts). Prints the errors after convergence and writes a PNG of "
        "the true path (green), the odometry (red) and the estimate (blue) on the map.",
    )
    parser.add_argument("bag", help="a .bag, .mcap or .db3 file, or a ROS 2 bag folder")
    parser.add_argument(
        "--global",
        dest="global_start",
        action="store_true",
        help="global localisation: particles over all the free space instead of at the start",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument(
        "--robot", default=None, help="a record --robots bag: the robot to localise (robot_1)"
    )
    parser.add_argument(
        "--out", default=None, help="PNG to write (default: beside the bag, BAG.localize.png)"
    )
    add_overwrite_option(parser)
    parser.add_argument("--seed", type=int, default=0, help="the filter's seed (episode k: +k)")
    parser.set_defaults(handler=_run)


def _text(summary: dict[str, Any]) -> str:
    def metres(v: float | None, unit: str, scale: float) -> str:
        return "n/a (never converged)" if v is None else f"{v * scale:.1f} {unit}"

    lines = [f"{summary['episodes']} episode(s), {summary['mode']}; truth: {summary['truth']}"]
    lines.append("episode  seed  converged after  position error  yaw error  odometry off at end")
    for e in summary["per_episode"]:
        after = e["converged_after_s"]
        lines.append(
            f"{e['episode']:>7}  {e['seed']:>4}  "
            f"{'never' if after is None else f'{after:.2f} s':>15}  "
            f"{metres(e['position_error_mean_m'], 'cm', 100):>14}  "
            f"{metres(e['yaw_error_mean_rad'], 'mrad', 1000):>9}  "
            f"{e['odometry_error_final_m']:.2f} m"
        )
    lines.append(
        f"mean: position {metres(summary['position_error_mean_m'], 'cm', 100)}, yaw "
        f"{metres(summary['yaw_error_mean_rad'], 'mrad', 1000)} after convergence; converged "
        f"within 10 s in {summary['converged_within_10s']:.0%}; raw odometry off by "
        f"{summary['odometry_error_final_m']:.2f} m at the end"
    )
    return "\n".join(lines)


def _run(args: argparse.Namespace) -> int:
    try:
        if not 0 <= args.seed <= 2**63 - 1:
            raise LocalizeBagError(f"--seed must be an int from 0 to {2**63 - 1}, got {args.seed}")
        out = Path(args.out) if args.out is not None else localize.default_png(args.bag)
        check_outputs([Output("--out", out, (".png",))], args.overwrite, inputs=[args.bag])
        bag = read_bag_episodes(args.bag, args.robot)
    except (OSError, LocalizeBagError, OutputError) as error:
        report("localize", str(error))
        return 2
    results = localize.localize_bag(bag, args.global_start, args.seed)
    summary = localize.report(bag, results, args.global_start)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        write_png(out, localize.picture(bag, results))
    except OSError as error:
        report("localize", f"cannot write --out {out}: {error.strerror}")
        return 1
    summary["png"] = str(out)
    if args.json:
        print(json.dumps(summary))
    else:
        print(_text(summary))
        print(f"wrote {out} (green: truth, red: odometry, blue: estimate)")
    if summary["position_error_mean_m"] is None:
        report("localize", "no error after convergence: no episode converged (n/a)")
        return 1
    return 0
