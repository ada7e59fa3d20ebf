"""JSON messages from Foxglove clients, turned into the CDR bytes the node's controls decode.

Foxglove's Teleop panel (and any client of a server that lists ``json`` first in its
``supportedEncodings``) publishes ROS messages as JSON objects, e.g. a ``geometry_msgs/Twist``
as ``{"linear": {"x": 0.2, "y": 0, "z": 0}, "angular": {"x": 0, "y": 0, "z": 0.5}}``. A field
left out is zero (or empty), as ``ros2 topic pub`` fills it; an unknown field, a wrong type or an
integer out of range is an error, so a typo does not drive the robot with zeros unnoticed.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np

from bubblerob_env.ros.messages.distros import serialize, typestore

__all__ = ["JsonMessageError", "json_to_cdr"]

_NAME, _ARRAY, _SEQUENCE = 2, 3, 4
"""``rosbags``' node types of a field: another message, a fixed array, a sequence."""
_FLOATS = {"float32": np.float32, "float64": np.float64}
_INTS = {
    f"{sign}int{bits}": getattr(np, f"{sign}int{bits}")
    for sign in ("", "u")
    for bits in (8, 16, 32, 64)
} | {"byte": np.uint8, "octet": np.uint8, "char": np.uint8}


class JsonMessageError(ValueError):
    """A JSON message that does not fit its ROS type (the message says where and why)."""


def json_to_cdr(distro: str, msgtype: str, raw: bytes) -> bytes:
    """``raw`` JSON of a ``msgtype`` message, serialised as CDR of ``distro``.

    Raises:
        JsonMessageError: Not JSON, not an object, or a field that does not fit the type.
    """
    try:
        value = json.loads(raw)
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as error:
        raise JsonMessageError(f"not JSON ({error})") from None
    message = _message(distro, msgtype, value, msgtype.rsplit("/", 1)[-1])
    try:
        return serialize(distro, message, msgtype)
    except Exception as error:  # noqa: BLE001 - whatever rosbags raises for a value it cannot pack
        raise JsonMessageError(f"cannot serialise a {msgtype} ({error})") from None


def _message(distro: str, msgtype: str, value: Any, where: str) -> Any:
    store = typestore(distro)
    if not isinstance(value, dict):
        raise JsonMessageError(f"{where}: expected an object for {msgtype}, got {value!r:.60}")
    _, fields = store.fielddefs[msgtype]
    names = [name for name, _ in fields]
    unknown = sorted(set(value) - set(names))
    if unknown:
        raise JsonMessageError(f"{where}: {msgtype} has no field {unknown[0]!r} (has {names})")
    args = {name: _field(distro, kind, value.get(name), f"{where}.{name}") for name, kind in fields}
    return store.types[msgtype](**args)


def _field(distro: str, kind: tuple[Any, Any], value: Any, where: str) -> Any:
    node, detail = kind
    if node == _NAME:
        return _message(distro, detail, {} if value is None else value, where)
    if node in (_ARRAY, _SEQUENCE):
        (item_node, item_detail), length = detail
        items = [] if value is None else value
        if not isinstance(items, list):
            raise JsonMessageError(f"{where}: expected a list, got {items!r:.60}")
        if node == _ARRAY:
            items = items or [None] * length
            if len(items) != length:
                raise JsonMessageError(f"{where}: expected {length} items, got {len(items)}")
        if item_node == 1 and item_detail[0] in (_FLOATS | _INTS):
            dtype = (_FLOATS | _INTS)[item_detail[0]]
            return np.array([_base(item_detail[0], v, where) for v in items], dtype=dtype)
        return [
            _field(distro, (item_node, item_detail), v, f"{where}[{i}]")
            for i, v in enumerate(items)
        ]
    return _base(detail[0], value, where)


def _base(name: str, value: Any, where: str) -> Any:
    """A base-type value (``None``: the type's zero)."""
    if name == "string":
        if value is None or isinstance(value, str):
            return value or ""
        raise JsonMessageError(f"{where}: expected a string, got {value!r:.60}")
    if name == "bool":
        if value is None or isinstance(value, bool):
            return bool(value)
        raise JsonMessageError(f"{where}: expected true or false, got {value!r:.60}")
    if value is None:
        return 0.0 if name in _FLOATS else 0
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise JsonMessageError(f"{where}: expected a number, got {value!r:.60}")
    if name in _FLOATS:
        return float(value)
    if not (isinstance(value, int) or (math.isfinite(value) and value == int(value))):
        raise JsonMessageError(f"{where}: expected an integer, got {value!r}")
    limits = np.iinfo(_INTS[name])
    if not limits.min <= int(value) <= limits.max:
        raise JsonMessageError(f"{where}: {value} is out of range for {name}")
    return int(value)
