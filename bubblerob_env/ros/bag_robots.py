"""Which robot of a bag to read: ``--robot NAME`` of ``info``, ``map`` and ``localize``.

A ``record --robots N`` bag holds every robot of one world, each with its own topics, episode
metadata and tf frames (``robot_k/odom``, ``robot_k/base_link``, ...). A reader of one robot's data
picks one: by its namespace (``robot_1``, Stage's) or its PettingZoo agent (``bubblerob_1``).
A bag of several robots read without ``--robot`` is refused (mixing robots' scans and poses would
be silently wrong); ``--robot`` on a one-robot bag is refused too.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

__all__ = ["match_robot", "robot_episodes"]


def match_robot(agents: Sequence[str], robot: str) -> str | None:
    """The agent among ``agents`` that ``robot`` names (``robot_1`` or ``bubblerob_1``), if any."""
    kind, _, index = robot.rpartition("_")
    for agent in agents:
        agent_kind, _, agent_index = agent.rpartition("_")
        if index == agent_index and kind in ("robot", agent_kind):
            return agent
    return None


def robot_episodes(
    path: str | Path, episodes: Sequence[Mapping[str, Any]], robot: str | None
) -> tuple[list[dict[str, Any]], str]:
    """One robot's episodes and tf frame prefix; ``episodes``: the bag's first episode topic's.

    A one-robot bag read without ``robot`` is returned as it is (prefix ``""``: the frames as
    recorded, namespaced or not).

    Raises:
        ValueError: Several robots and no ``robot``, an unknown ``robot``, or ``robot`` given for
            a bag of one robot (each in one line naming what there is).
    """
    several = bool(episodes) and "robots" in episodes[0] and "robot" in episodes[0]
    if not several:
        if robot is not None:
            raise ValueError(f"--robot {robot}: {path} holds one robot (leave --robot out)")
        return [dict(m) for m in episodes], ""
    from bubblerob_env.ros.world_record import episode_records

    records = [m for m in episode_records(Path(path)) if "robots" in m and "robot" in m]
    agents = list(dict.fromkeys(str(m["robot"]) for m in records))
    names = ", ".join(f"robot_{a.rpartition('_')[2]}" for a in agents)
    if robot is None:
        raise ValueError(f"{path} holds {len(agents)} robots ({names}): choose one with --robot")
    agent = match_robot(agents, robot)
    if agent is None:
        raise ValueError(f"--robot {robot}: not a robot of {path} (robots: {names})")
    chosen = sorted(
        (m for m in records if m["robot"] == agent),
        key=lambda m: (m["start_time_ns"], m["episode"]),
    )
    return chosen, str(chosen[0].get("frame_prefix", ""))
