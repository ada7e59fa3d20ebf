"""``/detections`` packed by the one packer: a compiled ``Packer`` per detections' shape.

A ``Detection2DArray`` has as many detections as the recogniser found, and each carries its class
as a string: its layout (and, in CDR, its padding) changes with the classes it lists, in order.
Its numbers do not change the layout, so, as ``/map`` has a packer per grid shape, each sequence
of classes gets a :class:`~bubblerob_env.ros.fastpath.packer.Packer` compiled from the message's
template (:meth:`~bubblerob_env.ros.messages.convert.RosConverter.detections` with
:class:`~bubblerob_env.ros.messages.values.Slot` numbers), cached: a frame whose classes were
seen before costs one ``struct`` call. The bytes are those ``rosbags`` serialises
(``tests/ros/test_detections.py`` checks every distro).
"""

from __future__ import annotations

from collections.abc import Sequence

from bubblerob_env.ros.fastpath.encode import message_items
from bubblerob_env.ros.fastpath.packer import Packer
from bubblerob_env.ros.messages.convert import RosConverter
from bubblerob_env.ros.messages.detections import (
    Recognised,
    detection_numbers,
    detection_slots,
)
from bubblerob_env.ros.messages.topics import MSGTYPES
from bubblerob_env.ros.messages.values import Slot, split_stamp

__all__ = ["MAX_SHAPES", "DetectionPacker"]

MAX_SHAPES = 512
"""Packers kept at most (the cache starts again beyond): a frame shows a few objects, and the
sequences of their classes that occur are far fewer than this."""
_HEADER = ("sec", "nanosec", "seq")


class DetectionPacker:
    """Packs ``/detections`` messages for the distro of ``converter``."""

    def __init__(self, converter: RosConverter) -> None:
        if converter.specs.camera is None:
            raise ValueError("detections need the env's camera")
        self.converter = converter
        self._packers: dict[tuple[str, ...], Packer] = {}

    def _packer(self, classes: tuple[str, ...]) -> Packer:
        packer = self._packers.get(classes)
        if packer is None:
            if len(self._packers) >= MAX_SHAPES:
                self._packers.clear()
            slots = detection_slots(len(classes))
            header = {name: Slot(name) for name in _HEADER}
            template = self.converter.detections(header, classes, slots)
            converter = self.converter
            items = message_items(
                converter.store, MSGTYPES["detections"], template, converter.distro.encoding
            )
            names = [*_HEADER]
            names += [slot.name for numbers in slots for slot in numbers.values()]
            packer = self._packers[classes] = Packer(items, names)
        return packer

    def pack(self, found: Sequence[Recognised], stamp_ns: int, seq: int) -> bytes:
        """The message of objects ``found`` in the image stamped ``stamp_ns``, number ``seq``."""
        classes = tuple(each.kind for each in found)
        sec, nanosec = split_stamp(stamp_ns)
        values: tuple[float | int, ...] = (sec, nanosec, seq & 0xFFFFFFFF)
        for each in found:
            values += detection_numbers(each)
        return self._packer(classes).pack_one(values, stamp_ns, stamp_ns)
