"""Serialise env frames once per distro and hand the bytes to every sink of that distro.

:class:`FrameSerializer` knows, for one distro and topic set, which messages a frame has and how
to serialise each (compiled once, see :mod:`~bubblerob_env.ros.encode`). :class:`MessageFanout`
turns a frame into field values once, serialises it once per distro among its sinks, and gives
the same bytes to each sink: a recorder has one sink; live publishing adds more.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from numpy.typing import NDArray

from bubblerob_env.ros.convert import EnvSpecs, RosConverter
from bubblerob_env.ros.encode import CompiledMessage, compile_message
from bubblerob_env.ros.sinks import BagSink
from bubblerob_env.ros.topics import LATCHED_TOPICS, MSGTYPES, Topics
from bubblerob_env.ros.writers import Record

__all__ = ["FrameSerializer", "MessageFanout"]


class FrameSerializer:
    """Serialised messages of frames, for one distro and topic set."""

    def __init__(self, specs: EnvSpecs, distro: str, topics: Topics) -> None:
        self.converter = RosConverter(specs, distro)
        self.names = topics.resolved()
        store = self.converter.store
        encoding = self.converter.distro.encoding
        self.encoding = encoding
        slots = self.converter.slots()
        action_keys = set(self.converter.action_keys())

        def plan(stepped: bool) -> list[tuple[str, CompiledMessage, bool]]:
            return [
                (self.names[key], encoders[key], key in action_keys)
                for key in self.converter.frame_keys(stepped)
                if key in self.names
            ]

        encoders = {
            key: compile_message(store, MSGTYPES[key], self.converter.message(key, slots), encoding)
            for key in self.converter.frame_keys(True)
            if key in self.names
        }
        self._plans = {False: plan(False), True: plan(True)}

    def topics(self) -> list[tuple[str, str, bool]]:
        """``(name, msgtype, latched)`` of every topic a bag of these frames holds."""
        keys = [*self.converter.frame_keys(True), *LATCHED_TOPICS]
        return [(self.names[k], MSGTYPES[k], k in LATCHED_TOPICS) for k in keys if k in self.names]

    def frame(
        self, values: Mapping[str, Any], stamp_ns: int, action_stamp_ns: int, stepped: bool
    ) -> list[Record]:
        """Records of one frame; the action's topics are logged at ``action_stamp_ns``."""
        return [
            (name, action_stamp_ns if is_action else stamp_ns, encoder.encode(values))
            for name, encoder, is_action in self._plans[stepped]
        ]

    def _serialize(self, key: str, message: Any) -> bytes:
        store = self.converter.store
        if self.encoding == "ros1":
            return bytes(store.serialize_ros1(message, MSGTYPES[key]))
        return bytes(store.serialize_cdr(message, MSGTYPES[key], little_endian=True))

    def tf_static(self, stamp_ns: int) -> list[Record]:
        """The ``/tf_static`` record (none if that topic is left out)."""
        if "tf_static" not in self.names:
            return []
        message = self.converter.tf_static(stamp_ns)
        return [(self.names["tf_static"], stamp_ns, self._serialize("tf_static", message))]

    def episode(self, metadata: Mapping[str, Any], stamp_ns: int) -> Record:
        """The episode metadata record (``std_msgs/String`` holding JSON)."""
        message = self.converter.episode(metadata)
        return (self.names["episode"], stamp_ns, self._serialize("episode", message))


class MessageFanout:
    """Frames in, serialised records out to every sink; each message serialised once per distro."""

    def __init__(self, specs: EnvSpecs, topics: Topics) -> None:
        self.specs = specs
        self.topics = topics
        self._serializers: dict[str, FrameSerializer] = {}
        self._sinks: dict[str, list[BagSink]] = {}

    def serializer(self, distro: str) -> FrameSerializer:
        """The serializer of ``distro`` (made on first use)."""
        if distro not in self._serializers:
            self._serializers[distro] = FrameSerializer(self.specs, distro, self.topics)
        return self._serializers[distro]

    def add_sink(self, sink: BagSink) -> None:
        """Start sending to ``sink``, declaring every topic in it."""
        for name, msgtype, latched in self.serializer(sink.distro).topics():
            sink.add_topic(name, msgtype, latched)
        self._sinks.setdefault(sink.distro, []).append(sink)

    def remove_sink(self, sink: BagSink) -> None:
        """Stop sending to ``sink`` (it is not closed)."""
        self._sinks[sink.distro].remove(sink)
        if not self._sinks[sink.distro]:
            del self._sinks[sink.distro]

    @property
    def sinks(self) -> list[BagSink]:
        """Every sink, in the order they were added per distro."""
        return [sink for group in self._sinks.values() for sink in group]

    def write_frame(
        self,
        obs: Mapping[str, NDArray[Any]],
        info: Mapping[str, Any],
        stamp_ns: int,
        seq: int,
        action: NDArray[Any] | None = None,
        action_stamp_ns: int | None = None,
        reward: float = 0.0,
        terminated: bool = False,
        truncated: bool = False,
    ) -> None:
        """Send one frame (``action=None``: a reset) to every sink."""
        if not self._sinks:
            return
        first = self.serializer(next(iter(self._sinks)))
        values = first.converter.frame_values(
            obs, info, stamp_ns, seq, action, reward, terminated, truncated
        )
        stepped = action is not None
        action_stamp = stamp_ns if action_stamp_ns is None else action_stamp_ns
        for distro, sinks in self._sinks.items():
            records = self._serializers[distro].frame(values, stamp_ns, action_stamp, stepped)
            for sink in sinks:
                sink.write_batch(records)

    def write_records(self, make: Any) -> None:
        """Send records made per distro by ``make(serializer) -> list[Record]``."""
        for distro, sinks in self._sinks.items():
            records = make(self._serializers[distro])
            if records:
                for sink in sinks:
                    sink.write_batch(records)
