"""``record --robots N``, and ``info``/``replay`` of such bags (``--robot NAME``: one robot).

A robot is named as its namespace (``robot_1``, Stage's) or as its PettingZoo agent
(``bubblerob_1``); both mean index 1.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

from bubblerob_cli.errors import report

__all__ = ["record_robots", "replay_world_bag", "robot_summary"]


def record_robots(args: argparse.Namespace, kwargs: dict[str, Any], bag: Path) -> int:
    """``bubblerob record --robots N``: the bag ``bag``, every robot driven by ``--policy``."""
    import bubblerob_env
    from bubblerob_env.extras import require_extra
    from bubblerob_env.mapping import check_resolution
    from bubblerob_env.ros.episodes import start_time_ns
    from bubblerob_env.ros.messages.robots import robot_topics
    from bubblerob_env.ros.messages.topics import topics_preset

    problem = _refused(args)
    if problem:
        report("record", problem)
        return 2
    require_extra("multi", "bubblerob record --robots")
    from bubblerob_env.ros.world_record import record_world

    robots = {"BubbleRob-v0": "bubblerob", "PioneerP3DX-v0": "pioneer_p3dx"}
    steps = kwargs.pop("max_episode_steps", 1000)
    try:
        env = bubblerob_env.parallel_env(
            num_robots=args.robots, robot=robots[args.env], max_episode_steps=steps, **kwargs
        )
    except (TypeError, ValueError) as error:
        report("record", str(error))
        return 2
    try:
        base = topics_preset(args.topics, "", not args.no_detections)
        topics = [robot_topics(base, k) for k in range(args.robots)]
        path, total = record_world(
            bag,
            env,
            topics,
            _driver(args, kwargs),
            [args.seed + k for k in range(args.episodes)],
            start_time_ns(args.start_time),
            check_resolution(args.map_resolution),
            kwargs=kwargs,
            fmt=args.format,
            distro=args.distro,
            compression=args.compression,
            overwrite=args.overwrite,
            facts={"policy": args.policy, "command": shlex.join(["bubblerob", *sys.argv[1:]])},
        )
    except FileExistsError as error:
        report("record", f"bag {error.filename} already exists; pass --overwrite to replace it")
        return 2
    except (OSError, ValueError) as error:
        report("record", str(error))
        return 2
    finally:
        env.close()
    print(f"recorded {args.episodes} episode(s) of {args.robots} robots, {total} steps to {path}")
    return 0


def _refused(args: argparse.Namespace) -> str | None:
    """Why ``--robots`` cannot record with the other options, in one line, or ``None``."""
    if args.robots < 1:
        return f"--robots must be at least 1, got {args.robots}"
    if args.env not in ("BubbleRob-v0", "PioneerP3DX-v0"):
        return f"--robots records BubbleRob-v0 or PioneerP3DX-v0, got --env {args.env}"
    for option, given in (
        ("--namespace", args.namespace),
        ("--per-episode", args.per_episode),
        ("--ray", args.ray),
    ):
        if given:
            return f"{option} is for one robot: leave it out with --robots {args.robots}"
    if args.topics != "default":
        return f"--topics {args.topics} is one robot's: each robot records under /robot_i"
    return None


def _driver(args: argparse.Namespace, kwargs: dict[str, Any]) -> Any:
    """One ``--policy`` per robot (each with its own state), as ``driver(agent, obs, start)``."""
    import gymnasium as gym
    import numpy as np

    from policies import load_policy

    single = gym.make(args.env, **kwargs)
    policies: dict[str, Any] = {}
    states: dict[str, Any] = {}

    def drive(agent: str, obs: Any, start: bool) -> Any:
        if agent not in policies:
            index = int(agent.rsplit("_", 1)[1])
            policies[agent] = load_policy(args.policy, env=single, seed=args.seed + index)
        if start:
            states[agent] = None
        action, states[agent] = policies[agent].predict(
            obs, state=states[agent], episode_start=np.array([start]), deterministic=True
        )
        return action

    return drive


def replay_world_bag(bag: Path, robot: str | None = None) -> int | None:
    """``replay`` of a ``record --robots`` bag (exit status), or ``None`` for another bag.

    ``robot`` (``robot_1``): compare that robot's own topics only (the world is re-simulated).
    """
    try:
        from bubblerob_env.ros.world_record import world_robots

        agents = world_robots(bag)
    except Exception:  # noqa: BLE001 - not readable as one: the one-robot replay says why
        agents = []
    if not agents:
        if robot is not None:
            report("replay", f"--robot {robot}: {bag} holds one robot (leave --robot out)")
            return 2
        return None
    from bubblerob_env.ros.bag_robots import match_robot
    from bubblerob_env.ros.world_record import replay_world

    agent = None if robot is None else match_robot(agents, robot)
    if robot is not None and agent is None:
        names = ", ".join(f"robot_{a.rpartition('_')[2]}" for a in agents)
        report("replay", f"--robot {robot}: not a robot of {bag} (robots: {names})")
        return 2
    difference = replay_world(bag, agent)
    what = "every message of every robot" if agent is None else f"every message of {robot}"
    if difference is None:
        print(f"{bag}: {what} replayed identical")
        return 0
    print(f"{bag}: replay differs: {difference}")
    return 1


def robot_summary(summary: Any, robot: str) -> Any:
    """``summary`` (``read_summary``'s) with one robot's topics and episodes; bad name: exit 2."""
    from bubblerob_env.ros.bag_robots import robot_episodes
    from bubblerob_env.ros.messages.topics import Topics

    try:
        episodes, _ = robot_episodes(summary.path, summary.episodes, robot)
    except ValueError as error:
        report("info", str(error))
        raise SystemExit(2) from None
    names = Topics.from_dict(episodes[0]["topics"]).resolved()
    topics = tuple(t for t in summary.topics if t.name in set(names.values()))
    return replace(
        summary,
        topics=topics,
        message_count=sum(t.count for t in topics),
        episodes=tuple(episodes),
        episode_topic=names["episode"],
    )
