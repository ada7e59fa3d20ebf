"""``bubblerob teleop``: drive BubbleRob from the keyboard in a terminal (curses), at real time.

Keys: Up/Down or W/S change the forward speed, Left/Right or A/D change the turn rate, space
stops, q quits (:mod:`bubblerob_cli.teleop.keys`). Locally (:mod:`bubblerob_cli.teleop.sim`) the
env runs in twist mode at its own control rate (20 Hz by default), paced to wall-clock time.
``--record DIR`` wraps the env in the ROS bag recorder (the ``ros`` extra, imported only then). At
exit one line ``final pose: x=.. y=.. yaw=..`` is printed. ``--ros 1|2`` drives a running
``bubblerob node`` instead (:mod:`bubblerob_cli.teleop.ros`), with the limits of the env that
``--env`` and ``--env-kwargs`` make and the node's ``--topics`` names.
"""

from __future__ import annotations

import argparse
import curses
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym

from bubblerob_cli.args import add_env_arguments, make_env
from bubblerob_cli.errors import fail
from bubblerob_cli.outputs import Output, add_overwrite_option, require_outputs
from bubblerob_cli.teleop.ros import RosLink, run_ros_teleop
from bubblerob_cli.teleop.sim import run_teleop
from bubblerob_env.extras import require_extra

__all__ = ["add_subcommands", "ros_limits"]

_MAX_SEED = 2**63 - 1  # NumPy seeds are ints >= 0; bags keep them as int64


def ros_limits(args: argparse.Namespace) -> tuple[float, float]:
    """The robot's top speed (m/s) and turn rate (rad/s): those of ``--env``, as the node's."""
    env = make_env("teleop", args.env, args.env_kwargs)
    base: Any = env.unwrapped
    limits = (float(base.max_linear_speed), float(base.max_angular_speed))
    env.close()
    return limits


def _require_terminal(close: Callable[[], object]) -> None:
    """Exit 2 with one line if there is no terminal to read keys from (``close()`` first)."""
    if sys.stdin.isatty() and sys.stdout.isatty():
        return
    try:
        fail(
            "teleop",
            "needs a terminal to read keys from (run it in one, not with piped input or output)",
        )
    finally:
        close()


def _run_ros(args: argparse.Namespace) -> int:
    """``--ros 1|2``: drive a live node; one line and exit 2 if ROS cannot be reached."""
    require_extra("ros", f"bubblerob teleop --ros {args.ros}")
    from bubblerob_env.ros.live.backend import BackendError
    from bubblerob_env.ros.messages.topics import topics_preset

    local = (args.record, args.start_pose, args.num_obstacles, args.overwrite or None)
    if any(option is not None for option in local):
        fail(
            "teleop",
            "--record, --overwrite, --start-pose and --num-obstacles are for the local "
            "simulation; with --ros "
            "give them to `bubblerob node` (--env-kwargs, rosbag record)",
        )
    try:
        topics = topics_preset(args.topics, args.namespace)
    except ValueError as error:
        fail("teleop", f"--topics: {error}")
    limits = ros_limits(args)  # the node's env: --env and --env-kwargs as it was given them
    try:
        link = RosLink(args.ros, topics, *limits)
    except BackendError as error:
        fail("teleop", str(error))
    _require_terminal(link.close)
    try:
        curses.wrapper(run_ros_teleop, link, args.max_seconds)
    except KeyboardInterrupt:  # Ctrl-C: as q (the robot is stopped below)
        pass
    finally:
        link.close()
    pose = link.pose
    if pose is None:
        print(f"final pose: unknown (nothing on the node's {link.odom_topic})")
    else:
        print(f"final pose: x={pose[0]:.4f} y={pose[1]:.4f} yaw={pose[2]:.4f} (odom)")
    return 0


def _recorded(env: gym.Env[Any, Any], record: str, overwrite: bool) -> gym.Env[Any, Any]:
    """``env`` wrapped in the bag recorder that writes ``record`` (checked before: exit 2)."""
    require_extra("ros", "bubblerob teleop --record")
    from bubblerob_env.ros import RosBagRecorder

    try:
        return RosBagRecorder(env, record, overwrite=overwrite, metadata={"policy": "teleop"})
    except FileExistsError:  # made since the check: a usage error, exit 2
        env.close()
        fail("teleop", f"bag {record} already exists; pass --overwrite to replace it")


def _run(args: argparse.Namespace) -> int:
    if args.seed is not None and not 0 <= args.seed <= _MAX_SEED:
        fail("teleop", f"--seed must be from 0 to {_MAX_SEED}, got {args.seed}")
    if args.robot is not None and args.ros is not None:
        args.namespace = args.robot  # `bubblerob node --robots N`: robot i under /robot_i
    if args.ros is not None:
        return _run_ros(args)
    if args.robots != 1 or args.robot is not None:
        from bubblerob_cli.teleop.robots import run_world_teleop

        return run_world_teleop(args)
    kwargs: dict[str, Any] = {"action_type": "twist"}  # the keys drive speed and turn rate
    if args.start_pose is not None:
        kwargs["start_pose"] = tuple(args.start_pose)
    if args.num_obstacles is not None:
        kwargs["num_obstacles"] = tuple(args.num_obstacles)
    if args.record is not None:  # before the env: an existing bag without --overwrite
        bag = Output("--record", Path(args.record), kind="bag")
        require_outputs("teleop", [bag], args.overwrite)
    env: gym.Env[Any, Any] = make_env("teleop", args.env, args.env_kwargs, **kwargs)
    _require_terminal(env.close)  # before a bag is started
    if args.record is not None:
        env = _recorded(env, args.record, args.overwrite)
    try:
        info = curses.wrapper(run_teleop, env, args.seed, args.max_seconds)
    finally:
        env.close()  # with --record: the bag is closed, every finished episode readable
    print(f"final pose: x={info['x']:.4f} y={info['y']:.4f} yaw={info['yaw']:.4f}")
    if args.record is not None:
        print(f"recorded: {args.record}")
    return 0


def _add_local_options(parser: argparse.ArgumentParser) -> None:
    """The options of the local simulation: the first reset, its start and obstacles, a bag."""
    parser.add_argument("--seed", type=int, default=None, help="seed of the first reset")
    parser.add_argument(
        "--start-pose",
        type=float,
        nargs=3,
        metavar=("X", "Y", "YAW"),
        default=None,
        help="fixed start pose (m, m, rad); default: random",
    )
    parser.add_argument(
        "--num-obstacles",
        type=int,
        nargs=2,
        metavar=("MIN", "MAX"),
        default=None,
        help="inclusive range of obstacles per episode; default: the env's (4 10)",
    )
    parser.add_argument(
        "--record", metavar="DIR", default=None, help="record the drive as a bag (ros extra)"
    )
    add_overwrite_option(parser)


def _add_ros_options(parser: argparse.ArgumentParser) -> None:
    """``--ros``, ``--namespace`` and ``--topics``: which live node to drive."""
    parser.add_argument(
        "--ros",
        type=int,
        choices=(1, 2),
        default=None,
        help="publish cmd_vel to a running `bubblerob node --ros N` instead of simulating "
        "(2: run it with .venv-ros2's bubblerob); give --env, --env-kwargs and --topics as the "
        "node has them (its top speed and turn rate, its topic names)",
    )
    parser.add_argument(
        "--namespace",
        default=os.environ.get("ROS_NAMESPACE", ""),
        help="with --ros: the node's namespace (default: $ROS_NAMESPACE)",
    )
    parser.add_argument(
        "--topics",
        default="default",
        metavar="PRESET",
        help="with --ros: the node's topic names, its --topics (default or vrep: /vrep/cmd_vel, "
        "/vrep/scan)",
    )


def add_subcommands(subparsers: Any) -> None:
    """Add ``teleop`` to the ``bubblerob`` command."""
    parser = subparsers.add_parser(
        "teleop",
        help="drive the robot from the keyboard in a terminal (real time)",
        description="Drive BubbleRob from the keyboard: Up/Down or W/S change the forward speed, "
        "Left/Right or A/D the turn rate (steps of 0.1 of the limits), space stops, q quits. "
        "The status line shows speed, the nearest laser reading and collisions; the final pose "
        "is printed at exit.",
    )
    _add_local_options(parser)
    add_env_arguments(parser)
    _add_ros_options(parser)
    parser.add_argument(
        "--robots", type=int, default=1, metavar="N", help="N robots in one world (local)"
    )
    parser.add_argument(
        "--robot",
        default=None,
        metavar="NAME",
        help="the robot the keys drive (robot_1); locally the others follow --policy; with "
        "--ros: that robot of `bubblerob node --robots N` (its /robot_i namespace)",
    )
    parser.add_argument(
        "--policy",
        default="reactive",
        help="with --robots: what drives the other robots (default reactive)",
    )
    parser.add_argument(
        "--max-seconds",
        type=float,
        default=None,
        help="quit after this many wall-clock seconds; default: only on q",
    )
    parser.set_defaults(handler=_run)
