"""Episodes as a stream of frames in simulated time: what the recorder and live publisher share.

:class:`EpisodeStream` stamps an episode's frames ``start + info["sim_time"]``, starts each
episode one control step after the previous one ended (so that stamps increase strictly across
episodes), numbers the frames, and sends them with the episode's metadata record, its
ground-truth ``/map`` (and ``/tf_static`` first) to a
:class:`~bubblerob_env.ros.fastpath.serializer.MessageFanout`. The
:class:`~bubblerob_env.ros.recorder.RosBagRecorder` and the
:class:`~bubblerob_env.ros.live.wrapper.RosLivePublisher` both write through one, so that a live
run and a recording of the same seeds and actions carry the same stamps.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Mapping
from datetime import datetime, timezone
from decimal import Decimal, InvalidOperation
from pathlib import Path
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from bubblerob_env import names
from bubblerob_env.mapping import (
    DEFAULT_RESOLUTION,
    Grid,
    check_resolution,
    episode_grid,
    has_arena,
)
from bubblerob_env.ros.fanout import MessageFanout
from bubblerob_env.ros.messages.topics import Topics
from bubblerob_env.tasks.goals import NavProblem
from bubblerob_env.tasks.nav import BubbleRobNavEnv

__all__ = [
    "MAX_START_NS",
    "RESERVED_KEYS",
    "EpisodeStream",
    "env_metadata",
    "env_topics",
    "jsonable",
    "start_time_ns",
]

MAX_START_NS = 2**31 * 10**9
"""Start times must be below 2038-01-19: ROS 2 stamps hold seconds in an int32, and a recording
needs room to run (ROS 1 holds a uint32)."""


def start_time_ns(start_time: float | str | None = None) -> int:
    """A recording's epoch in nanoseconds since the Unix epoch.

    ``None`` means now (the wall clock); else Unix seconds (a number, or its text, exact to the
    nanosecond) or an ISO 8601 date (naive dates are UTC).
    """
    if start_time is None:
        return time.time_ns()
    try:
        nanoseconds = int(Decimal(str(start_time)) * 10**9)
    except (InvalidOperation, ValueError, OverflowError):
        try:
            moment = datetime.fromisoformat(str(start_time).replace("Z", "+00:00"))
        except ValueError:
            raise ValueError(
                f"start time {start_time!r} is neither Unix seconds nor an ISO 8601 date"
            ) from None
        if moment.tzinfo is None:
            moment = moment.replace(tzinfo=timezone.utc)
        nanoseconds = int(moment.timestamp()) * 10**9 + moment.microsecond * 1000
    if not 0 < nanoseconds < MAX_START_NS:
        raise ValueError(f"start time {start_time!r} is outside 1970-01-01 .. 2038-01-19 (UTC)")
    return nanoseconds


RESERVED_KEYS = frozenset({
    "episode", "seed", "rng_state", "options", "env_id", "env_kwargs", "max_episode_steps",
    "start_time_ns", "first_seq", "dt", "distro", "format", "topics", "bubblerob_version",
})  # fmt: skip
"""Keys of an episode's metadata that :meth:`EpisodeStream.reset` sets; users' facts may not."""


def jsonable(value: Any) -> Any:
    """``value`` as JSON data: numpy arrays and scalars as lists and numbers, the rest as text."""
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    return str(value)  # paths and the like


def env_metadata(env: gym.Env[Any, Any]) -> dict[str, Any]:
    """How to re-create ``env``: its registered id, constructor kwargs and step limit."""
    spec = env.spec
    if spec is None:
        return {"env_id": None, "env_kwargs": {}, "max_episode_steps": None}
    return {
        "env_id": spec.id,
        "env_kwargs": jsonable(spec.kwargs),
        "max_episode_steps": spec.max_episode_steps,
    }


def env_topics(env: gym.Env[Any, Any], topics: Topics) -> Topics:
    """``topics`` for ``env``: with a Nav env's goal and path (:meth:`Topics.for_nav`)."""
    return topics.for_nav() if isinstance(env.unwrapped, BubbleRobNavEnv) else topics


def _version() -> str:
    from bubblerob_env import __version__

    return __version__


class EpisodeStream:
    """Frames of consecutive episodes into ``fanout``, stamped in simulated nanoseconds.

    Args:
        fanout: Where the frames and records go.
        dt_ns: Simulated nanoseconds per env step (the gap before an episode's first frame).
        epoch_ns: Stamp of the first frame (nanoseconds since the Unix epoch): simulated time
            runs from it. ROS 1 tools drop messages stamped 0 ("invalid time"), so recorders
            and the live node pass a real time (:func:`start_time_ns`).
        map_resolution: Metres per cell of each episode's ``/map`` (see
            :func:`~bubblerob_env.mapping.check_resolution`).
    """

    def __init__(
        self,
        fanout: MessageFanout,
        dt_ns: int,
        epoch_ns: int = 0,
        map_resolution: float = DEFAULT_RESOLUTION,
    ) -> None:
        if not 0 <= epoch_ns < MAX_START_NS:  # 0: time from zero, for tests of the layers
            raise ValueError(f"start time {epoch_ns} ns is outside 0 .. {MAX_START_NS} ns")
        self.map_resolution = check_resolution(map_resolution)
        self.fanout = fanout
        self.dt_ns = dt_ns
        self.epoch_ns = epoch_ns
        self.seq = 0
        """Sequence number of the next frame (never restarts)."""
        self.episodes = 0
        self._warned_no_map = False
        """Episodes begun by :meth:`reset` so far (the next one's number)."""
        self.last_ns: int | None = None
        """Stamp of the latest frame; ``None`` before the first (or after :meth:`restart`)."""
        self._offset_ns = 0
        self._sent_problem: NavProblem | None = None  # a Nav env's goal and path last sent

    def restart(self) -> None:
        """Start again at the epoch with ``/tf_static`` (a new bag); sequence numbers go on."""
        self.last_ns = None

    def next_start(self) -> int:
        """The stamp the next episode's first frame will get."""
        return self.epoch_ns if self.last_ns is None else self.last_ns + self.dt_ns

    def reset(
        self,
        env: gym.Env[Any, Any],
        seed: int | None,
        options: dict[str, Any] | None,
        facts: Mapping[str, Any],
    ) -> tuple[Any, dict[str, Any], dict[str, Any]]:
        """Reset ``env`` and begin an episode: ``(obs, info, the episode's metadata)``.

        The metadata, the one definition of an episode's record: its number, the seed (or, for an
        unseeded reset, the state of the env's generator, which replay restores), the options,
        how to re-create the env, the start stamp and first sequence number, the step length,
        then ``facts`` (the writer's: distro, format, topics, users' facts).
        """
        rng_state = None
        if seed is None:  # replay restores the generator instead of seeding it
            rng_state = jsonable(env.unwrapped.np_random.bit_generator.state)
        obs, info = env.reset(seed=seed, options=options)
        if self.fanout.detects and self.fanout.detector is None:
            from bubblerob_env.vision.recognise import Recogniser  # numba: only for a camera

            self.fanout.detector = Recogniser.for_env(env.unwrapped)
        metadata = {
            "episode": self.episodes,
            "seed": seed,
            "rng_state": rng_state,
            "options": jsonable(options),
            **env_metadata(env),
            "start_time_ns": self.next_start(),
            "first_seq": self.seq,
            "dt": float(env.unwrapped.dt),  # type: ignore[attr-defined]
            "bubblerob_version": _version(),
            **jsonable(facts),
        }
        grid = None
        if self.fanout.topics.map is not None:
            if has_arena(env):
                grid = episode_grid(env, self.map_resolution)
            elif not self._warned_no_map:  # an xml_file scene without the arena's walls
                self._warned_no_map = True
                scene = Path(getattr(env.unwrapped, "xml_file", "the scene")).name
                warnings.warn(
                    f"{scene} has no arena walls ({', '.join(names.ARENA_WALLS)}): "
                    "no /map is published for it",
                    UserWarning,
                    stacklevel=2,
                )
        problem = getattr(env.unwrapped, "problem", None)  # a Nav env's goal and path
        self.begin(obs, info, metadata, grid, problem if isinstance(problem, NavProblem) else None)
        self.episodes += 1
        return obs, info, metadata

    def begin(
        self,
        obs: Mapping[str, NDArray[Any]],
        info: Mapping[str, Any],
        metadata: Mapping[str, Any],
        grid: Grid | None = None,
        problem: NavProblem | None = None,
    ) -> int:
        """Send a new episode's records and first frame (after a reset); its start stamp.

        ``/tf_static`` goes first when the stream (re)starts, then the episode's metadata record,
        ``/map`` of ``grid`` (if given), a Nav env's goal and path (``problem``) and the frame.
        """
        start = self.next_start()
        self._offset_ns = start - round(float(info["sim_time"]) * 1e9)
        if self.last_ns is None:
            self.fanout.write_records(lambda s: s.tf_static(start))
        self.fanout.write_records(lambda s: [s.episode(metadata, start)])
        if grid is not None:
            self.fanout.write_records(lambda s: s.map(grid, start))
        self._sent_problem = problem
        if problem is not None:
            self.fanout.write_records(lambda s: s.goal(problem, start))
        self.fanout.write_frame(obs, info, start, self.seq)
        self.seq += 1
        self.last_ns = start
        return start

    def new_goal(self, problem: NavProblem) -> None:
        """Send a goal and path set during an episode (once), stamped with its latest frame."""
        if self.last_ns is None:
            raise RuntimeError("new_goal before the episode's first frame")
        if problem is self._sent_problem:
            return
        stamp = self.last_ns
        self._sent_problem = problem
        self.fanout.write_records(lambda s: s.goal(problem, stamp))

    def follow_goal(self, env: gym.Env[Any, Any]) -> None:
        """Before a step: send a Nav env's goal if it changed since the last one sent.

        ``env.unwrapped.set_goal`` between steps is then in the bag, where replay sets it again.
        """
        problem = getattr(env.unwrapped, "problem", None)
        if isinstance(problem, NavProblem) and problem is not self._sent_problem:
            self.new_goal(problem)

    def step(
        self,
        obs: Mapping[str, NDArray[Any]],
        info: Mapping[str, Any],
        action: Any,
        reward: SupportsFloat,
        terminated: bool,
        truncated: bool,
    ) -> int:
        """Send the frame after a step; the action's topics are stamped with the frame before it.

        Returns the frame's stamp.
        """
        stamp = self._offset_ns + round(float(info["sim_time"]) * 1e9)
        self.fanout.write_frame(  # positional: called every step
            obs, info, stamp, self.seq, action, self.last_ns, reward, terminated, truncated
        )
        self.seq += 1
        self.last_ns = stamp
        return stamp
