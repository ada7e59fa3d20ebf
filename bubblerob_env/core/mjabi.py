"""MuJoCo's C API and ``mjData`` memory, reachable from numba without a compiler.

The mujoco wheel ships ``libmujoco``; loading it into LLVM's symbol table lets numba code call
``mj_step1``, ``mj_step2`` and ``mj_multiRay`` by name (the cache stores the name, not an
address, so ``cache=True`` works across processes). Arrays of ``mjData`` that the Python
bindings expose as numpy views never move, so their addresses are read once per robot. Three
scalars that the bindings expose only as Python numbers (``ncon``, ``time`` and the ``contact``
pointer) are read at offsets computed from ``mujoco.introspect``'s field list; the supported
mujoco range is pinned in pyproject.toml and ``tests/test_core_abi.py`` checks every offset
against the bindings, so a release that moves them fails a test, not a user's run.

MuJoCo's profiling clock, the global ``mjcb_time`` callback, is read and set by name too
(:func:`timer_callback`, :func:`set_timer_callback`): the kernel turns it off around its own
steps (see :func:`~bubblerob_env.core.kernel.step_robots`).
"""

from __future__ import annotations

import functools
import os
from dataclasses import dataclass
from typing import Any

import llvmlite.binding as llvm
import mujoco
from llvmlite import ir
from mujoco.introspect import structs
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

__all__ = [
    "MJ_MULTIRAY",
    "MJ_STEP1",
    "MJ_STEP2",
    "DataLayout",
    "as_pointer",
    "data_layout",
    "disableflags_address",
    "load_mujoco_library",
    "set_timer_callback",
    "timer_callback",
]


def load_mujoco_library() -> str:
    """Make libmujoco's symbols visible to numba-compiled code; returns the library's path."""
    folder = os.path.dirname(mujoco.__file__)
    names = sorted(n for n in os.listdir(folder) if n.startswith("libmujoco.so"))
    if not names:  # macOS and Windows wheels name it differently
        names = sorted(n for n in os.listdir(folder) if n.startswith(("libmujoco", "mujoco.dll")))
    if not names:
        raise ImportError(f"no libmujoco shared library in {folder}")
    path = os.path.join(folder, names[-1])
    llvm.load_library_permanently(path)
    return str(path)


load_mujoco_library()

MJ_STEP1 = types.ExternalFunction("mj_step1", types.void(types.voidptr, types.voidptr))
MJ_STEP2 = types.ExternalFunction("mj_step2", types.void(types.voidptr, types.voidptr))
MJ_MULTIRAY = types.ExternalFunction(
    "mj_multiRay",
    types.void(
        types.voidptr,  # const mjModel* m
        types.voidptr,  # mjData* d
        types.voidptr,  # const mjtNum pnt[3]
        types.voidptr,  # const mjtNum* vec
        types.voidptr,  # const mjtByte* geomgroup
        types.uint8,  # mjtBool flg_static
        types.int32,  # int bodyexclude
        types.voidptr,  # int* geomid
        types.voidptr,  # mjtNum* dist
        types.voidptr,  # mjtNum* normal (NULL)
        types.int32,  # int nray
        types.float64,  # mjtNum cutoff
    ),
)


def _as_pointer(typingctx: Any, address: Any) -> tuple[Any, Any]:
    signature = types.voidptr(address)

    def codegen(context: Any, builder: Any, sig: Any, args: Any) -> Any:
        return builder.inttoptr(args[0], cgutils.voidptr_t)

    return signature, codegen


as_pointer: Any = intrinsic(_as_pointer)
"""Numba only: an integer address as a ``void*`` (for ``numba.carray`` and C calls)."""

_TIMER = "mjcb_time"


def _timer_variable(builder: Any) -> Any:
    """The ``mjcb_time`` of libmujoco (a function pointer), declared in the module being built.

    An external declaration: resolved by name when the code is loaded, like ``mj_step1``.
    """
    variable = builder.module.globals.get(_TIMER)
    if variable is None:
        variable = ir.GlobalVariable(builder.module, cgutils.voidptr_t, _TIMER)
        variable.linkage = "external"
    return variable


def _timer_callback(typingctx: Any) -> tuple[Any, Any]:
    def codegen(context: Any, builder: Any, sig: Any, args: Any) -> Any:
        return builder.ptrtoint(builder.load(_timer_variable(builder)), ir.IntType(64))

    return types.uint64(), codegen


def _set_timer_callback(typingctx: Any, value: Any) -> tuple[Any, Any]:
    def codegen(context: Any, builder: Any, sig: Any, args: Any) -> Any:
        builder.store(builder.inttoptr(args[0], cgutils.voidptr_t), _timer_variable(builder))
        return context.get_dummy_value()

    return types.void(value), codegen


timer_callback: Any = intrinsic(_timer_callback)
"""Numba only: MuJoCo's ``mjcb_time`` as an address (0: none, MuJoCo's timers are off)."""
set_timer_callback: Any = intrinsic(_set_timer_callback)
"""Numba only: set MuJoCo's ``mjcb_time`` to an address (0 turns its timers off)."""


_SCALAR_SIZES = {
    "int": 4,
    "mjtBool": 1,
    "mjtByte": 1,
    "mjtNum": 8,
    "mjtSize": 8,
    "size_t": 8,
    "uintptr_t": 8,
}


def _field_size(type_name: str) -> tuple[int, int]:
    """(size, alignment) of an ``introspect`` field type made of scalars or pointers."""
    if type_name.endswith("*"):
        return 8, 8
    base, _, extent = type_name.partition(" [")
    size = _SCALAR_SIZES[base]
    count = int(extent.rstrip("]")) if extent else 1
    return size * count, size


def _offsets(struct_name: str, first_field: str, first_offset: int) -> dict[str, int]:
    """Byte offsets of ``struct_name``'s fields from ``first_field`` on, C alignment rules.

    Stops at the first nested struct; ``"<end>"`` is where the last field read ends, padded to
    8 bytes (the struct's size when every field was read and its widest member is 8 bytes).
    """
    offsets: dict[str, int] = {}
    offset = first_offset
    started = False
    for field in structs.STRUCTS[struct_name].fields:
        started = started or field.name == first_field
        if not started:
            continue
        try:
            size, align = _field_size(str(field.type))
        except (KeyError, ValueError):
            break  # a nested struct: the fields we need come before it
        offset = (offset + align - 1) // align * align
        offsets[field.name] = offset
        offset += size
    offsets["<end>"] = (offset + 7) // 8 * 8
    return offsets


@dataclass(frozen=True)
class DataLayout:
    """Where ``mjData``'s scalars are, in bytes from the struct's start, and ``mjContact``'s."""

    ncon: int
    time: int
    contact: int
    contact_size: int
    contact_geom: int


@functools.cache
def data_layout() -> DataLayout:
    """The layout of this mujoco build's ``mjData``, anchored on the ``timer`` array's view."""
    model = mujoco.MjModel.from_xml_string("<mujoco/>")
    data = mujoco.MjData(model)
    timers = data.timer.duration
    ncon = timers.ctypes.data + timers.strides[0] * len(timers) - data._address
    offsets = _offsets("mjData", "ncon", ncon)
    contact_fields = _offsets("mjContact", "dist", 0)
    return DataLayout(
        ncon=offsets["ncon"],
        time=offsets["time"],
        contact=offsets["contact"],
        contact_size=contact_fields["<end>"],
        contact_geom=contact_fields["geom"],
    )


def disableflags_address(model: mujoco.MjModel) -> int:
    """The address of ``model.opt.disableflags`` (an int), anchored on ``opt.gravity``'s view."""
    gravity = model.opt.gravity.ctypes.data
    offsets = _offsets("mjOption", "gravity", gravity - model._address)
    return int(model._address + offsets["disableflags"])
