"""Serialise env frames once per distro and hand the bytes to every sink of that distro.

:class:`FrameSerializer` knows, for one distro and topic set, which messages a frame has and how
to serialise each (compiled once, see :mod:`~bubblerob_env.ros.encode`). :class:`MessageFanout`
turns a frame into field values once, serialises it once per distro among its sinks, and gives
the same bytes to each sink: a recorder has one sink; live publishing adds more.

Bag sinks that frame records themselves (MCAP, ROS 1: :meth:`~bubblerob_env.ros.sinks.BagSink.
framing`) get the whole frame, record headers included, from one generated ``struct`` call of a
:class:`FramePacker`; other sinks of that distro get records sliced from those bytes.
"""

from __future__ import annotations

import struct
from collections.abc import Mapping, Sequence
from typing import Any

from numpy.typing import NDArray

from bubblerob_env.ros.convert import EnvSpecs, RosConverter
from bubblerob_env.ros.encode import CompiledMessage, Item, compile_items, compile_message
from bubblerob_env.ros.sinks import BagSink
from bubblerob_env.ros.topics import LATCHED_TOPICS, MSGTYPES, Topics
from bubblerob_env.ros.writers import FrameLayout, Framing, Record

__all__ = ["FramePacker", "FrameSerializer", "MessageFanout"]

_Plan = list[tuple[str, CompiledMessage, bool]]  # (topic, encoder, logged at the action stamp)


class FramePacker:
    """One frame's records, each behind its :class:`~bubblerob_env.ros.writers.Framing` header.

    The whole frame is packed by one ``struct`` call (constants folded, see
    :func:`~bubblerob_env.ros.encode.compile_items`); :attr:`layout` tells the writer where each
    record starts, so that it can index them when the chunk closes.
    """

    def __init__(self, plan: _Plan, framing: Framing) -> None:
        items: list[Item] = []
        channels, offsets, action = [], [], []
        self._payloads: list[tuple[str, int, int, bool]] = []
        ids = dict(framing.ids)
        pos = 0
        for topic, encoder, is_action in plan:
            header = framing.header(topic, encoder.size, is_action)
            head = struct.calcsize("<" + "".join(code for code, _ in header))
            channels.append(ids[topic])
            offsets.append(pos)
            action.append(is_action)
            self._payloads.append((topic, pos + head, pos + head + encoder.size, is_action))
            items += header
            items += encoder.items
            pos += head + encoder.size
        self._compiled = compile_items(items)
        assert self._compiled.size == pos
        self.layout = FrameLayout(tuple(channels), tuple(offsets), tuple(action), pos)
        self._ros1 = framing.kind == "ros1"

    def pack(self, values: dict[str, Any], stamp_ns: int, action_stamp_ns: int) -> bytes:
        """The frame's bytes; adds the log-time slots to ``values``."""
        values["log_ns"] = stamp_ns
        values["action_log_ns"] = action_stamp_ns
        if self._ros1:
            values["log_sec"], values["log_nsec"] = divmod(stamp_ns, 1_000_000_000)
            values["action_log_sec"], values["action_log_nsec"] = divmod(
                action_stamp_ns, 1_000_000_000
            )
        return self._compiled.encode(values)

    def records(self, data: bytes, stamp_ns: int, action_stamp_ns: int) -> list[Record]:
        """The frame's records, their messages sliced from packed ``data``."""
        return [
            (topic, action_stamp_ns if is_action else stamp_ns, data[start:end])
            for topic, start, end, is_action in self._payloads
        ]


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

        def plan(stepped: bool) -> _Plan:
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
        self._packers: dict[tuple[Framing, bool], FramePacker] = {}

    def packer(self, framing: Framing, stepped: bool) -> FramePacker:
        """The packer of frames after a ``step`` (or a ``reset``) for ``framing`` (cached)."""
        key = (framing, stepped)
        if key not in self._packers:
            self._packers[key] = FramePacker(self._plans[stepped], framing)
        return self._packers[key]

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


_Route = tuple[BagSink, Framing | None]


class MessageFanout:
    """Frames in, serialised records out to every sink; each message serialised once per distro."""

    def __init__(self, specs: EnvSpecs, topics: Topics) -> None:
        self.specs = specs
        self.topics = topics
        self._serializers: dict[str, FrameSerializer] = {}
        self._sinks: dict[str, list[BagSink]] = {}
        self._routes: dict[str, list[_Route]] = {}  # per distro: packing sinks first

    def serializer(self, distro: str) -> FrameSerializer:
        """The serializer of ``distro`` (made on first use)."""
        if distro not in self._serializers:
            self._serializers[distro] = FrameSerializer(self.specs, distro, self.topics)
        return self._serializers[distro]

    def add_sink(self, sink: BagSink) -> None:
        """Start sending to ``sink``, declaring every topic in it."""
        serializer = self.serializer(sink.distro)
        for name, msgtype, latched in serializer.topics():
            sink.add_topic(name, msgtype, latched)
        framing = sink.framing()
        if framing is not None:  # compile now: errors before the first frame
            serializer.packer(framing, False)
            serializer.packer(framing, True)
        self._sinks.setdefault(sink.distro, []).append(sink)
        self._update_routes(sink.distro)

    def remove_sink(self, sink: BagSink) -> None:
        """Stop sending to ``sink`` (it is not closed)."""
        self._sinks[sink.distro].remove(sink)
        if not self._sinks[sink.distro]:
            del self._sinks[sink.distro]
        self._update_routes(sink.distro)

    def _update_routes(self, distro: str) -> None:
        routes = [(sink, sink.framing()) for sink in self._sinks.get(distro, [])]
        if routes:
            self._routes[distro] = sorted(routes, key=lambda route: route[1] is None)
        else:
            self._routes.pop(distro, None)

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
        if not self._routes:
            return
        first = self._serializers[next(iter(self._routes))]
        values = first.converter.frame_values(
            obs, info, stamp_ns, seq, action, reward, terminated, truncated
        )
        stepped = action is not None
        action_stamp = stamp_ns if action_stamp_ns is None else action_stamp_ns
        for distro, routes in self._routes.items():
            self._send(distro, routes, values, stamp_ns, action_stamp, stepped)

    def _send(
        self,
        distro: str,
        routes: Sequence[_Route],
        values: dict[str, Any],
        stamp_ns: int,
        action_stamp: int,
        stepped: bool,
    ) -> None:
        serializer = self._serializers[distro]
        packed: dict[Framing, bytes] = {}
        records: list[Record] | None = None
        for sink, framing in routes:
            if framing is not None:
                packer = serializer.packer(framing, stepped)
                data = packed.get(framing)
                if data is None:
                    data = packed[framing] = packer.pack(values, stamp_ns, action_stamp)
                sink.write_packed(data, packer.layout, stamp_ns, action_stamp)
            else:
                if records is None:
                    if packed:  # slice the messages out of a packed frame: serialised once
                        framing, data = next(iter(packed.items()))
                        records = serializer.packer(framing, stepped).records(
                            data, stamp_ns, action_stamp
                        )
                    else:
                        records = serializer.frame(values, stamp_ns, action_stamp, stepped)
                sink.write_batch(records)

    def write_records(self, make: Any) -> None:
        """Send records made per distro by ``make(serializer) -> list[Record]``."""
        for distro, sinks in self._sinks.items():
            records = make(self._serializers[distro])
            if records:
                for sink in sinks:
                    sink.write_batch(records)
