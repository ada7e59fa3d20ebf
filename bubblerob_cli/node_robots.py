"""``bubblerob node --robots N``: N robots of one world as one ROS node (``MultiSimNode``)."""

from __future__ import annotations

import argparse
import signal
import sys
from typing import Any

from bubblerob_cli.action_type import load_checked, refuse_unused
from bubblerob_cli.errors import fail

__all__ = ["add_robots_argument", "run_robots"]


def add_robots_argument(node: argparse.ArgumentParser) -> None:
    """``--robots N`` of ``bubblerob node``."""
    node.add_argument(
        "--robots",
        type=int,
        default=1,
        metavar="N",
        help="N robots in one world (one /clock; robot i's topics under /robot_i, frames "
        "robot_i/...; default 1: today's names)",
    )


def run_robots(args: argparse.Namespace) -> int:
    """Run ``bubblerob node`` with ``--robots N``; exit status (bad input: one line, exit 2)."""
    from bubblerob_env.extras import require_extra

    refused = _refused(args)
    if refused:
        fail("node", refused)
    require_extra("multi", "bubblerob node --robots")
    if args.foxglove:
        require_extra("foxglove", "bubblerob node --foxglove")
    from bubblerob_env.ros.live.multi_node import MultiSimNode
    from bubblerob_env.ros.live.node import NodeConfig
    from bubblerob_env.ros.messages.topics import topics_preset

    env, kwargs = _world(args)
    naming = "tutorial" if args.topics == "tutorial" else "namespace"
    try:
        topics = topics_preset("default" if naming == "tutorial" else args.topics)
        if args.no_clock:
            topics = topics.replace(clock=None)
        config = NodeConfig(
            rate_factor=args.rate_factor,
            sync=args.sync,
            watchdog=args.watchdog,
            seed=args.seed,
            start=args.start,
            start_time=args.start_time,
            map_resolution=float(args.map_resolution),
        )
        backend = _backend(args, env)
        node = MultiSimNode(env, backend, topics, naming, config, _drivers(args, env, kwargs))
    except (TypeError, ValueError) as error:
        env.close()
        fail("node", str(error))
    where = _serve_foxglove(backend, node) if args.foxglove else f"ROS {args.ros}"
    previous = signal.signal(signal.SIGTERM, lambda *_: node.request_stop())
    mode = "sync mode" if args.sync else f"rate factor {args.rate_factor:g}"
    print(f"bubblerob node: {where}, {args.robots} robots, {mode}; ready", flush=True)
    try:
        node.run(max_steps=args.steps, duration=args.duration)
    except KeyboardInterrupt:
        pass
    finally:
        signal.signal(signal.SIGTERM, previous)
        node.close()
        backend.shutdown("exiting")
    lost = getattr(backend, "lost_master", None)
    if lost:
        print(f"bubblerob node: {lost}; exiting (start it again with the master)", flush=True)
    print(f"bubblerob node: {node.steps} steps, {node.published} messages published", flush=True)
    return 1 if lost else 0


def _refused(args: argparse.Namespace) -> str | None:
    """Why ``--robots`` cannot run with the other options, in one line, or ``None``."""
    if args.robots < 1:
        return f"--robots must be at least 1, got {args.robots}"
    if args.namespace:
        return "--namespace is for one robot: with --robots each robot gets its own (robot_i)"
    if args.localize:
        return f"--localize runs one robot: leave it out with --robots {args.robots}"
    if args.topics not in ("default", "tutorial"):
        return f"--topics {args.topics} is one robot's; with --robots use default or tutorial"
    return None


def _world(args: argparse.Namespace) -> tuple[Any, dict[str, Any]]:
    """``parallel_env`` of ``--env``'s robot and the single env's kwargs; bad input: one line."""
    import bubblerob_env

    robots = {"BubbleRob-v0": "bubblerob", "PioneerP3DX-v0": "pioneer_p3dx"}
    if args.env not in robots:
        fail("node", f"--robots runs {' or '.join(robots)}, got --env {args.env}")
    kwargs: dict[str, Any] = dict(args.env_kwargs)
    if args.camera or args.camera_size is not None:
        kwargs["camera"] = True
    if args.camera_size is not None:
        kwargs["camera_width"], kwargs["camera_height"] = args.camera_size
    if kwargs.get("action_type", "wheels") != "wheels":
        fail("node", "the node drives the wheels: action_type must be 'wheels' (cmd_vel is mapped)")
    kwargs["action_type"] = "wheels"
    steps = kwargs.pop("max_episode_steps", None) if args.max_steps is None else args.max_steps
    try:
        env = bubblerob_env.parallel_env(
            num_robots=args.robots,
            robot=robots[args.env],
            max_episode_steps=1000 if steps is None else steps,
            **kwargs,
        )
        return env, kwargs
    except (TypeError, ValueError) as error:
        fail("node", str(error))


def _backend(args: argparse.Namespace, env: Any) -> Any:
    """``--ros``'s ROS node or ``--foxglove``'s server; one line and exit 2 if it cannot start."""
    from bubblerob_env.ros.live.backend import BackendError
    from bubblerob_env.ros.live.connect import load_backend

    try:
        if args.foxglove:
            from bubblerob_cli.foxglove_view import quiet_sdk_log
            from bubblerob_env.ros.live.foxglove import FoxgloveBackend

            quiet_sdk_log("node")
            return FoxgloveBackend(args.host, args.port, logger=_log_line)
        return load_backend(args.ros, master_timeout=args.master_timeout)
    except BackendError as error:
        env.close()
        fail("node", str(error))


def _log_line(level: str, text: str) -> None:
    """The Foxglove server's log: one line on stderr (ROS nodes log to rosout)."""
    print(f"bubblerob node: {'warning: ' if level == 'warn' else ''}{text}", file=sys.stderr)


def _serve_foxglove(backend: Any, node: Any) -> str:
    """Add the world's services and the robots' bodies to the Foxglove server; its address."""
    from bubblerob_env.ros.live.foxglove import SUBPROTOCOL
    from bubblerob_env.ros.live.foxglove_services import serve_world

    serve_world(backend, node)
    return f"Foxglove at {backend.url} (WebSocket subprotocol {SUBPROTOCOL})"


def _drivers(args: argparse.Namespace, env: Any, kwargs: dict[str, Any]) -> Any:
    """``--policy``: one policy per robot (each its own state), as ``driver(agent, obs, start)``."""
    if args.policy is None:
        refuse_unused("node", args.action_type, False)
        return None
    import gymnasium as gym

    from policies.loading import load_policy

    single = gym.make(args.env, **kwargs)  # the policy's spaces: one robot's
    try:
        _, bare = load_checked(
            "node", args.policy, single, args.action_type, lambda: load_policy(args.policy, single)
        )
        refuse_unused("node", args.action_type, bare)
        policies = {agent: load_policy(args.policy, single) for agent in env.possible_agents}
    except (ValueError, OSError) as error:
        env.close()
        fail("node", f"--policy {args.policy}: {error}")
    finally:
        single.close()

    def drive(agent: str, obs: Any, episode_start: bool) -> Any:
        policy = policies[agent]
        if episode_start:
            policy.reset()
        return policy.predict(obs, deterministic=True)[0]

    return drive
