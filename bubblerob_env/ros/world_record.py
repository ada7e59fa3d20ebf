"""One bag with every robot of a world (``record --robots N``), and its exact replay.

:func:`record_world` drives a :func:`bubblerob_env.parallel_env` world and writes every robot's
frames (:class:`~bubblerob_env.ros.world_streams.WorldStreams`: robot ``k``'s topics under
``/robot_k`` or with the tutorial's suffix, frames ``robot_k/...``) into one bag; the shared
``/tf`` and ``/tf_static`` are one connection each. :func:`replay_world` reads the recorded
actions of every robot, records the same seeds and actions again through the same path and
compares every message of every topic byte for byte.
"""

from __future__ import annotations

import json
import tempfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from bubblerob_env.ros.bags.sinks import BagSink, open_bag
from bubblerob_env.ros.fastpath.framing import Framing, PackedBatchWriter, PackedWriter, Record
from bubblerob_env.ros.messages.topics import Topics
from bubblerob_env.ros.world_streams import WorldStreams

__all__ = [
    "WorldDriver",
    "is_world_bag",
    "episode_records",
    "record_world",
    "replay_world",
    "world_robots",
]

WorldDriver = Callable[[str, Any, bool], Any]
"""``driver(agent, obs, episode_start) -> action`` for each live robot of each step."""


class _RobotBagView:
    """One robot's view of the shared bag: topics all robots share are declared once."""

    def __init__(self, bag: BagSink) -> None:
        self.bag, self.distro = bag, bag.distro

    def add_topic(self, topic: str, msgtype: str, latched: bool = False) -> None:
        if topic not in self.bag.topics:
            self.bag.add_topic(topic, msgtype, latched)

    def write_batch(self, records: Sequence[Record]) -> None:
        self.bag.write_batch(records)

    def framing(self) -> Framing | None:
        return self.bag.framing()

    def packed_writer(self) -> PackedWriter:
        return self.bag.packed_writer()

    def packed_batch_writer(self) -> PackedBatchWriter:
        return self.bag.packed_batch_writer()

    def close(self) -> None:
        """The bag is the recording's: closed once, by :func:`record_world`."""


def record_world(
    path: str | Path,
    env: Any,
    topics: Sequence[Topics],
    driver: WorldDriver,
    seeds: Sequence[int],
    start_time_ns: int,
    map_resolution: float,
    *,
    kwargs: Mapping[str, Any] | None = None,
    fmt: str = "mcap",
    distro: str | None = None,
    compression: str | None = None,
    overwrite: bool = False,
    facts: Mapping[str, Any] | None = None,
    clock: str | None = "/clock",
) -> tuple[Path, int]:
    """Record one episode of ``env`` per seed into one bag; ``(the bag's path, steps)``.

    ``clock``: the world's ``/clock`` topic, one message per frame of the world (``None``: none).
    """
    bag = open_bag(path, fmt, distro, compression, overwrite)
    steps = 0
    try:
        world = WorldStreams(env, topics, start_time_ns, map_resolution, kwargs)
        for k in range(env.num_robots):
            world.add_sink(k, _RobotBagView(bag), bag.distro)
        tick = _clock_writer(bag, clock)
        base = {"distro": bag.distro, "format": fmt, "map_resolution": map_resolution}
        for seed in seeds:
            observations, _ = world.reset(seed, {**base, **(facts or {})})
            tick(world.last_ns)
            starts = dict.fromkeys(env.agents, True)
            while env.agents:
                actions = {}
                for agent in env.agents:
                    actions[agent] = driver(agent, observations[agent], starts[agent])
                    starts[agent] = False
                observations = world.step(actions)[0]
                tick(world.last_ns)
                steps += 1
        world.flush()
    finally:
        bag.close()
    return bag.path, steps


def _clock_writer(bag: BagSink, topic: str | None) -> Callable[[int | None], None]:
    """``tick(stamp_ns)``: the world's clock at a frame, into ``bag`` (nothing without a topic)."""
    if topic is None:
        return lambda stamp_ns: None
    from bubblerob_env.ros.messages.distros import serialize, typestore
    from bubblerob_env.ros.messages.topics import MSGTYPES

    msgtype, types = MSGTYPES["clock"], typestore(bag.distro).types
    bag.add_topic(topic, msgtype)

    def tick(stamp_ns: int | None) -> None:
        assert stamp_ns is not None
        sec, nanosec = divmod(stamp_ns, 10**9)
        time = types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec)
        data = serialize(bag.distro, types[msgtype](clock=time), msgtype)
        bag.write_batch([(topic, stamp_ns, data)])

    return tick


def episode_records(path: Path) -> list[dict[str, Any]]:
    """Every episode record of a bag (every robot's), in order."""
    from rosbags.highlevel import AnyReader

    found = []
    with AnyReader([path]) as reader:
        episodes = [c for c in reader.connections if c.msgtype == "std_msgs/msg/String"]
        for connection, _, raw in reader.messages(connections=episodes):
            record: Any = reader.deserialize(raw, connection.msgtype)
            text = record.data
            try:
                found.append(json.loads(text))
            except ValueError:
                continue
    return found


def world_robots(path: str | Path) -> list[str]:
    """The robots of a ``record --robots`` bag, in order; empty for a one-robot bag."""
    robots: dict[str, None] = {}
    for meta in episode_records(Path(path)):
        if "robots" in meta and "robot" in meta:
            robots[meta["robot"]] = None
    return list(robots)


def is_world_bag(path: str | Path) -> bool:
    """Whether ``path`` holds several robots of one world (``record --robots``)."""
    return bool(world_robots(path))


def _messages(path: Path) -> dict[str, list[tuple[int, bytes]]]:
    from rosbags.highlevel import AnyReader

    topics: dict[str, list[tuple[int, bytes]]] = {}
    with AnyReader([path]) as reader:
        for connection, stamp, raw in reader.messages():
            topics.setdefault(connection.topic, []).append((stamp, bytes(raw)))
    return topics


def _actions(path: Path, episodes: list[dict[str, Any]]) -> dict[str, list[Any]]:
    """Each robot's recorded actions, in order (float64 in the bag: the float32 exactly)."""
    from rosbags.highlevel import AnyReader

    names = {m["robot"]: Topics.from_dict(m["topics"]).resolved()["action"] for m in episodes}
    actions: dict[str, list[Any]] = {robot: [] for robot in names}
    by_topic = {topic: robot for robot, topic in names.items()}
    with AnyReader([path]) as reader:
        chosen = [c for c in reader.connections if c.topic in by_topic]
        for connection, _, raw in reader.messages(connections=chosen):
            message: Any = reader.deserialize(raw, connection.msgtype)
            data = message.data
            actions[by_topic[connection.topic]].append(np.asarray(data, dtype=np.float32))
    return actions


def replay_world(path: str | Path, topics_of: str | None = None) -> str | None:
    """Re-simulate a ``record --robots`` bag; ``None`` if every message is equal, else where not.

    The whole world is re-simulated (the robots act on each other); ``topics_of``: compare only
    that agent's own topics (``bubblerob_1``), else every topic.

    Raises:
        ValueError: Not a bag of several robots, or ``topics_of`` not one of its robots.
    """
    import bubblerob_env

    source = Path(path)
    episodes = [m for m in episode_records(source) if "robots" in m and "robot" in m]
    if not episodes:
        raise ValueError(f"{source} is not a bag of several robots (bubblerob record --robots)")
    first = episodes[0]
    robots = list(dict.fromkeys(m["robot"] for m in episodes))
    topics = [
        Topics.from_dict(next(m for m in episodes if m["robot"] == r)["topics"]) for r in robots
    ]
    seeds = [m["seed"] for m in episodes if m["robot"] == robots[0]]
    queues = {robot: iter(actions) for robot, actions in _actions(source, episodes).items()}
    env = bubblerob_env.parallel_env(**first["env_kwargs"])
    kind = "ros1" if source.suffix == ".bag" else first["format"]
    recorded = _messages(source)
    with tempfile.TemporaryDirectory(prefix="bubblerob_replay_") as scratch:
        again, _ = record_world(
            Path(scratch) / ("again.bag" if kind == "ros1" else "again"),
            env,
            topics,
            lambda agent, obs, start: next(queues[agent]),
            seeds,
            first["start_time_ns"],
            first["map_resolution"],
            kwargs={k: v for k, v in first["env_kwargs"].items() if k not in _WORLD_KEYS},
            fmt=kind,
            distro=first["distro"],
            facts={k: v for k, v in first.items() if k not in _SET_KEYS},
            clock="/clock" if "/clock" in recorded else None,
        )
        env.close()
        replayed = _messages(again)
    if topics_of is not None:
        mine = [m for m in episodes if m["robot"] == topics_of]
        if not mine:
            raise ValueError(f"{topics_of} is not a robot of {source} (robots: {robots})")
        names = set(Topics.from_dict(mine[0]["topics"]).resolved().values()) - _SHARED
        recorded = {t: v for t, v in recorded.items() if t in names}
        replayed = {t: v for t, v in replayed.items() if t in names}
    return _first_difference(recorded, replayed)


_SHARED = {
    "/tf",
    "/tf_static",
    "/clock",
}  # every robot's transforms: a robot's own topics leave them out
_WORLD_KEYS = ("num_robots", "robot", "scenario", "max_episode_steps")
_SET_KEYS = frozenset({
    "episode", "seed", "env_id", "env_kwargs", "robots", "robot", "frame_prefix",
    "start_time_ns", "first_seq", "dt", "topics", "distro", "format", "map_resolution",
})  # fmt: skip


def _first_difference(
    recorded: dict[str, list[tuple[int, bytes]]], replayed: dict[str, list[tuple[int, bytes]]]
) -> str | None:
    """The earliest message (by stamp) that differs, in words; ``None`` if all are equal."""
    if set(recorded) != set(replayed):
        return f"topics differ: {sorted(set(recorded) ^ set(replayed))}"
    found: list[tuple[int, str]] = []
    for topic in sorted(recorded):
        a, b = recorded[topic], replayed[topic]
        at = next((i for i, (x, y) in enumerate(zip(a, b, strict=False)) if x != y), None)
        if at is not None:
            found.append((a[at][0], f"{topic} message {at} (stamp {a[at][0]}) differs"))
        elif len(a) != len(b):
            found.append((2**63, f"{topic}: {len(a)} messages recorded, {len(b)} replayed"))
    return min(found)[1] if found else None
