"""``bubblerob teleop``: drive BubbleRob from the keyboard in a terminal (curses), at real time.

Keys: Up/Down or W/S change the forward speed, Left/Right or A/D change the turn rate, space
stops, q quits. A status line shows the commanded and measured speed, the nearest laser reading
and the collisions so far. The env runs in twist mode at its own control rate (20 Hz by default),
paced to wall-clock time. ``--record DIR`` wraps the env in the ROS bag recorder (the ``ros``
extra, imported only then). At exit one line ``final pose: x=.. y=.. yaw=..`` is printed.
``--ros 1|2`` drives a running ``bubblerob node`` instead (:mod:`policies.teleop_ros`), with the
limits of the env that ``--env`` and ``--env-kwargs`` make and the node's ``--topics`` names.
"""

from __future__ import annotations

import argparse
import curses
import os
import sys
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

__all__ = ["KEYS", "TeleopState", "add_subcommands", "run_teleop"]

LINEAR_STEP = 0.1
"""Change of the forward command per key press, as a fraction of ``max_linear_speed``."""
ANGULAR_STEP = 0.1
"""Change of the turn command per key press, as a fraction of ``max_angular_speed``."""

KEYS: dict[int, tuple[float, float] | str] = {
    curses.KEY_UP: (LINEAR_STEP, 0.0),
    ord("w"): (LINEAR_STEP, 0.0),
    curses.KEY_DOWN: (-LINEAR_STEP, 0.0),
    ord("s"): (-LINEAR_STEP, 0.0),
    curses.KEY_LEFT: (0.0, ANGULAR_STEP),
    ord("a"): (0.0, ANGULAR_STEP),
    curses.KEY_RIGHT: (0.0, -ANGULAR_STEP),
    ord("d"): (0.0, -ANGULAR_STEP),
    ord(" "): "stop",
    ord("q"): "quit",
}


class TeleopState:
    """The commanded twist, as fractions of the env's limits, changed key by key."""

    def __init__(self) -> None:
        """Start at rest."""
        self.linear = 0.0
        self.angular = 0.0
        self.quit = False
        self.last_info: dict[str, Any] | None = None  # the latest step's, for Ctrl-C

    def press(self, key: int) -> None:
        """Apply one key (unknown keys are ignored); upper-case letters act as lower-case."""
        if ord("A") <= key <= ord("Z"):
            key = key - ord("A") + ord("a")
        effect = KEYS.get(key)
        if effect == "stop":
            self.linear = self.angular = 0.0
        elif effect == "quit":
            self.quit = True
        elif isinstance(effect, tuple):
            self.linear = float(np.clip(round(self.linear + effect[0], 6), -1.0, 1.0))
            self.angular = float(np.clip(round(self.angular + effect[1], 6), -1.0, 1.0))

    @property
    def action(self) -> np.ndarray[Any, np.dtype[np.float32]]:
        """The twist action ``[linear, angular]``."""
        return np.array([self.linear, self.angular], dtype=np.float32)


def _status(state: TeleopState, info: dict[str, Any], nearest: float, collisions: int) -> str:
    """The status line: commanded and measured speed, nearest laser reading, collisions."""
    forward = float(info["body_twist"][0])
    return (
        f"cmd lin {state.linear:+.1f} ang {state.angular:+.1f} | speed {forward:+.2f} m/s "
        f"| nearest {nearest:.2f} m | collisions {collisions}"
    )


def run_teleop(
    screen: Any,
    env: gym.Env[Any, Any],
    seed: int | None,
    max_seconds: float | None = None,
) -> dict[str, Any]:
    """Drive ``env`` (twist actions) from ``screen``'s keys until q; return the last info."""
    curses.curs_set(0)
    screen.nodelay(True)
    screen.keypad(True)
    state = TeleopState()
    _, info = env.reset(seed=seed)
    dt = float(env.unwrapped.dt)  # type: ignore[attr-defined]
    try:
        info = _drive(screen, env, state, info, dt, max_seconds)
    except KeyboardInterrupt:  # Ctrl-C quits as q does: no traceback, the last pose printed
        info = state.last_info or info
    return info


def _drive(
    screen: Any,
    env: gym.Env[Any, Any],
    state: TeleopState,
    info: dict[str, Any],
    dt: float,
    max_seconds: float | None,
) -> dict[str, Any]:
    """The teleop loop: keys, a step, the status lines, at real time; the last info."""
    collisions = 0
    started = next_tick = time.monotonic()
    episode = 0
    while not state.quit:
        while (key := screen.getch()) != -1:
            state.press(key)
        if state.quit:
            break
        obs, _, terminated, truncated, info = env.step(state.action)
        state.last_info = info
        collisions += bool(info["collision"])
        nearest = float(np.min(obs["laser"])) if "laser" in obs else float("nan")
        screen.erase()
        screen.addstr(0, 0, "BubbleRob teleop: arrows/WASD drive, space stops, q quits")
        width = max(screen.getmaxyx()[1] - 1, 1)
        screen.addstr(1, 0, _status(state, info, nearest, collisions)[:width])
        pose = f"pose x={info['x']:+.2f} y={info['y']:+.2f} yaw={info['yaw']:+.2f}"
        screen.addstr(2, 0, f"{pose} | episode {episode} | sim {info['sim_time']:.1f} s"[:width])
        screen.refresh()
        if terminated or truncated:
            episode += 1
            state.linear = state.angular = 0.0
            obs, info = env.reset()
            state.last_info = info
        next_tick += dt
        delay = next_tick - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        else:
            next_tick = time.monotonic()  # fell behind: do not try to catch up in a burst
        if max_seconds is not None and time.monotonic() - started > max_seconds:
            break
    return info


def _ros_limits(args: argparse.Namespace) -> tuple[float, float]:
    """The robot's top speed (m/s) and turn rate (rad/s): those of ``--env``, as the node's."""
    from bubblerob_cli.args import make_env

    env = make_env("teleop", args.env, args.env_kwargs)
    base: Any = env.unwrapped
    limits = (float(base.max_linear_speed), float(base.max_angular_speed))
    env.close()
    return limits


def _run_ros(args: argparse.Namespace) -> int:
    """``--ros 1|2``: drive a live node; one line and exit 2 if ROS cannot be reached."""
    from bubblerob_env.extras import require_extra

    require_extra("ros", f"bubblerob teleop --ros {args.ros}")
    from bubblerob_env.ros.live.backend import BackendError
    from bubblerob_env.ros.messages.topics import topics_preset
    from policies.teleop_ros import RosLink, run_ros_teleop

    local = (args.record, args.start_pose, args.num_obstacles)
    if any(option is not None for option in local):
        print(
            "bubblerob teleop: --record, --start-pose and --num-obstacles are for the local "
            "simulation; with --ros give them to `bubblerob node` (--env-kwargs, rosbag record)",
            file=sys.stderr,
        )
        return 2
    try:
        topics = topics_preset(args.topics, args.namespace)
    except ValueError as error:
        print(f"bubblerob teleop: --topics: {error}", file=sys.stderr)
        return 2
    limits = _ros_limits(args)  # the node's env: --env and --env-kwargs as it was given them
    try:
        link = RosLink(args.ros, topics, *limits)
    except BackendError as error:
        print(f"bubblerob teleop: {error}", file=sys.stderr)
        return 2
    if _no_terminal():
        link.close()
        return 2
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


_MAX_SEED = 2**63 - 1  # NumPy seeds are ints >= 0; bags keep them as int64


def _usage_error(args: argparse.Namespace) -> str | None:
    """What is wrong with the command line before anything starts, or None."""
    if args.seed is not None and not 0 <= args.seed <= _MAX_SEED:
        return f"--seed must be from 0 to {_MAX_SEED}, got {args.seed}"
    return None


def _no_terminal() -> bool:
    """Whether there is no terminal to read keys from; says so in one line."""
    if sys.stdin.isatty() and sys.stdout.isatty():
        return False
    print(
        "bubblerob teleop: needs a terminal to read keys from (run it in one, not with piped "
        "input or output)",
        file=sys.stderr,
    )
    return True


def _run(args: argparse.Namespace) -> int:
    problem = _usage_error(args)
    if problem is not None:
        print(f"bubblerob teleop: {problem}", file=sys.stderr)
        return 2
    if args.ros is not None:
        return _run_ros(args)
    from bubblerob_cli.args import make_env

    kwargs: dict[str, Any] = {"action_type": "twist"}  # the keys drive speed and turn rate
    if args.start_pose is not None:
        kwargs["start_pose"] = tuple(args.start_pose)
    if args.num_obstacles is not None:
        kwargs["num_obstacles"] = tuple(args.num_obstacles)
    env: gym.Env[Any, Any] = make_env("teleop", args.env, args.env_kwargs, **kwargs)
    if args.record is not None and Path(args.record).exists():  # as the recorder refuses it
        env.close()
        message = f"bubblerob teleop: bag {args.record} already exists; --record another path"
        print(message, file=sys.stderr)
        return 2
    if _no_terminal():  # before a bag is started
        env.close()
        return 2
    if args.record is not None:
        from bubblerob_env.extras import require_extra

        require_extra("ros", "bubblerob teleop --record")
        from bubblerob_env.ros import RosBagRecorder

        try:
            env = RosBagRecorder(env, args.record, metadata={"policy": "teleop"})
        except FileExistsError:  # a usage error: exit 2
            env.close()
            message = f"bubblerob teleop: bag {args.record} already exists; --record another path"
            print(message, file=sys.stderr)
            raise SystemExit(2) from None
    try:
        info = curses.wrapper(run_teleop, env, args.seed, args.max_seconds)
    finally:
        env.close()  # with --record: the bag is closed, every finished episode readable
    print(f"final pose: x={info['x']:.4f} y={info['y']:.4f} yaw={info['yaw']:.4f}")
    if args.record is not None:
        print(f"recorded: {args.record}")
    return 0


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
    from bubblerob_cli.args import add_env_arguments  # the command module imports this one

    add_env_arguments(parser)
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
    parser.add_argument(
        "--max-seconds",
        type=float,
        default=None,
        help="quit after this many wall-clock seconds; default: only on q",
    )
    parser.set_defaults(handler=_run)
