"""``RosBagRecorder``: a Gymnasium wrapper that records every step of every episode into a bag.

Timestamps are simulated time from a real epoch (the recorder's wall-clock start by default, or
``start_time``): an episode's frames are stamped ``start + info["sim_time"]``, and each episode
starts one control step after the previous one ended, so that time increases strictly across the
episodes of a bag. With ``per_episode=True`` each episode gets its own bag instead.
"""

from __future__ import annotations

import json
import multiprocessing
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import gymnasium as gym
from numpy.typing import NDArray

from bubblerob_env.mapping import DEFAULT_RESOLUTION
from bubblerob_env.ros.bags import safety
from bubblerob_env.ros.bags.process import ProcessBagSink, can_write_apart, open_bag_in_process
from bubblerob_env.ros.bags.sinks import (
    DEFAULT_DISTRO,
    FORMATS,
    BagSink,
    bag_path,
    open_bag,
    remove_bag,
)
from bubblerob_env.ros.episodes import (
    RESERVED_KEYS,
    EpisodeStream,
    env_topics,
    jsonable,
    start_time_ns,
)
from bubblerob_env.ros.fanout import MessageFanout
from bubblerob_env.ros.messages.topics import Topics
from bubblerob_env.specs import EnvSpecs
from bubblerob_env.tasks.nav import BubbleRobNavEnv

__all__ = [
    "EPISODES_KEY",
    "RECORDING_KEY",
    "RosBagRecorder",
    "WRITERS",
    "recorded_env_fns",
]

EPISODES_KEY = "bubblerob.episodes"
"""ROS 2 bags: ``custom_data`` key (metadata.yaml and the MCAP ``rosbag2`` metadata record) of a
JSON list with each episode's number, seed and start time. The env id, kwargs, policy and the rest
are under ``bubblerob.recording``; every episode's full metadata is on the episode topic."""
RECORDING_KEY = "bubblerob.recording"
WRITERS = ("inline", "process")
"""Who writes a bag: the recording process, or a process of its own (the default where
:func:`~bubblerob_env.ros.bags.process.can_write_apart`)."""
_SUMMARY_KEYS = ("episode", "seed", "start_time_ns")
_SHARED_KEYS = ("episode", "seed", "rng_state", "options", "start_time_ns", "first_seq")


class RosBagRecorder(gym.Wrapper[Any, Any, Any, Any]):
    """Record every ``reset`` and ``step`` of a BubbleRob env into a ROS bag.

    The bag is created when the wrapper is (so a bad path fails before the first step) and
    finished by :meth:`close`, or, if the program dies of an exception, Ctrl-C or SIGTERM first,
    by :mod:`~bubblerob_env.ros.bags.safety`; either way it holds every completed step. A recorder
    closed before its first ``reset`` removes its empty bag: ``AsyncVectorEnv`` makes and closes
    one env only to read the spaces, and its worker must be able to create the same bag.

    Example:
        >>> env = RosBagRecorder(gym.make("BubbleRob-v0"), "runs/demo", metadata={"policy": "me"})
        >>> obs, info = env.reset(seed=0)  # doctest: +SKIP
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        path: str | Path,
        format: str = "mcap",  # noqa: A002 - the natural name, as in the CLI's --format
        distro: str | None = None,
        compression: str | None = None,
        topics: Topics | None = None,
        overwrite: bool = False,
        metadata: Mapping[str, Any] | None = None,
        per_episode: bool = False,
        start_time: float | str | None = None,
        map_resolution: float = DEFAULT_RESOLUTION,
        writer: str | None = None,
    ) -> None:
        """Wrap ``env`` and create the bag.

        Args:
            env: A ``BubbleRob-v0`` env (made with ``gym.make`` so that replay can re-create it).
            path: The bag (ROS 1: ``.bag`` file; ROS 2: directory). With ``per_episode``, a
                directory that gets one bag per episode, ``episode_000000`` and on.
            format: ``"mcap"`` (default), ``"sqlite3"`` or ``"ros1"``.
            distro: ``"jazzy"`` (default) or ``"humble"`` for ROS 2 formats, ``"noetic"`` for ROS 1.
            compression: MCAP: ``"zstd"`` (default) or ``"none"``; ROS 1: ``"none"`` (default),
                ``"bz2"`` or ``"lz4"``.
            topics: Topic names (default :class:`~bubblerob_env.ros.messages.topics.Topics`).
            overwrite: Replace existing bags instead of raising ``FileExistsError``.
            metadata: JSON-able facts stored with every episode, e.g. ``{"policy": "reactive"}``.
            per_episode: One bag per episode instead of one for all.
            start_time: Stamp of the first frame, Unix seconds or an ISO 8601 date (see
                :func:`~bubblerob_env.ros.episodes.start_time_ns`); default: now. Simulated
                time runs from it; with ``per_episode`` every bag starts at it.
            map_resolution: Metres per cell of each episode's ``/map`` (the ground-truth
                occupancy grid, written once per episode at its start stamp), 0.005 to 1.
            writer: ``"process"``: a process of its own converts, packs, compresses and writes
                the frames (:mod:`~bubblerob_env.ros.bags.process`), off the stepping loop;
                ``"inline"``: this process writes the bag. The same bytes either way. Default:
                ``"process"`` where it helps and is safe (Linux, two or more usable cores, no other
                thread, not a daemonic process: see
                :func:`~bubblerob_env.ros.bags.process.can_write_apart`), else ``"inline"``. A
                daemonic process (an ``AsyncVectorEnv`` worker) always writes inline: it may not
                start processes.
        """
        super().__init__(env)
        if not isinstance(env.observation_space, gym.spaces.Dict):  # before the bag is made
            raise ValueError(
                "a recorder makes ROS messages from the Dict observation, but this env gives "
                f"{type(env.observation_space).__name__} observations: make it with obs_mode "
                "'dict' (the default)"
            )
        if format not in FORMATS:
            raise ValueError(f"unknown bag format {format!r}; choose one of {list(FORMATS)}")
        if writer is None:
            writer = "process" if can_write_apart() else "inline"
        if writer not in WRITERS:
            raise ValueError(f"unknown bag writer {writer!r}; choose one of {list(WRITERS)}")
        self.writer = writer
        self.format = format
        self.distro = distro or DEFAULT_DISTRO[format]
        self.compression = compression
        self.topics = env_topics(env, topics or Topics())
        self.overwrite = overwrite
        self.per_episode = per_episode
        self.metadata = dict(jsonable(metadata or {}))
        clash = sorted(RESERVED_KEYS & set(self.metadata))
        if clash:
            raise ValueError(f"metadata keys {clash} are reserved for the recorder")
        self.path = Path(path)
        self.specs = EnvSpecs.from_env(env)
        self._dt = float(env.unwrapped.dt)  # type: ignore[attr-defined]
        self._dt_ns = round(self._dt * 1e9)
        self._fanout = MessageFanout(self.specs, self.topics)
        self._fanout.serializer(self.distro)  # compile now: errors before the first step
        self._episodes: list[dict[str, Any]] = []
        self._episode_count = 0
        self._ended_in_bag = 0  # episodes ended (and flushed) in the open bag
        self._saved_before = 0  # episodes on disk in the bags closed before it
        self.start_time_ns = start_time_ns(start_time)
        self._stream = EpisodeStream(self._fanout, self._dt_ns, self.start_time_ns, map_resolution)
        facts = {"distro": self.distro, "format": self.format, "topics": self.topics.to_dict()}
        self._facts = jsonable(facts | self.metadata)  # every episode's: made once
        self._goals = isinstance(env.unwrapped, BubbleRobNavEnv)  # goals set between steps
        self._sink: BagSink | ProcessBagSink | None = None
        self._closed = False
        self._bag_paths: list[Path] = []
        self._open_bag(0)
        self._token = safety.register(self._finish)

    @property
    def completed_episodes(self) -> int:
        """Episodes recorded to their end (terminated or truncated) and on disk, in every bag.

        With ``writer="process"``, the episodes the writer has flushed (it may be a batch or two
        behind while recording); exact once the recorder is closed, even after an error (a full
        disk): what reads back.
        """
        return self._saved_before + self._saved_in(self._sink)

    def _saved_in(self, sink: BagSink | ProcessBagSink | None) -> int:
        if isinstance(sink, ProcessBagSink):  # one flush per episode's end
            return sink.flushed
        return self._ended_in_bag

    # -- bags -----------------------------------------------------------------------------------

    @property
    def bag_paths(self) -> list[Path]:
        """Every bag this recorder has created so far."""
        return list(self._bag_paths)

    def _target(self, episode: int) -> Path:
        if self.per_episode:
            return self.path / f"episode_{episode:06d}"
        return self.path

    def _open_bag(self, episode: int) -> None:
        # A daemonic process (an AsyncVectorEnv worker) may not start one: it writes inline.
        apart = self.writer == "process" and not multiprocessing.current_process().daemon
        opener = open_bag_in_process if apart else open_bag
        sink = opener(
            self._target(episode), self.format, self.distro, self.compression, self.overwrite
        )
        self._bag_paths.append(sink.path)
        self._fanout.add_sink(sink)
        self._sink = sink
        self._ended_in_bag = 0
        self._episodes = []
        self._stream.restart()  # each bag starts at the start time

    def _close_bag(self) -> None:
        sink, self._sink = self._sink, None
        if sink is None:
            return
        with safety.critical:
            try:
                self._finish_bag(sink)
            finally:  # what is on disk, even after an error
                self._saved_before += self._saved_in(sink)
                self._ended_in_bag = 0

    def _finish_bag(self, sink: BagSink | ProcessBagSink) -> None:
        try:
            self._fanout.remove_sink(sink)  # writes the frames still batched
        finally:  # whatever happened, finish the file: it holds every frame written
            if self._episodes:  # kept small: ruamel.yaml dumps long strings slowly
                summary = [{k: e[k] for k in _SUMMARY_KEYS} for e in self._episodes]
                shared = {k: v for k, v in self._episodes[-1].items() if k not in _SHARED_KEYS}
                sink.set_metadata(EPISODES_KEY, json.dumps(summary, sort_keys=True))
                sink.set_metadata(RECORDING_KEY, json.dumps(shared, sort_keys=True))
            sink.close()
            if not self._episodes:  # closed before any reset: leave no empty bag behind
                remove_bag(sink.path)
                self._bag_paths.remove(sink.path)

    def _finish(self) -> None:
        """Close the bag (atexit and signal paths); the env is left alone."""
        if not self._closed:
            self._closed = True
            try:
                self._close_bag()
            finally:  # even when the disk is full: the handlers go back
                safety.unregister(self._token)

    # -- gym API --------------------------------------------------------------------------------

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Reset the env and record the first frame of a new episode."""
        if self._closed:
            raise RuntimeError(f"the recorder of {self.path} is closed")
        with safety.critical:
            if self.per_episode and self._episode_count > 0:
                self._close_bag()
                self._open_bag(self._episode_count)
            obs, info, episode = self._stream.reset(self.env, seed, options, self._facts)
            self._episodes.append(episode)
            self._episode_count += 1
        return obs, info

    def step(self, action: NDArray[Any]) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """Step the env and record the frame; the step is recorded whole or not at all."""
        if self._stream.last_ns is None or self._closed:
            raise RuntimeError("call reset() before step() (and do not step a closed recorder)")
        with safety.critical:
            if self._goals:
                self._stream.follow_goal(self.env)  # a Nav env's goal set since the last step
            obs, reward, terminated, truncated, info = self.env.step(action)
            self._stream.step(obs, info, action, reward, terminated, truncated)
            if (terminated or truncated) and self._sink is not None:
                self._fanout.flush()  # batched frames, then the sink's chunk: on disk
                self._sink.flush()
                self._ended_in_bag += 1
        return obs, float(reward), terminated, truncated, info

    def close(self) -> None:
        """Finish the bag, then close the env."""
        try:
            self._finish()
        finally:
            super().close()


def recorded_env_fns(
    env_id: str,
    num_envs: int,
    directory: str | Path,
    env_kwargs: Mapping[str, Any] | None = None,
    **recorder_kwargs: Any,
) -> list[Callable[[], gym.Env[Any, Any]]]:
    """Env factories for a vector env in which every sub-env records its own bag.

    Sub-env ``i`` records into ``directory/env_<i>`` (``.bag`` for ROS 1)::

        envs = gym.vector.SyncVectorEnv(recorded_env_fns("BubbleRob-v0", 4, "runs/vec"))

    Works with ``AsyncVectorEnv`` too: each worker process creates and finishes its own bag.
    """
    kwargs = dict(env_kwargs or {})
    fmt = recorder_kwargs.get("format", "mcap")

    def factory(index: int) -> Callable[[], gym.Env[Any, Any]]:
        def make() -> gym.Env[Any, Any]:
            env = gym.make(env_id, **kwargs)
            return RosBagRecorder(env, Path(directory) / f"env_{index}", **recorder_kwargs)

        return make

    for index in range(num_envs):  # fail early, in this process, on an existing bag
        target = bag_path(Path(directory) / f"env_{index}", fmt)
        if target.exists() and not recorder_kwargs.get("overwrite", False):
            raise FileExistsError(f"bag {target} already exists; pass overwrite=True")
    return [factory(i) for i in range(num_envs)]
