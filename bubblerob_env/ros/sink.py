"""``Sink``: where the fan-out sends a frame's serialised messages, a bag or a live ROS graph.

:class:`~bubblerob_env.ros.fanout.MessageFanout` serialises each message once per distro and
hands the same bytes to every sink of that distro. Two kinds meet this protocol:
:class:`~bubblerob_env.ros.bags.sinks.BagSink` (a ROS 1 ``.bag`` or a ROS 2 MCAP or sqlite3 bag,
from :func:`~bubblerob_env.ros.bags.sinks.open_bag`) and
:class:`~bubblerob_env.ros.live.sink.LiveSink` (publishers of a live ROS node). A sink takes
records, ``(topic, stamp, data)``; one that frames records (:meth:`Sink.framing` not ``None``:
MCAP, ROS 1, sqlite3 bags) also takes packed frames, the records of a frame in one byte string
(:mod:`~bubblerob_env.ros.fastpath.framing`), which is what makes recording fast.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

from bubblerob_env.ros.fastpath.framing import Framing, PackedBatchWriter, PackedWriter, Record

__all__ = ["PackedBatchWriter", "PackedWriter", "Sink"]


class Sink(Protocol):
    """What :class:`~bubblerob_env.ros.fanout.MessageFanout` needs of a place messages go."""

    distro: str
    """Whose message definitions the bytes follow (``noetic``, ``humble``, ``jazzy``)."""

    def add_topic(self, topic: str, msgtype: str, latched: bool = False) -> None:
        """Declare ``topic`` of ``msgtype`` (``pkg/msg/Type``) before its first record."""

    def write_batch(self, records: Sequence[Record]) -> None:
        """Take ``(topic, stamp, data)`` records, in order; their topics were added."""

    def framing(self) -> Framing | None:
        """How this sink frames records, if it takes packed frames; ``None``: records only."""

    def packed_writer(self) -> PackedWriter:
        """The callable that takes one packed frame (asked only when :meth:`framing` is set)."""

    def packed_batch_writer(self) -> PackedBatchWriter:
        """The callable that takes many packed frames (asked only when :meth:`framing` is set).

        Their bytes are valid during the call only: the fan-out packs its next batch into them.
        """

    def close(self) -> None:
        """Finish: a bag writes its index, a live sink stops publishing. Safe twice."""
