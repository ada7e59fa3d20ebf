"""Fast serialisation of fixed-shape messages: one ``struct`` call per message.

``rosbags`` serialises any message, generically; per message that costs microseconds, too much to
record at thousands of steps per second. The messages a recording writes have the same shape every
step (same frame ids, same array lengths), only their numbers change. :func:`compile_message`
walks a *template* message, built by the same code that builds real messages but with
:class:`Slot` placeholders where the values go, following the type store's field definitions, and
compiles it into one ``struct.Struct``. :meth:`CompiledMessage.encode` then fills the slots.

The bytes are those ``rosbags`` would produce (``serialize_cdr`` little-endian or
``serialize_ros1``); ``tests/ros/test_encode.py`` checks every recorded topic of every distro.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from rosbags.interfaces import Nodetype
from rosbags.typesys.store import Typestore

__all__ = [
    "CDR_HEADER",
    "PAD",
    "CompiledMessage",
    "Item",
    "Slot",
    "compile_items",
    "compile_message",
]

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


@dataclass(frozen=True)
class Slot:
    """A placeholder for a value filled in at encode time.

    A scalar slot stands for one number; a slot with ``count`` stands for a fixed-length array or a
    sequence of ``count`` elements, and is filled with their little-endian bytes.
    """

    name: str
    count: int | None = None


Item = tuple[str, Any]
"""One ``struct`` code and its value: a constant, a :class:`Slot`, or :data:`PAD` for padding."""

PAD = object()
"""The value of a padding item (``"3x"``): it takes no argument."""


class CompiledMessage:
    """A message type (or a whole frame of records) with fixed shape, compiled for one encoding.

    Runs of constants (frame ids, sensor geometry, lengths, padding) are packed once, when
    compiling, into one byte string each; each call packs only the slots between them.
    """

    def __init__(
        self,
        layout: struct.Struct,
        template: list[Any],
        slots: list[tuple[int, str]],
        items: tuple[Item, ...] = (),
    ) -> None:
        self.size = layout.size
        self.items = items
        """The unfolded items (``compile_message``/``compile_items`` keep them for framing)."""
        self.slot_names = tuple(name for _, name in slots)
        for name in self.slot_names:
            if not name.isidentifier():
                raise ValueError(f"slot names must be identifiers, got {name!r}")
        self._layout = layout
        self._template = template
        self._slots = dict(slots)
        self._encode = self._generate("v", {name: f'v["{name}"]' for name in self.slot_names})

    def _generate(self, params: str, sources: Mapping[str, str], prelude: str = "") -> Any:
        """One generated call: ``pack(c0, <source of slot 1>, c2, ...)``, constants as defaults.

        The code holds only argument names, slot names (checked to be identifiers) and indexes,
        no values.
        """
        by_index, template = self._slots, self._template
        args = [sources[by_index[i]] if i in by_index else f"c{i}" for i in range(len(template))]
        consts = [f"c{i}=c{i}" for i in range(len(template)) if i not in by_index]
        source = f"def encode({', '.join([params, 'pack=pack', 'divmod=divmod', *consts])}):\n"
        source += prelude + f"    return pack({', '.join(args)})\n"
        namespace: dict[str, Any] = {"pack": self._layout.pack, "divmod": divmod}
        namespace.update({f"c{i}": value for i, value in enumerate(template) if i not in by_index})
        exec(source, namespace)  # noqa: S102 - generated from the names above only
        return namespace["encode"]

    def tuple_encoder(
        self, names: Sequence[str], stamps: Sequence[str] = ()
    ) -> Callable[..., bytes]:
        """A function ``encode(values, *stamps)`` that takes the slot values as a tuple.

        Args:
            names: The slot name of each position of ``values`` (unused positions are allowed).
            stamps: Names of further arguments, nanosecond stamps ending in ``_ns``: a slot named
                after one is filled with it, and slots ``<stem>_sec`` and ``<stem>_nsec`` with its
                seconds and nanoseconds (ROS 1 record headers).

        Raises:
            ValueError: A slot has no source among ``names`` and ``stamps``.
        """
        sources = {name: f"a[{i}]" for i, name in enumerate(names) if name.isidentifier()}
        prelude = ""
        for stamp in stamps:
            if not stamp.isidentifier() or not stamp.endswith("_ns"):
                raise ValueError(f"stamp arguments are identifiers ending in _ns, got {stamp!r}")
            stem = stamp[: -len("_ns")]
            sources[stamp] = stamp
            if f"{stem}_sec" in self.slot_names or f"{stem}_nsec" in self.slot_names:
                sources[f"{stem}_sec"], sources[f"{stem}_nsec"] = f"{stem}_sec", f"{stem}_nsec"
                prelude += f"    {stem}_sec, {stem}_nsec = divmod({stamp}, 1000000000)\n"
        missing = sorted(set(self.slot_names) - set(sources))
        if missing:
            raise ValueError(f"slots {missing} are neither among the values nor the stamps")
        return self._generate(", ".join(["a", *stamps]), sources, prelude)  # type: ignore[no-any-return]

    def encode(self, values: Mapping[str, Any]) -> bytes:
        """Serialised message with every slot taken from ``values`` (by slot name)."""
        return self._encode(values)  # type: ignore[no-any-return]


def compile_items(items: Sequence[Item]) -> CompiledMessage:
    """Compile little-endian ``items`` (constants folded into byte strings) into one call."""
    fmt = ["<"]
    args: list[Any] = []
    slots: list[tuple[int, str]] = []
    codes: list[str] = []
    constants: list[Any] = []

    def fold() -> None:
        if codes:
            data = struct.pack("<" + "".join(codes), *constants)
            fmt.append(f"{len(data)}s")
            args.append(data)
            codes.clear()
            constants.clear()

    for code, value in items:
        if isinstance(value, Slot):
            fold()
            slots.append((len(args), value.name))
            fmt.append(code)
            args.append(None)
        else:
            codes.append(code)
            if value is not PAD:
                constants.append(value)
    fold()
    return CompiledMessage(struct.Struct("".join(fmt)), args, slots, tuple(items))


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


def compile_message(
    store: Typestore, msgtype: str, template: Any, encoding: str
) -> CompiledMessage:
    """Compile ``template`` (a ``store`` message object with :class:`Slot` values) for ``encoding``.

    Args:
        store: Type store whose field definitions describe ``msgtype``.
        msgtype: Message type name, e.g. ``"sensor_msgs/msg/LaserScan"``.
        template: A message of that type; strings and array lengths must be constant.
        encoding: ``"cdr"`` (little-endian ROS 2) or ``"ros1"``.

    Returns:
        The compiled message.
    """
    if encoding not in ("cdr", "ros1"):
        raise ValueError(f"encoding must be 'cdr' or 'ros1', got {encoding!r}")
    compiler = _Compiler(store, cdr=encoding == "cdr")
    if compiler.cdr:
        compiler.items.append(("4s", CDR_HEADER))
    compiler.message(msgtype, template)
    return compile_items(compiler.items)
