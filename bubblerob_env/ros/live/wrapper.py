"""``RosLivePublisher``: a Gymnasium wrapper that publishes every step of any loop live.

Frames are stamped exactly as :class:`~bubblerob_env.ros.recorder.RosBagRecorder` stamps them
(simulated time from a real start time, episodes back to back), so ``rosbag record`` of a live
run holds the messages a recorder writes for the same seeds, actions and start time, with
``/clock`` for ``use_sim_time``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from bubblerob_env.mapping import DEFAULT_RESOLUTION
from bubblerob_env.ros.episodes import EpisodeStream, env_topics, jsonable, start_time_ns
from bubblerob_env.ros.fanout import MessageFanout
from bubblerob_env.ros.live.backend import LiveBackend
from bubblerob_env.ros.live.connect import load_backend
from bubblerob_env.ros.live.sink import LiveSink
from bubblerob_env.ros.messages.topics import Topics
from bubblerob_env.ros.sink import Sink
from bubblerob_env.specs import EnvSpecs
from bubblerob_env.tasks.goals import NavProblem

__all__ = ["RosLivePublisher"]


class RosLivePublisher(gym.Wrapper[Any, Any, Any, Any]):
    """Publish every ``reset`` and ``step`` of a BubbleRob env on ROS topics as it happens.

    Example (ROS 1; needs a running ``roscore``)::

        env = RosLivePublisher(gym.make("BubbleRob-v0"), ros=1)
        obs, info = env.reset(seed=0)   # rviz shows the robot, /scan, /odom, /tf ...

    Args:
        env: A ``BubbleRob-v0`` env.
        backend: A started :class:`~bubblerob_env.ros.live.backend.LiveBackend`; default: start
            one with ``ros`` (it is shut down by :meth:`close`).
        ros: 1 (``rospy``) or 2 (``rclpy``) when no backend is given.
        topics: Topic names (default :class:`~bubblerob_env.ros.messages.topics.Topics`). The
            scan goes out every ``EnvSpecs.scan_every`` steps (the robot's: the Pioneer's 4th),
            the other topics and any bag in ``sinks`` every step.
        sinks: More sinks (bags from :func:`~bubblerob_env.ros.bags.sinks.open_bag`) fed with the
            same serialised bytes; they are closed by :meth:`close`.
        metadata: JSON-able facts published with every episode on the episode topic.
        start_time: Stamp of the first frame, Unix seconds or an ISO 8601 date (see
            :func:`~bubblerob_env.ros.episodes.start_time_ns`); default: now.
        map_resolution: Metres per cell of ``/map`` (latched, published again at every reset).
        static_map_to_odom: Publish the identity ``map -> odom`` on ``/tf_static``; False where
            a localiser publishes ``map -> odom`` on ``/tf`` (``bubblerob node --localize``).
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        backend: LiveBackend | None = None,
        ros: int = 1,
        topics: Topics | None = None,
        sinks: Sequence[Sink] = (),
        metadata: Mapping[str, Any] | None = None,
        start_time: float | str | None = None,
        map_resolution: float = DEFAULT_RESOLUTION,
        static_map_to_odom: bool = True,
    ) -> None:
        super().__init__(env)
        self.topics = env_topics(env, topics or Topics())
        self._own_backend = backend is None
        self.backend = backend or load_backend(ros, namespace=self.topics.namespace)
        self.specs = EnvSpecs.from_env(env)
        self.metadata = dict(jsonable(metadata or {}))
        self._dt_ns = round(float(env.unwrapped.dt) * 1e9)  # type: ignore[attr-defined]
        self.fanout = MessageFanout(self.specs, self.topics)
        self.sink = LiveSink(self.backend)
        self.scan_topic = self.topics.resolved().get("scan")
        """The laser's topic, published every ``specs.scan_every`` steps live (bags: every one)."""
        if self.scan_topic is not None and self.specs.laser is not None:
            self.sink.publish_every(self.scan_topic, self.specs.scan_every)
        self.fanout.add_sink(self.sink)
        self._extra = list(sinks)
        for sink in self._extra:
            self.fanout.add_sink(sink)
        for sink in (self.sink, *self._extra):
            self.fanout.serializer(sink.distro).converter.static_map_to_odom = static_map_to_odom
        self.episode = 0
        self.start_time_ns = start_time_ns(start_time)
        """Stamp of the first frame (nanoseconds since the Unix epoch)."""
        self._stream = EpisodeStream(self.fanout, self._dt_ns, self.start_time_ns, map_resolution)
        self._closed = False

    @property
    def dt_ns(self) -> int:
        """Simulated nanoseconds per step."""
        return self._dt_ns

    @property
    def seq(self) -> int:
        """Sequence number of the next frame."""
        return self._stream.seq

    @property
    def stamp_ns(self) -> int | None:
        """Stamp of the latest frame (nanoseconds: :attr:`start_time_ns` + simulated time)."""
        return self._stream.last_ns

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Reset the env and publish the first frame of a new episode (and its metadata)."""
        if self._closed:
            raise RuntimeError("this RosLivePublisher is closed")
        facts = {"distro": self.backend.distro, "format": "live", "topics": self.topics.to_dict()}
        obs, info, _ = self._stream.reset(self.env, seed, options, facts | self.metadata)
        self.episode += 1
        return obs, info

    def step(self, action: NDArray[Any]) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """Step the env and publish the frame (the action's topics stamped when it was sent)."""
        if self.stamp_ns is None or self._closed:
            raise RuntimeError("call reset() before step() (and do not step a closed publisher)")
        self._stream.follow_goal(self.env)  # a Nav env's goal set since the last step
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._stream.step(
            obs, info, np.asarray(action), float(reward), bool(terminated), bool(truncated)
        )
        return obs, float(reward), terminated, truncated, info

    def new_goal(self, problem: NavProblem) -> None:
        """Publish a Nav env's goal and path set mid-episode (stamped with the latest frame)."""
        self._stream.new_goal(problem)

    def close(self) -> None:
        """Stop publishing, close the extra sinks, shut down an own backend, close the env."""
        if not self._closed:
            self._closed = True
            self.sink.close()
            for sink in self._extra:
                sink.close()
            if self._own_backend:
                self.backend.shutdown("closed")
        super().close()
