"""The one packer: ``struct`` items -> bytes, one frame at a time or many at once.

A :class:`Packer` is made from the items of a whole frame (record headers and messages, see
:mod:`~bubblerob_env.ros.fastpath.encode` and :mod:`~bubblerob_env.ros.fastpath.framing`). Both
of its ways of packing are generated from those items, so they give the same bytes:

- :meth:`Packer.pack_one`: one frame from the tuple of field values of
  :meth:`~bubblerob_env.ros.messages.values.FrameValues.frame_args`, by one generated
  ``struct`` call (runs of constants folded into byte strings);
- :meth:`Packer.pack_many`: ``n`` frames from the columns of
  :meth:`~bubblerob_env.ros.fastpath.batch.FrameBatch.columns`, laid out at once by a structured
  ``numpy`` dtype of the frame (constants and padding in a template row, each slot a field).
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bubblerob_env.ros.fastpath.encode import PAD, Item, Slot

__all__ = ["STAMPS", "Packer"]

STAMPS = ("log_ns", "action_log_ns")
"""The stamps :meth:`Packer.pack_one` takes after the values: a slot named after one is filled
with it, and slots ``<stem>_sec``/``<stem>_nsec`` with its seconds and nanoseconds."""


class Packer:
    """Packs frames laid out as ``items`` (see the module docstring).

    Args:
        items: Little-endian ``struct`` items: constants, padding and slots.
        names: The slot name of each position of the value tuples :meth:`pack_one` takes (unused
            positions are allowed).

    Raises:
        ValueError: A slot is neither among ``names`` nor a stamp of :data:`STAMPS`.
    """

    def __init__(self, items: Sequence[Item], names: Sequence[str]) -> None:
        self.items = tuple(items)
        fmt, template, slots = _fold(self.items)
        layout = struct.Struct(fmt)
        self.size = layout.size
        self.slot_names = tuple(sorted({name for _, name in slots}))
        for name in self.slot_names:
            if not name.isidentifier():
                raise ValueError(f"slot names must be identifiers, got {name!r}")
        self.pack_one: Callable[[tuple[Any, ...], int, int], bytes] = _generate(
            layout, template, slots, names
        )
        """``pack_one(values, log_ns, action_log_ns)``: one frame's bytes."""
        self._many: _BatchLayout | None = None  # made on first use: /detections never need it

    def pack_many(self, columns: Mapping[str, NDArray[Any]], count: int) -> NDArray[np.uint8]:
        """``count`` frames, one after the other, as a flat ``uint8`` array.

        ``columns`` holds every slot's values by slot name, one row per frame: scalars as 1-D
        arrays, array slots as 2-D arrays of their serialised element type. The array is a view
        of a buffer the next call packs into again: write (or copy) it before that.
        """
        if self._many is None:
            self._many = _BatchLayout(self.items, self.size)
        return self._many.pack(columns, count)


def _fold(items: Sequence[Item]) -> tuple[str, list[Any], list[tuple[int, str]]]:
    """``struct`` format, argument template and ``(argument index, slot name)`` of ``items``.

    Runs of constants (frame ids, sensor geometry, lengths, padding) are packed now, into one byte
    string each; each frame packs only the slots between them.
    """
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
    return "".join(fmt), args, slots


def _generate(
    layout: struct.Struct, template: list[Any], slots: list[tuple[int, str]], names: Sequence[str]
) -> Any:
    """``pack(c0, <source of slot 1>, c2, ...)`` as a function of the values and the stamps.

    The generated code holds only argument names, slot names (checked to be identifiers) and
    indexes, no values; constants are default arguments.
    """
    sources = {name: f"a[{i}]" for i, name in enumerate(names) if name.isidentifier()}
    slot_names = {name for _, name in slots}
    prelude = ""
    for stamp in STAMPS:
        stem = stamp[: -len("_ns")]
        sources[stamp] = stamp
        if f"{stem}_sec" in slot_names or f"{stem}_nsec" in slot_names:
            sources[f"{stem}_sec"], sources[f"{stem}_nsec"] = f"{stem}_sec", f"{stem}_nsec"
            prelude += f"    {stem}_sec, {stem}_nsec = divmod({stamp}, 1000000000)\n"
    missing = sorted(slot_names - set(sources))
    if missing:
        raise ValueError(f"slots {missing} are neither among the values nor the stamps")
    by_index = dict(slots)
    args = [sources[by_index[i]] if i in by_index else f"c{i}" for i in range(len(template))]
    consts = [f"c{i}=c{i}" for i in range(len(template)) if i not in by_index]
    params = ", ".join(["a", *STAMPS, "pack=pack", "divmod=divmod", *consts])
    source = f"def pack_one({params}):\n{prelude}    return pack({', '.join(args)})\n"
    namespace: dict[str, Any] = {"pack": layout.pack, "divmod": divmod}
    namespace.update({f"c{i}": value for i, value in enumerate(template) if i not in by_index})
    exec(source, namespace)  # noqa: S102 - generated from the names above only
    return namespace["pack_one"]


class _BatchLayout:
    """A structured ``numpy`` dtype of one frame: constants in a template row, slots as fields."""

    def __init__(self, items: Sequence[Item], size: int) -> None:
        template = bytearray()
        names: list[str] = []
        formats: list[Any] = []
        offsets: list[int] = []
        self._fields: list[tuple[str, str, bool]] = []  # (field, slot, raw bytes)
        for code, value in items:
            width = struct.calcsize("<" + code)
            if isinstance(value, Slot):
                field = f"f{len(names)}"
                blob = code.endswith("s")
                names.append(field)
                formats.append(("u1", (width,)) if blob else np.dtype("<" + code))
                offsets.append(len(template))
                self._fields.append((field, value.name, blob))
                template += bytes(width)
            elif value is PAD:
                template += bytes(width)
            else:
                template += struct.pack("<" + code, value)
        if len(template) != size:  # pragma: no cover - both come from the same items
            raise ValueError(f"items pack {len(template)} bytes, the frame has {size}")
        self._dtype = np.dtype(
            {"names": names, "formats": formats, "offsets": offsets, "itemsize": size}
        )
        self._template = np.frombuffer(bytes(template), dtype=np.uint8)
        self._size = size
        # Frames with the constants in place, reused: each pack writes every slot of its rows.
        self._buffer = np.zeros(0, dtype=np.uint8)

    def pack(self, columns: Mapping[str, NDArray[Any]], count: int) -> NDArray[np.uint8]:
        if self._buffer.size < count * self._size:  # grows to the largest batch so far
            self._buffer = np.tile(self._template, count)
        data = self._buffer[: count * self._size]
        frames = data.view(self._dtype)
        for field, slot, blob in self._fields:
            column = columns[slot]
            if blob:  # serialised elements: their little-endian bytes
                frames[field] = np.ascontiguousarray(column).view(np.uint8).reshape(count, -1)
            else:
                frames[field] = column
        return data
