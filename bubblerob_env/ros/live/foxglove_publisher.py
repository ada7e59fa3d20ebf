"""``FoxglovePublisher``: any RL loop live in Foxglove, as ``RosLivePublisher`` is on ROS.

A :class:`~bubblerob_env.ros.live.wrapper.RosLivePublisher` on a Foxglove server of its own
(:class:`~bubblerob_env.ros.live.foxglove.FoxgloveBackend`): the same topics, types and stamps,
no ROS. With a ``budget`` it publishes whole episodes only while publishing has cost at most
that fraction of the wall time since it started (training: a few percent), so a viewer sees
whole episodes, now and then, and the loop barely slows; with ``watched_only`` too, only while
a client subscribes to something (training when nobody watches: no cost at all).
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium as gym
from numpy.typing import NDArray

from bubblerob_env.mapping import DEFAULT_RESOLUTION
from bubblerob_env.ros.live.foxglove import DEFAULT_HOST, DEFAULT_PORT, FoxgloveBackend
from bubblerob_env.ros.live.foxglove_robot import publish_robot_model
from bubblerob_env.ros.live.wrapper import RosLivePublisher
from bubblerob_env.ros.messages.topics import Topics
from bubblerob_env.ros.sink import Sink

__all__ = ["FoxglovePublisher"]


class _InnerClock(gym.Wrapper[Any, Any, Any, Any]):
    """Adds up the seconds the wrapped env itself takes, to tell publishing's cost apart."""

    def __init__(self, env: gym.Env[Any, Any]) -> None:
        super().__init__(env)
        self.seconds = 0.0

    def reset(self, **kwargs: Any) -> Any:
        began = time.perf_counter()
        try:
            return self.env.reset(**kwargs)
        finally:
            self.seconds += time.perf_counter() - began

    def step(self, action: Any) -> Any:
        began = time.perf_counter()
        try:
            return self.env.step(action)
        finally:
            self.seconds += time.perf_counter() - began


class FoxglovePublisher(RosLivePublisher):
    """Publish every ``reset`` and ``step`` of a BubbleRob env to Foxglove as it happens.

    Example::

        env = FoxglovePublisher(gym.make("BubbleRob-v0"), port=8765)
        print(env.url)              # ws://127.0.0.1:8765: Foxglove's "Open connection"
        obs, info = env.reset(seed=0)

    Args:
        env: A BubbleRob env.
        host: Address to listen on (loopback by default).
        port: Port to listen on; 0: any free one (see :attr:`url`).
        budget: Publish whole episodes only while publishing has taken at most this fraction of
            the wall time since the first reset (e.g. 0.04); ``None``: publish every episode.
        watched_only: Publish an episode only if a client subscribes to a topic when it
            starts (a client that connects mid-episode sees the next one from its start, with
            the latched topics sent again on subscribing, as when the budget skips episodes).
        topics, sinks, metadata, start_time, map_resolution: As for
            :class:`~bubblerob_env.ros.live.wrapper.RosLivePublisher`.

    Raises:
        BackendError: The server cannot listen there (a port in use); RosUnavailableError:
            ``foxglove-sdk`` is missing (the ``foxglove`` extra).
    """

    def __init__(
        self,
        env: gym.Env[Any, Any],
        host: str = DEFAULT_HOST,
        port: int = DEFAULT_PORT,
        budget: float | None = None,
        topics: Topics | None = None,
        sinks: Sequence[Sink] = (),
        metadata: Mapping[str, Any] | None = None,
        start_time: float | str | None = None,
        map_resolution: float = DEFAULT_RESOLUTION,
        watched_only: bool = False,
    ) -> None:
        if budget is not None and not 0 < budget <= 1:
            raise ValueError(f"budget must be a fraction in (0, 1], got {budget!r}")
        backend = FoxgloveBackend(host, port)
        self._inner = _InnerClock(env)
        try:
            super().__init__(
                self._inner,
                backend,
                topics=topics,
                sinks=sinks,
                metadata=metadata,
                start_time=start_time,
                map_resolution=map_resolution,
            )
            publish_robot_model(backend, env, self.topics)
        except BaseException:
            backend.shutdown()
            raise
        self.budget = budget
        self.watched_only = watched_only
        self.publishing = True
        """Whether the current episode is published (always, without a budget)."""
        self.published_episodes = 0
        self.skipped_episodes = 0
        self._spent = 0.0
        self._began: float | None = None

    @property
    def url(self) -> str:
        """``ws://host:port``, where Foxglove connects."""
        assert isinstance(self.backend, FoxgloveBackend)
        return self.backend.url

    @property
    def overhead(self) -> float:
        """Seconds spent publishing so far (the wrapped env's own time left out)."""
        return self._spent

    def _timed(self, call: Any, *args: Any, **kwargs: Any) -> Any:
        inner, began = self._inner.seconds, time.perf_counter()
        try:
            return call(*args, **kwargs)
        finally:
            self._spent += time.perf_counter() - began - (self._inner.seconds - inner)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Reset; publish the new episode if the budget allows (see the class doc)."""
        now = time.perf_counter()
        if self._began is None:
            self._began = now
        elapsed = now - self._began
        within = self.budget is None or self._spent <= self.budget * elapsed
        self.publishing = within and (not self.watched_only or self._backend_watched())
        if not self.publishing:
            self.skipped_episodes += 1
            return self._inner.reset(seed=seed, options=options)  # type: ignore[no-any-return]
        self.published_episodes += 1
        return self._timed(super().reset, seed=seed, options=options)  # type: ignore[no-any-return]

    def _backend_watched(self) -> bool:
        assert isinstance(self.backend, FoxgloveBackend)
        return self.backend.watched()

    def step(self, action: NDArray[Any]) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """Step; published if this episode is (see :attr:`publishing`)."""
        if not self.publishing:
            return self._inner.step(action)  # type: ignore[no-any-return]
        return self._timed(super().step, action)  # type: ignore[no-any-return]

    def close(self) -> None:
        """Close the env and stop the server."""
        super().close()
        self.backend.shutdown("closed")
