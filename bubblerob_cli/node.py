"""``bubblerob node``: BubbleRob as a live ROS node (see :mod:`~bubblerob_env.ros.live.node`)."""

from __future__ import annotations

import argparse
import math
import os
import signal
import sys
from dataclasses import replace
from typing import TYPE_CHECKING, Any

from bubblerob_cli.action_type import add_action_type_option, load_checked, refuse_unused
from bubblerob_cli.args import add_env_arguments, make_env, with_options
from bubblerob_cli.errors import fail
from bubblerob_cli.node_robots import add_robots_argument
from bubblerob_env.extras import require_extra
from bubblerob_env.ros.live.node import LAUNCH_DIR
from bubblerob_env.ros.messages.topics import PRESETS

if TYPE_CHECKING:
    from bubblerob_env.ros.live.backend import LiveBackend
    from bubblerob_env.ros.live.node import NodeConfig, SimNode
    from bubblerob_env.ros.messages.topics import Topics

__all__ = ["add_subcommands", "parse_rate"]


def parse_rate(text: str) -> float:
    """``--rate-factor``: a number >= 0, or ``max`` (as fast as possible, same as 0)."""
    if text.strip().lower() == "max":
        return 0.0
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number >= 0 or 'max', got {text!r}") from None
    if not value >= 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a number >= 0 or 'max', got {text!r}")
    return value


def _size(text: str) -> tuple[int, int]:
    width, sep, height = text.lower().partition("x")
    if not sep or not width.isdigit() or not height.isdigit():
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT such as 64x64, got {text!r}")
    return int(width), int(height)


def add_subcommands(subparsers: Any) -> None:
    """Add ``node`` to the ``bubblerob`` command."""
    node = subparsers.add_parser(
        "node",
        help="run the robot as a live ROS node (sensors out, cmd_vel and sim control in)",
        description="Run the env --env makes (BubbleRob-v0 by default; PioneerP3DX-v0 with "
        "--topics vrep is the third tutorial's Pioneer) as a ROS node: publishes the recorder's "
        "topics live with /clock, takes /cmd_vel or /leftMotorSpeed + /rightMotorSpeed, the "
        "sensor switches and CoppeliaSim's simulation-control topics (start/pause/stop, sync "
        "mode, triggerNextStep).",
    )
    node.add_argument(
        "--ros",
        type=int,
        choices=(1, 2),
        default=1,
        help="ROS 1 (rospy, default) or ROS 2 (rclpy, Jazzy)",
    )
    _add_foxglove_arguments(node)
    mode = node.add_mutually_exclusive_group()
    mode.add_argument(
        "--rate-factor",
        type=parse_rate,
        default=1.0,
        metavar="X",
        help="simulated/real time in free mode: 1 (default), 0 or max: flat out",
    )
    mode.add_argument("--sync", action="store_true", help="start in sync mode (triggerNextStep)")
    node.add_argument(
        "--namespace",
        default=os.environ.get("ROS_NAMESPACE", ""),
        help="prefix for this robot's topics (default: $ROS_NAMESPACE)",
    )
    node.add_argument(
        "--topics",
        choices=[*sorted(PRESETS), "tutorial"],
        default="default",
        help="topic names; tutorial: with --robots, each robot's names end in its index "
        "(/leftMotorSpeed0, as the first tutorial's suffix) instead of a /robot_i namespace",
    )
    add_robots_argument(node)
    node.add_argument("--camera", action="store_true", help="publish the camera (64x64)")
    node.add_argument(
        "--camera-size",
        type=_size,
        default=None,
        metavar="WxH",
        help="camera size, e.g. 128x96 (turns the camera on)",
    )
    _add_simulation_arguments(node)
    add_env_arguments(node)
    _add_later_arguments(node)
    node.set_defaults(handler=_node)


def _add_foxglove_arguments(node: argparse.ArgumentParser) -> None:
    """``--foxglove``, ``--host``, ``--port``: serve Foxglove's WebSocket protocol, no ROS."""
    node.add_argument(
        "--foxglove",
        action="store_true",
        help="no ROS: serve the topics to Foxglove over its WebSocket protocol (foxglove-sdk; "
        "the [foxglove] extra); replaces --ros",
    )
    node.add_argument(
        "--host",
        default="127.0.0.1",
        help="with --foxglove: address to listen on (0.0.0.0: every interface)",
    )
    node.add_argument(
        "--port",
        type=int,
        default=8765,
        help="with --foxglove: port to listen on (0: any free one)",
    )


def _add_simulation_arguments(node: argparse.ArgumentParser) -> None:
    """``--seed`` to ``--start-time``, in ``--help``'s order."""
    node.add_argument("--seed", type=int, default=0, help="seed of the first episode (k: seed+k)")
    node.add_argument(
        "--watchdog",
        type=float,
        default=0.5,
        help="stop the wheels after this many sim seconds without a command; 0: off",
    )
    node.add_argument(
        "--start",
        choices=("running", "paused", "stopped"),
        default="running",
        help="initial simulation state",
    )
    node.add_argument("--max-steps", type=int, default=None, help="step limit per episode")
    node.add_argument(
        "--no-clock",
        action="store_true",
        help="do not publish /clock: follow it (start at its first time) as a second robot",
    )
    node.add_argument(
        "--start-time",
        default=None,
        help="stamp of the first frame: Unix seconds or an ISO 8601 date (default: now)",
    )


def _add_later_arguments(node: argparse.ArgumentParser) -> None:
    """The options after ``--env``/``--env-kwargs``, in ``--help``'s order."""
    node.add_argument(
        "--map-resolution",
        default="0.05",
        metavar="M",
        help="metres per cell of the latched /map, 0.005 to 1",
    )
    node.add_argument(
        "--localize",
        nargs="?",
        const="track",
        default=None,
        choices=("track", "global"),
        help="run the particle filter as AMCL: /amcl_pose, /particlecloud, map -> odom on /tf, "
        "/initialpose in; 'track' (the default) from each episode's start pose, 'global' from "
        "particles over all the free space",
    )
    node.add_argument(
        "--policy",
        default=None,
        metavar="NAME",
        help="drive the robot with this policy instead of /cmd_vel (as evaluate --policy): "
        "navigator on a Nav env drives to each goal (with --localize, seen from the estimate)",
    )
    add_action_type_option(node)
    node.add_argument("--steps", type=int, default=None, help="exit after this many steps")
    node.add_argument("--duration", type=float, default=None, help="exit after this many seconds")
    node.add_argument(
        "--master-timeout",
        type=float,
        default=3.0,
        help="seconds to wait for the ROS master (ROS 1)",
    )
    node.add_argument(
        "--launch-dir",
        action="store_true",
        help="print the directory holding bubblerob.launch and bubblerob.rviz (a ROS package "
        "named bubblerob, for ROS_PACKAGE_PATH) and exit",
    )


def _usage_error(args: argparse.Namespace) -> str | None:
    """What is wrong with the node's numeric options, in one line, or ``None``."""
    if not 0 <= args.seed <= 2**63 - 1:
        return f"--seed must be an int from 0 to {2**63 - 1}, got {args.seed}"
    if not 0 <= args.port <= 65535:
        return f"--port must be 0 (any free port) to 65535, got {args.port}"
    for option, value in (("--max-steps", args.max_steps), ("--steps", args.steps)):
        if value is not None and value < 1:
            return f"{option} must be at least 1, got {value}"
    for option, value in (
        ("--duration", args.duration),
        ("--master-timeout", args.master_timeout),
        ("--watchdog", args.watchdog),
    ):
        if value is not None and not (math.isfinite(value) and value >= 0):
            return f"{option} must be a finite number of seconds >= 0, got {value}"
    return None


def _node(args: argparse.Namespace) -> int:
    if args.launch_dir:
        print(LAUNCH_DIR)
        return 0
    import bubblerob_env  # noqa: F401  (registers the envs)
    from bubblerob_env.ros.live.controls import CONTROL_PRESETS
    from bubblerob_env.ros.live.node import SimNode

    problem = _usage_error(args)
    if problem is not None:
        fail("node", problem)
    if args.robots != 1:
        from bubblerob_cli.node_robots import run_robots

        return run_robots(args)
    if args.topics == "tutorial":
        args.topics = "default"  # a lone robot: the tutorial's names are the default ones
    if args.foxglove:
        require_extra("foxglove", "bubblerob node --foxglove")
    kwargs = _env_kwargs(args)
    if kwargs.get("action_type", "wheels") != "wheels":
        fail("node", "the node drives the wheels: action_type must be 'wheels' (cmd_vel is mapped)")
    kwargs["action_type"] = "wheels"
    topics, config = _topics_and_config(args)
    env = make_env("node", args.env, kwargs, dict_observations=True)
    if args.localize and getattr(env.unwrapped, "laser_spec", None) is None:
        env.close()
        fail("node", "--localize needs the laser: leave laser_num_rays above 0")
    if args.localize:
        from bubblerob_env.ros.localize import localize_problem

        if problem := localize_problem(env, config.map_resolution):
            env.close()
            fail("node", f"--localize: {problem}")
    if args.policy is None:
        refuse_unused("node", args.action_type, False)
    driver = (
        None if args.policy is None else _driver(args.policy, env, args.localize, args.action_type)
    )
    backend = _start_backend(args, env)
    config = _follow_clock(args, backend, config)
    controls = CONTROL_PRESETS.get(args.topics)
    node = SimNode(env, backend, topics, controls, config=config, driver=driver)
    where = f"ROS {args.ros}"
    if args.foxglove:
        where = _serve_foxglove(backend, node, args.namespace)
    previous = signal.signal(signal.SIGTERM, lambda *_: node.request_stop())
    print(
        f"bubblerob node: {where}, {len(node.publisher.sink.topics)} topics, "
        f"{'sync mode' if args.sync else f'rate factor {args.rate_factor:g}'}; ready",
        flush=True,
    )
    try:
        node.run(max_steps=args.steps, duration=args.duration)
    except KeyboardInterrupt:
        pass
    finally:
        signal.signal(signal.SIGTERM, previous)
        node.close()
        backend.shutdown("exiting")
    return _report(node, getattr(backend, "lost_master", None))


def _topics_and_config(args: argparse.Namespace) -> tuple[Topics, NodeConfig]:
    """The node's topics and settings; a bad value is one line, exit 2, before ROS starts."""
    from bubblerob_env.mapping import check_resolution
    from bubblerob_env.ros.episodes import start_time_ns
    from bubblerob_env.ros.live.node import NodeConfig
    from bubblerob_env.ros.messages.topics import topics_preset

    try:
        topics = topics_preset(args.topics, args.namespace)
        if args.no_clock:
            topics = topics.replace(clock=None)
        config = NodeConfig(
            rate_factor=args.rate_factor,
            sync=args.sync,
            watchdog=args.watchdog,
            seed=args.seed,
            start=args.start,
            start_time=args.start_time,
            map_resolution=check_resolution(args.map_resolution),
            localize=args.localize,
        )
        if args.start_time is not None:
            start_time_ns(args.start_time)  # a bad date fails here, before ROS starts
    except (TypeError, ValueError) as error:
        fail("node", str(error))
    return topics, config


def _start_backend(args: argparse.Namespace, env: Any) -> LiveBackend:
    """The ROS node of ``--ros`` or ``--foxglove``'s server; one line and exit 2 if it cannot start.

    The env is closed before exiting.
    """
    from bubblerob_env.ros.live.backend import BackendError
    from bubblerob_env.ros.live.connect import load_backend

    try:
        if args.foxglove:
            from bubblerob_cli.foxglove_view import quiet_sdk_log
            from bubblerob_env.ros.live.foxglove import FoxgloveBackend

            quiet_sdk_log("node")
            return FoxgloveBackend(args.host, args.port, logger=_log_line)
        return load_backend(args.ros, namespace=args.namespace, master_timeout=args.master_timeout)
    except BackendError as error:
        env.close()
        fail("node", str(error))


def _driver(name: str, env: Any, localize: str | None, action_type: str | None) -> Any:
    """``--policy``: ``driver(obs, episode_start) -> action``; one line and exit 2 if unusable."""
    from policies.loading import load_policy

    if name == "pursuit" and localize:  # it would drive on the truth, silently
        env.close()
        fail(
            "node",
            "--policy pursuit reads the ground truth (the env's pose and layout), not "
            "--localize's estimate: use --policy navigator, or leave out --localize",
        )
    try:
        policy, bare = load_checked("node", name, env, action_type, lambda: load_policy(name, env))
    except (ValueError, OSError) as error:
        env.close()
        fail("node", f"--policy {name}: {error}")
    refuse_unused("node", action_type, bare)

    def drive(obs: Any, episode_start: bool) -> Any:
        if episode_start:
            policy.reset()
        return policy.predict(obs, deterministic=True)[0]

    return drive


def _log_line(level: str, text: str) -> None:
    """The Foxglove server's log: one line on stderr (ROS nodes log to rosout)."""
    print(f"bubblerob node: {'warning: ' if level == 'warn' else ''}{text}", file=sys.stderr)


def _serve_foxglove(backend: LiveBackend, node: SimNode, namespace: str) -> str:
    """Add the services and the robot's body to the Foxglove server; where clients connect."""
    from bubblerob_env.ros.live.foxglove import SUBPROTOCOL, FoxgloveBackend
    from bubblerob_env.ros.live.foxglove_services import serve_simulation

    assert isinstance(backend, FoxgloveBackend)
    serve_simulation(backend, node, namespace)
    return f"Foxglove at {backend.url} (WebSocket subprotocol {SUBPROTOCOL})"


def _follow_clock(args: argparse.Namespace, backend: LiveBackend, config: NodeConfig) -> NodeConfig:
    """With ``--no-clock`` and no ``--start-time``: start at the first time on the shared /clock."""
    from bubblerob_env.ros.live.node import shared_clock_ns
    from bubblerob_env.ros.messages.topics import topics_preset

    if not args.no_clock or args.start_time is not None or args.foxglove:
        return config
    shared = topics_preset(args.topics, args.namespace).resolved().get("clock")
    start = shared_clock_ns(backend, shared, 10.0) if shared else None
    if start is None:
        print(f"bubblerob node: no {shared} within 10 s: starting at the wall clock")
        return config
    return replace(config, start_time=f"{start // 10**9}.{start % 10**9:09d}")


def _env_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    """``--env-kwargs``, then ``--camera``, ``--camera-size`` and ``--max-steps``."""
    options: dict[str, tuple[str, Any]] = {}
    if args.camera:
        options["camera"] = ("--camera", True)
    if args.camera_size is not None:
        width, height = args.camera_size
        options["camera_width"] = (f"--camera-size {width}x{height}", width)
        options["camera_height"] = (f"--camera-size {width}x{height}", height)
    if args.max_steps is not None:
        options["max_episode_steps"] = (f"--max-steps {args.max_steps}", args.max_steps)
    return with_options("node", args.env_kwargs, options)


def _report(node: SimNode, lost: str | None) -> int:
    """The node's closing lines; exit 1 if it lost its master, else 0."""
    if lost:
        print(f"bubblerob node: {lost}; exiting (start it again with the master)", flush=True)
    first, last = node.first_step_at, node.last_step_at
    wall = (last - first) if first is not None and last is not None else 0.0
    rate = f"{node.steps / wall:.1f}" if wall > 0 else "-"
    print(
        f"bubblerob node: {node.steps} steps in {wall:.2f} s ({rate} steps/s), "
        f"{node.publisher.sink.published} messages published",
        flush=True,
    )
    return 1 if lost else 0
