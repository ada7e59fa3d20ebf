"""Message templates -> ``struct`` items: what a fixed-shape message looks like on the wire.

``rosbags`` serialises any message, generically; per message that costs microseconds, too much to
record at thousands of steps per second. The messages a recording writes have the same shape every
step (same frame ids, same array lengths), only their numbers change. :func:`message_items` walks a
*template* message, built by the same code that builds real messages but with :class:`Slot`
placeholders where the values go, following the type store's field definitions, and lists its
``struct`` items: constants, padding and slots. :mod:`~bubblerob_env.ros.fastpath.packer` compiles
a frame's items (record headers and messages) into its one packer.

The bytes are those ``rosbags`` would produce (``serialize_cdr`` little-endian or
``serialize_ros1``); ``tests/ros/test_encode.py`` checks every recorded topic of every distro.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from typing import Any

import numpy as np
from rosbags.interfaces import Nodetype
from rosbags.typesys.store import Typestore

from bubblerob_env.ros.messages.values import Slot

__all__ = ["CDR_HEADER", "PAD", "Item", "Slot", "items_size", "message_items"]

CDR_HEADER = b"\x00\x01\x00\x00"
"""Encapsulation header of a little-endian CDR message."""

_CODES = {
    "bool": "?",
    "byte": "B",
    "char": "B",
    "int8": "b",
    "uint8": "B",
    "int16": "h",
    "uint16": "H",
    "int32": "i",
    "uint32": "I",
    "int64": "q",
    "uint64": "Q",
    "float32": "f",
    "float64": "d",
}


Item = tuple[str, Any]
"""One ``struct`` code and its value: a constant, a :class:`Slot`, or :data:`PAD` for padding."""

PAD = object()
"""The value of a padding item (``"3x"``): it takes no argument."""


class _Compiler:
    def __init__(self, store: Typestore, cdr: bool) -> None:
        self.store = store
        self.cdr = cdr
        self.items: list[Item] = []
        self.pos = 0  # offset in the payload (after the CDR encapsulation header)

    def align(self, size: int) -> None:
        if self.cdr and self.pos % size:
            pad = size - self.pos % size
            self.items.append((f"{pad}x", PAD))
            self.pos += pad

    def put(self, code: str, value: Any) -> None:
        size = struct.calcsize("<" + code)
        self.align(size)
        self.items.append((code, value))
        self.pos += size

    def blob(self, value: Any, elem: str, count: int) -> None:
        """``count`` elements of base type ``elem`` as raw bytes (a slot or constant values)."""
        size = struct.calcsize("<" + _CODES[elem]) * count
        if count:
            self.align(struct.calcsize("<" + _CODES[elem]))
        self.pos += size
        if not isinstance(value, Slot):
            value = np.asarray(value, dtype="<" + _CODES[elem]).tobytes()
        self.items.append((f"{size}s", value))

    def string(self, value: Any) -> None:
        if not isinstance(value, str):
            raise TypeError(f"strings must be constants in a template, got {value!r}")
        data = value.encode()
        if self.cdr:
            data += b"\0"
        self.put("I", len(data))
        self.items.append((f"{len(data)}s", data))
        self.pos += len(data)

    def message(self, msgtype: str, obj: Any) -> None:
        _, fields = self.store.fielddefs[msgtype]
        for name, desc in fields:
            self.field(desc, getattr(obj, name))

    def field(self, desc: Any, value: Any) -> None:
        kind = desc[0]
        if kind == Nodetype.NAME:
            self.message(desc[1], value)
        elif kind == Nodetype.BASE:
            base = desc[1][0]
            if base == "string":
                self.string(value)
            else:
                self.put(_CODES[base], value)
        elif kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
            sub, length = desc[1]
            count = value.count if isinstance(value, Slot) else len(value)
            if count is None:
                raise ValueError(f"slot {value.name!r} stands for an array: give its count")
            if kind == Nodetype.ARRAY and count != length:
                raise ValueError(f"array needs {length} elements, template has {count}")
            if kind == Nodetype.SEQUENCE:
                self.put("I", count)
            if sub[0] == Nodetype.BASE and sub[1][0] != "string":
                self.blob(value, sub[1][0], count)
            elif isinstance(value, Slot):
                raise TypeError(f"slot {value.name!r}: only arrays of numbers can be slots")
            else:
                for item in value:
                    self.field(sub, item)
        else:  # pragma: no cover - rosbags has no other node types
            raise TypeError(f"unsupported field description {desc!r}")


def items_size(items: Sequence[Item]) -> int:
    """Bytes that ``items`` pack into."""
    return struct.calcsize("<" + "".join(code for code, _ in items))


def message_items(store: Typestore, msgtype: str, template: Any, encoding: str) -> tuple[Item, ...]:
    """The ``struct`` items of ``template`` (a ``store`` message with :class:`Slot` values).

    Args:
        store: Type store whose field definitions describe ``msgtype``.
        msgtype: Message type name, e.g. ``"sensor_msgs/msg/LaserScan"``.
        template: A message of that type; strings and array lengths must be constant.
        encoding: ``"cdr"`` (little-endian ROS 2) or ``"ros1"``.

    Returns:
        The message's items, little-endian, padding included (CDR: the encapsulation header first).
    """
    if encoding not in ("cdr", "ros1"):
        raise ValueError(f"encoding must be 'cdr' or 'ros1', got {encoding!r}")
    compiler = _Compiler(store, cdr=encoding == "cdr")
    if compiler.cdr:
        compiler.items.append(("4s", CDR_HEADER))
    compiler.message(msgtype, template)
    return tuple(compiler.items)
