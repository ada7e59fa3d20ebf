"""Replay a bag: re-simulate every episode from its metadata and compare every message.

For each episode the env is re-created from the recorded env id and kwargs, reset with the recorded
seed (or, for an unseeded reset, with the recorded state of its random generator), and stepped with
the recorded raw actions (``/bubblerob/action``, float64, exact). Every frame is serialised again
exactly as the recorder did and compared byte for byte with the recorded messages of every topic,
which covers the whole observation (laser, proximity, velocity via odometry, camera), the pose, the
action in physical units, rewards and episode ends. The first difference is reported field by field.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

import bubblerob_env  # noqa: F401  (registers BubbleRob-v0)
from bubblerob_env.ros.fastpath.framing import Record
from bubblerob_env.ros.fastpath.serializer import FrameSerializer
from bubblerob_env.ros.messages.distros import deserialize
from bubblerob_env.ros.messages.topics import MSGTYPES, NAV_TOPICS, Topics
from bubblerob_env.ros.readback.episode_env import make_episode_env
from bubblerob_env.ros.readback.scan import CorruptBagError
from bubblerob_env.ros.readback.summary import bag_root, find_episodes, open_reader
from bubblerob_env.specs import EnvSpecs

__all__ = ["Divergence", "ReplayError", "ReplayReport", "replay_bag"]


class ReplayError(RuntimeError):
    """The bag cannot be replayed (no metadata, no env id, ...)."""


@dataclass(frozen=True)
class Divergence:
    """The first place where the replay differs from the recording."""

    episode: int
    step: int  # 0: the reset frame
    topic: str
    field: str
    recorded: Any
    replayed: Any

    def __str__(self) -> str:
        where = "the reset" if self.step == 0 else f"step {self.step}"
        return (
            f"episode {self.episode}, {where}, {self.topic} {self.field}: "
            f"recorded {self.recorded!r}, replayed {self.replayed!r}"
        )


@dataclass(frozen=True)
class ReplayReport:
    """Outcome of :func:`replay_bag`."""

    path: Path
    episodes: int
    steps: int
    messages: int
    divergence: Divergence | None
    unfinished: bool = False
    """The bag was never finished: its complete episodes were replayed."""
    not_resimulated: tuple[tuple[str, int], ...] = ()
    """Messages of the replayed episodes that are read but not re-simulated, per topic: the
    episode records, the latched ``/tf_static`` and ``/map``. With these, ``messages`` adds
    up to ``bubblerob info``'s count for a bag replayed whole."""

    @property
    def ok(self) -> bool:
        """Whether every re-simulated message equals the recorded one."""
        return self.divergence is None

    def __str__(self) -> str:
        head = f"{self.path}: {self.episodes} episode(s), {self.steps} step(s), "
        if self.unfinished:
            head = f"{self.path}: unfinished recording: {self.episodes} complete episode(s), "
            head += f"{self.steps} step(s), "
        if self.ok:
            text = head + f"{self.messages} messages: replay matches the recording"
            if self.not_resimulated:
                others = ", ".join(f"{count} {topic}" for topic, count in self.not_resimulated)
                total = self.messages + sum(count for _, count in self.not_resimulated)
                text += f" ({total} in all: {others} not re-simulated)"
            return text
        return head + f"first divergence at {self.divergence}"


def _first_difference(value_a: Any, value_b: Any, path: str = "") -> tuple[str, Any, Any] | None:
    if hasattr(value_a, "__dataclass_fields__"):
        for name in value_a.__dataclass_fields__:
            found = _first_difference(
                getattr(value_a, name), getattr(value_b, name), f"{path}.{name}"
            )
            if found:
                return found
        return None
    if isinstance(value_a, (np.ndarray, list, tuple)):
        array_a, array_b = np.asarray(value_a), np.asarray(value_b)
        if array_a.dtype == object:
            for i, (a, b) in enumerate(zip(value_a, value_b, strict=False)):
                found = _first_difference(a, b, f"{path}[{i}]")
                if found:
                    return found
            return (
                None
                if len(value_a) == len(value_b)
                else (f"{path} length", len(value_a), len(value_b))
            )
        if array_a.shape != array_b.shape:
            return f"{path} shape", array_a.shape, array_b.shape
        differs = ~(
            (array_a == array_b) | (np.isnan(array_a) & np.isnan(array_b))
            if array_a.dtype.kind == "f"
            else (array_a == array_b)
        )
        if differs.any():
            i = int(np.flatnonzero(differs.reshape(-1))[0])
            return f"{path}[{i}]", array_a.reshape(-1)[i].item(), array_b.reshape(-1)[i].item()
        return None
    if value_a != value_b and not (value_a != value_a and value_b != value_b):  # NaN == NaN here
        return path, value_a, value_b
    return None


class _Episode:
    """Recorded messages of one episode, per topic, in time order."""

    def __init__(self, reader: Any, start: int, stop: int | None, topics: set[str]) -> None:
        self.path = getattr(reader, "path", None) or "the bag"
        connections = [c for c in reader.connections if c.topic in topics]
        self.messages: dict[str, list[tuple[int, bytes]]] = {t: [] for t in topics}
        for connection, stamp, raw in reader.messages(
            connections=connections, start=start, stop=stop
        ):
            self.messages[connection.topic].append((stamp, bytes(raw)))


def _make_env(meta: dict[str, Any]) -> gym.Env[Any, Any]:
    if not meta.get("env_id"):
        raise ReplayError("the bag's metadata has no env id: record with an env made by gym.make")
    return make_episode_env(meta, ReplayError)


def _serializer(env: gym.Env[Any, Any], meta: dict[str, Any]) -> FrameSerializer:
    try:
        topics = Topics.from_dict(meta["topics"])
        return FrameSerializer(EnvSpecs.from_env(env), meta["distro"], topics)
    except (KeyError, TypeError, ValueError) as error:
        raise ReplayError(
            f"episode {meta.get('episode')}'s metadata names no usable distro and topics "
            f"({type(error).__name__}: {error})"
        ) from None


def replay_bag(path: str | Path, max_episodes: int | None = None) -> ReplayReport:
    """Replay the bag at ``path`` (see the module docstring); stops at the first divergence.

    Args:
        path: The bag (see :func:`~bubblerob_env.ros.readback.layout.bag_root`).
        max_episodes: Replay only the first this many episodes (>= 1); default: all.

    Raises:
        ValueError: ``max_episodes`` is not an int >= 1.
        ReplayError: The bag holds no episode metadata, or its metadata is unusable.
        OSError: Not a bag (``BagLayoutError``), or a damaged one (``CorruptBagError``).
    """
    if max_episodes is not None and (
        not isinstance(max_episodes, int) or isinstance(max_episodes, bool) or max_episodes < 1
    ):
        raise ValueError(f"episodes to replay must be an int >= 1, got {max_episodes!r}")
    root = bag_root(path)
    episodes_done = steps = compared = 0
    compared_topics: set[str] = set()
    with open_reader(root) as reader:
        unfinished = getattr(reader, "unfinished", False)
        _, episodes = find_episodes(reader)
        if not episodes:
            raise ReplayError(f"{root} holds no bubblerob episode metadata: nothing to replay")
        env: gym.Env[Any, Any] | None = None
        env_key = None
        try:
            for index, meta in enumerate(episodes[:max_episodes]):
                key = (
                    meta.get("env_id"),
                    repr(meta.get("env_kwargs")),
                    meta.get("max_episode_steps"),
                )
                if env is None or key != env_key:
                    if env is not None:
                        env.close()
                    env, env_key = _make_env(meta), key
                serializer = _serializer(env, meta)
                stop = episodes[index + 1]["start_time_ns"] if index + 1 < len(episodes) else None
                per_frame = {name for name, _, latched in serializer.topics() if not latched}
                per_frame |= {serializer.names[k] for k in NAV_TOPICS if k in serializer.names}
                compared_topics |= per_frame
                recorded = _Episode(reader, meta["start_time_ns"], stop, per_frame)
                result = _replay_episode(env, serializer, meta, recorded)
                steps += result[0]
                compared += result[1]
                episodes_done += 1
                if result[2] is not None:
                    return ReplayReport(root, episodes_done, steps, compared, result[2], unfinished)
        finally:
            if env is not None:
                env.close()
        stop = None
        if max_episodes is not None and max_episodes < len(episodes):
            stop = int(episodes[max_episodes]["start_time_ns"])
        others = _not_resimulated(reader, compared_topics, stop)
    return ReplayReport(root, episodes_done, steps, compared, None, unfinished, others)


def _not_resimulated(
    reader: Any, compared: set[str], stop: int | None
) -> tuple[tuple[str, int], ...]:
    """Per topic, the messages up to ``stop`` (ns; None: all) that are not re-simulated."""
    connections = [c for c in reader.connections if c.topic not in compared]
    counts: dict[str, int] = {}
    for connection, _, _ in reader.messages(connections=connections, stop=stop):
        counts[connection.topic] = counts.get(connection.topic, 0) + 1
    return tuple(sorted(counts.items()))


def _replay_episode(
    env: gym.Env[Any, Any], serializer: FrameSerializer, meta: dict[str, Any], recorded: _Episode
) -> tuple[int, int, Divergence | None]:
    """``(steps, messages compared, first divergence)`` of one episode."""
    actions = _recorded_actions(serializer, meta, recorded)
    cursor = {topic: 0 for topic in recorded.messages}
    compared = 0

    def check(records: list[Record], step: int) -> Divergence | None:
        nonlocal compared
        for topic, stamp, data in records:
            i = cursor[topic]
            cursor[topic] += 1
            have = recorded.messages[topic]
            if i >= len(have):
                return Divergence(meta["episode"], step, topic, "message", "none", "one more")
            rec_stamp, rec_data = have[i]
            compared += 1
            if rec_stamp != stamp:
                return Divergence(meta["episode"], step, topic, "log time", rec_stamp, stamp)
            if rec_data != data:
                field, a, b = _field_difference(serializer, topic, rec_data, data)
                return Divergence(meta["episode"], step, topic, field, a, b)
        return None

    base = env.unwrapped
    if meta.get("seed") is None and meta.get("rng_state") is not None:
        generator = np.random.Generator(getattr(np.random, meta["rng_state"]["bit_generator"])())
        generator.bit_generator.state = meta["rng_state"]
        base.np_random = generator
    obs, info = env.reset(seed=meta.get("seed"), options=meta.get("options"))
    start = meta["start_time_ns"]
    offset = start - round(float(info["sim_time"]) * 1e9)
    seq = meta["first_seq"]
    convert = serializer.converter.frame_args
    detect = _detector(env, serializer)
    args = convert(obs, info, start, seq)
    records = serializer.frame(args, start, start, False) + detect(obs, start, seq)
    problem = getattr(base, "problem", None)  # a Nav env's goal and path, re-planned
    records += serializer.goal(problem, start) if problem else []
    # The goals set after a frame are planned once its records are compared (lazy ``or``).
    divergence = check(records, 0) or check(
        _goals_set_at(base, serializer, recorded, cursor, start), 0
    )
    if divergence is not None:
        return 0, compared, divergence
    last = start
    for step, action in enumerate(actions, start=1):
        obs, reward, terminated, truncated, info = env.step(action)
        seq += 1
        stamp = offset + round(float(info["sim_time"]) * 1e9)
        args = convert(obs, info, stamp, seq, action, float(reward), terminated, truncated)
        records = serializer.frame(args, stamp, last, True) + detect(obs, stamp, seq)
        divergence = check(records, step) or check(
            _goals_set_at(base, serializer, recorded, cursor, stamp), step
        )
        if divergence is not None:
            return step, compared, divergence
        last = stamp
    for topic, have in recorded.messages.items():
        if cursor[topic] < len(have):
            extra = f"one more at {have[cursor[topic]][0]} ns"
            return (
                len(actions),
                compared,
                Divergence(meta["episode"], len(actions), topic, "message", extra, "none"),
            )
    return len(actions), compared, None


def _goals_set_at(
    base: Any, serializer: FrameSerializer, recorded: _Episode, cursor: dict[str, int], stamp: int
) -> list[Record]:
    """A Nav env's goals set after the frame at ``stamp`` (live, or ``set_goal`` between steps).

    Each recorded goal not yet compared with that stamp is set again, from its recorded path's
    first point (the node plans from its pose estimate with ``--localize``); the records of the
    new goal and path, to compare. A goal the env refuses is left for the end's count.
    """
    names = serializer.names
    if "goal" not in names or "plan" not in names or not hasattr(base, "set_goal"):
        return []
    goals, plans = recorded.messages[names["goal"]], recorded.messages[names["plan"]]
    records: list[Record] = []
    first, first_plan = cursor[names["goal"]], cursor[names["plan"]]
    for k, (at, raw) in enumerate(goals[first:]):
        if at != stamp or first_plan + k >= len(plans):
            break
        decode = _decoder(serializer)
        try:
            position = decode(raw, MSGTYPES["goal"]).pose.position
            start = decode(plans[first_plan + k][1], MSGTYPES["plan"]).poses[0].pose.position
            problem = base.set_goal((position.x, position.y), (start.x, start.y))
        except (ValueError, IndexError):
            break
        records += serializer.goal(problem, stamp)
    return records


def _recorded_actions(
    serializer: FrameSerializer, meta: dict[str, Any], recorded: _Episode
) -> list[NDArray[np.float64]]:
    """The episode's actions, decoded; a message that does not decode is a damaged bag."""
    decode = _decoder(serializer)
    actions = []
    for stamp, raw in recorded.messages[serializer.names["action"]]:
        try:
            action = np.asarray(decode(raw, MSGTYPES["action"]).data, dtype=np.float64)
        except Exception as error:  # noqa: BLE001 - damaged bytes fail in many ways
            raise CorruptBagError(
                f"{recorded.path}: episode {meta['episode']}'s action at {stamp} ns does not "
                f"deserialize ({error})"
            ) from None
        actions.append(action)
    return actions


def _detector(env: gym.Env[Any, Any], serializer: FrameSerializer) -> Any:
    """``detect(obs, stamp, seq)``: the ``/detections`` record of a frame, as the recorder's."""
    if not serializer.detects:
        return lambda obs, stamp, seq: []
    from bubblerob_env.vision.recognise import Recogniser  # numba: only for a camera

    recogniser = Recogniser.for_env(env.unwrapped)
    return lambda obs, stamp, seq: serializer.detections(recogniser(obs["camera"]), stamp, seq)


def _decoder(serializer: FrameSerializer) -> Any:
    name = serializer.distro.name
    return lambda raw, msgtype: deserialize(name, raw, msgtype)


def _field_difference(
    serializer: FrameSerializer, topic: str, recorded: bytes, replayed: bytes
) -> tuple[str, Any, Any]:
    key = next(k for k, name in serializer.names.items() if name == topic)
    decode = _decoder(serializer)
    try:
        found = _first_difference(decode(recorded, MSGTYPES[key]), decode(replayed, MSGTYPES[key]))
    except Exception as error:  # noqa: BLE001 - a corrupt recorded message is a divergence too
        return f"bytes (undecodable: {error})", len(recorded), len(replayed)
    return found or ("bytes", recorded.hex(), replayed.hex())
