"""Env frames -> serialised records, for one distro and topic set.

:class:`FrameSerializer` knows which messages a frame has and their ``struct`` items (from
templates, see :mod:`~bubblerob_env.ros.fastpath.encode`). For a sink's
:class:`~bubblerob_env.ros.fastpath.framing.Framing` it gives a :class:`FramePacker`: the frame's
records, each behind its header, as one :class:`~bubblerob_env.ros.fastpath.packer.Packer`
(``pack_one`` per frame, ``pack_many`` per batch). Sinks that take records rather than packed
frames (a live publisher, replay) get them sliced from a frame packed without headers (``raw``):
every recorded message goes through the same packer.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from bubblerob_env.ros.fastpath.detections import DetectionPacker
from bubblerob_env.ros.fastpath.encode import Item, items_size, message_items
from bubblerob_env.ros.fastpath.framing import FrameLayout, Framing, Record
from bubblerob_env.ros.fastpath.packer import Packer
from bubblerob_env.ros.messages.convert import MAP_SLOTS, RosConverter
from bubblerob_env.ros.messages.detections import Recognised
from bubblerob_env.ros.messages.distros import serialize
from bubblerob_env.ros.messages.topics import LATCHED_TOPICS, MSGTYPES, Topics
from bubblerob_env.ros.messages.values import Slot, split_stamp
from bubblerob_env.specs import EnvSpecs

if TYPE_CHECKING:
    from bubblerob_env.mapping import Grid
    from bubblerob_env.tasks.goals import NavProblem

__all__ = ["FramePacker", "FrameSerializer"]

_Plan = list[tuple[str, tuple[Item, ...], bool]]  # (topic, message items, logged at the action)


class FramePacker:
    """One frame's records, each behind its header, packed by one ``Packer``.

    The headers are those of a :class:`~bubblerob_env.ros.fastpath.framing.Framing`; the packer
    is a :class:`~bubblerob_env.ros.fastpath.packer.Packer`.

    :attr:`layout` tells a writer where each record starts, so that it can index them when the
    chunk closes.
    """

    def __init__(self, plan: _Plan, framing: Framing, names: Sequence[str]) -> None:
        items: list[Item] = []
        channels, offsets, action = [], [], []
        self._payloads: list[tuple[str, int, int, bool]] = []
        ids = dict(framing.ids)
        pos = 0
        for topic, message, is_action in plan:
            size = items_size(message)
            header = framing.header(topic, size, is_action)
            head = items_size(header)
            channels.append(ids[topic])
            offsets.append(pos)
            action.append(is_action)
            self._payloads.append((topic, pos + head, pos + head + size, is_action))
            items += header
            items += message
            pos += head + size
        self.packer = Packer(items, names)
        self.pack_one = self.packer.pack_one
        """``pack_one(frame_args, stamp_ns, action_stamp_ns)``: the frame's bytes."""
        self.layout = FrameLayout(tuple(channels), tuple(offsets), tuple(action), pos)

    def pack_many(self, columns: Mapping[str, NDArray[Any]], count: int) -> NDArray[np.uint8]:
        """``count`` frames from :meth:`~bubblerob_env.ros.fastpath.batch.FrameBatch.columns`."""
        return self.packer.pack_many(columns, count)

    def records(self, data: bytes, stamp_ns: int, action_stamp_ns: int) -> list[Record]:
        """The frame's records, their messages sliced from packed ``data``."""
        return [
            (topic, action_stamp_ns if is_action else stamp_ns, data[start:end])
            for topic, start, end, is_action in self._payloads
        ]


class FrameSerializer:
    """Serialised messages of frames, for one distro and topic set."""

    def __init__(self, specs: EnvSpecs, distro: str, topics: Topics) -> None:
        self.converter = RosConverter(specs, distro, topics.frame_prefix)
        self.names = topics.resolved()
        self.distro = self.converter.distro
        slots = self.converter.slots()
        action_keys = set(self.converter.action_keys())
        messages = {
            key: message_items(
                self.converter.store,
                MSGTYPES[key],
                self.converter.message(key, slots),
                self.distro.encoding,
            )
            for key in self.converter.frame_keys(True)
            if key in self.names
        }
        self._plans = {
            stepped: [
                (self.names[key], messages[key], key in action_keys)
                for key in self.converter.frame_keys(stepped)
                if key in self.names
            ]
            for stepped in (False, True)
        }
        self.detects = specs.camera is not None and "detections" in self.names
        """Whether frames have ``/detections`` (the camera is on and the topic not left out)."""
        self._detections = DetectionPacker(self.converter) if self.detects else None
        self._raw = Framing("raw", tuple((name, i) for i, name in enumerate(self.names.values())))
        self._packers: dict[tuple[Framing, bool], FramePacker] = {}
        self._map_packers: dict[tuple[Any, ...], Packer] = {}

    def packer(self, framing: Framing | None, stepped: bool) -> FramePacker:
        """The packer of frames after a ``step`` (or a ``reset``) for ``framing`` (cached).

        ``None``: no headers, for slicing records (:meth:`FramePacker.records`).
        """
        key = (framing or self._raw, stepped)
        if key not in self._packers:
            names = self.converter.value_names(stepped)
            self._packers[key] = FramePacker(self._plans[stepped], key[0], names)
        return self._packers[key]

    def topics(self) -> list[tuple[str, str, bool]]:
        """``(name, msgtype, latched)`` of every topic a bag of these frames holds."""
        keys = [*self.converter.frame_keys(True), *LATCHED_TOPICS]
        keys += ["detections"] if self.detects else []
        return [(self.names[k], MSGTYPES[k], k in LATCHED_TOPICS) for k in keys if k in self.names]

    def frame(
        self, args: tuple[Any, ...], stamp_ns: int, action_stamp_ns: int, stepped: bool
    ) -> list[Record]:
        """Records of one frame (``args``: its ``frame_args``), sliced from one packed frame.

        The action's topics are logged at ``action_stamp_ns``.
        """
        packer = self.packer(None, stepped)
        data = packer.pack_one(args, stamp_ns, action_stamp_ns)
        return packer.records(data, stamp_ns, action_stamp_ns)

    def detections(self, found: Sequence[Recognised], stamp_ns: int, seq: int) -> list[Record]:
        """The ``/detections`` record of objects ``found`` in the image of frame ``seq``.

        None when the frames have no detections (:attr:`detects`).
        """
        if self._detections is None:
            return []
        data = self._detections.pack(found, stamp_ns, seq)
        return [(self.names["detections"], stamp_ns, data)]

    def tf_static(self, stamp_ns: int) -> list[Record]:
        """The ``/tf_static`` record (none if that topic is left out)."""
        if "tf_static" not in self.names:
            return []
        message = self.converter.tf_static(stamp_ns)
        data = serialize(self.distro.name, message, MSGTYPES["tf_static"])
        return [(self.names["tf_static"], stamp_ns, data)]

    def map(self, grid: Grid, stamp_ns: int) -> list[Record]:
        """The ``/map`` record of ``grid`` (none if that topic is left out).

        Packed by a :class:`~bubblerob_env.ros.fastpath.packer.Packer` compiled from the
        message's template, like every frame (one per grid shape, origin and resolution).
        """
        if "map" not in self.names:
            return []
        shape = (int(grid.data.shape[0]), int(grid.data.shape[1]))
        key = (shape, grid.origin, grid.resolution)
        packer = self._map_packers.get(key)
        if packer is None:
            slots = {name: Slot(name) for name in MAP_SLOTS}
            slots["cells"] = Slot("cells", shape[0] * shape[1])
            template = self.converter.occupancy_grid(slots, shape, grid.origin, grid.resolution)
            items = message_items(
                self.converter.store, MSGTYPES["map"], template, self.distro.encoding
            )
            packer = self._map_packers[key] = Packer(items, MAP_SLOTS)
        sec, nanosec = split_stamp(stamp_ns)
        cells = np.ascontiguousarray(grid.data, dtype=np.int8).tobytes()
        data = packer.pack_one((sec, nanosec, 0, cells), stamp_ns, stamp_ns)
        return [(self.names["map"], stamp_ns, data)]

    def goal(self, problem: NavProblem, stamp_ns: int) -> list[Record]:
        """A Nav env's goal and path records (those of its topics not left out)."""
        records = []
        if "goal" in self.names:
            message = self.converter.goal(stamp_ns, problem.goal)
            data = serialize(self.distro.name, message, MSGTYPES["goal"])
            records.append((self.names["goal"], stamp_ns, data))
        if "plan" in self.names:
            message = self.converter.plan(stamp_ns, problem.path.tolist())
            data = serialize(self.distro.name, message, MSGTYPES["plan"])
            records.append((self.names["plan"], stamp_ns, data))
        return records

    def episode(self, metadata: Mapping[str, Any], stamp_ns: int) -> Record:
        """The episode metadata record (``std_msgs/String`` holding JSON)."""
        message = self.converter.episode(metadata)
        data = serialize(self.distro.name, message, MSGTYPES["episode"])
        return (self.names["episode"], stamp_ns, data)
