"""``LiveSink``: a :class:`~bubblerob_env.ros.sink.Sink` publishing to a live ROS graph, not a file.

:class:`~bubblerob_env.ros.fanout.MessageFanout` serialises each message once per distro and
hands the same bytes to every sink of that distro: a bag, this sink, or both at once.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from bubblerob_env.ros.fastpath.framing import Framing, PackedBatchWriter, PackedWriter, Record
from bubblerob_env.ros.live.backend import LiveBackend, Publish

__all__ = ["LiveSink"]


class LiveSink:
    """Publishes every record on its topic through ``backend``; muted topics are skipped.

    A topic set with :meth:`publish_every` goes out only every ``n``-th record (the first, then
    every ``n``: the tutorial's Pioneer publishes ``/vrep/scan`` every 4th simulation step). Its
    records are counted whether muted or not, so a switch does not shift which steps publish.
    """

    def __init__(self, backend: LiveBackend) -> None:
        """Publish through ``backend`` (its distro decides which serializer feeds this sink)."""
        self.distro = backend.distro
        self.backend = backend
        self.closed = False
        self._publish: dict[str, Publish] = {}
        self._types: dict[str, str] = {}
        self.muted: set[str] = set()
        self.published = 0
        self._every: dict[str, int] = {}
        self._seen: dict[str, int] = {}

    def add_topic(self, topic: str, msgtype: str, latched: bool = False) -> None:
        """Advertise ``topic`` (latched topics reach late subscribers too)."""
        if topic not in self._publish:
            self._publish[topic] = self.backend.advertise(topic, msgtype, latched)
            self._types[topic] = msgtype

    def write_batch(self, records: Sequence[Record]) -> None:
        """Publish each record now (its stamp is already in the message where it has one)."""
        muted, every = self.muted, self._every
        for topic, _, data in records:
            if topic in every:
                seen = self._seen[topic]
                self._seen[topic] = seen + 1
                if seen % every[topic]:
                    continue
            if topic not in muted:
                self._publish[topic](data)
                self.published += 1

    def framing(self) -> Framing | None:
        """None: this sink takes records (each published as it comes), not packed frames."""
        return None

    def packed_writer(self) -> PackedWriter:
        """Not offered: :meth:`framing` is None, so the fan-out sends records."""
        raise NotImplementedError("LiveSink takes records, not packed frames")

    def packed_batch_writer(self) -> PackedBatchWriter:
        """Not offered: :meth:`framing` is None, so the fan-out sends records."""
        raise NotImplementedError("LiveSink takes records, not packed frames")

    def publish_every(self, topic: str, every: int) -> None:
        """Publish ``topic``'s first record, then every ``every``-th (1: all of them)."""
        if every < 1:
            raise ValueError(f"publish every n-th {topic} record needs n >= 1, got {every}")
        self._every[topic] = every
        self._seen[topic] = 0

    def latest_due(self, topic: str) -> bool:
        """Whether ``topic``'s latest record was one to publish (muted or not)."""
        every = self._every.get(topic, 1)
        return (self._seen.get(topic, 1) - 1) % every == 0

    def mute(self, topics: Iterable[str], muted: bool = True) -> None:
        """Stop (``muted``) or resume publishing ``topics``."""
        if muted:
            self.muted.update(topics)
        else:
            self.muted.difference_update(topics)

    def close(self) -> None:
        """Stop publishing (the backend's node is left running)."""
        self.closed = True

    @property
    def topics(self) -> tuple[str, ...]:
        """Topics advertised so far."""
        return tuple(self._publish)

    def msgtype(self, topic: str) -> str:
        """Message type of an advertised topic."""
        return self._types[topic]
