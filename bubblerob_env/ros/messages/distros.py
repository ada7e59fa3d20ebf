"""ROS distributions a bag can claim: their ``rosbags`` type stores and message definitions.

A bag carries the definitions of the distro it claims: ROS 1 bags get Noetic's genuine full texts
(comments included, see :mod:`~bubblerob_env.ros.messages.definitions`), ROS 2 bags the Humble
or Jazzy
definitions with their RIHS01 hashes (Jazzy's ``sensor_msgs/Range`` has a ``variance`` field that
Humble's lacks).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from typing import Any

from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from bubblerob_env.ros.messages.definitions import VISION_MSGS, msg_text, ros1_definition

__all__ = [
    "DISTROS",
    "Distro",
    "deserialize",
    "get_distro",
    "message_definition",
    "serialize",
    "typestore",
]


@dataclass(frozen=True)
class Distro:
    """A ROS distribution: its name, ROS version (1 or 2) and ``rosbags`` type store."""

    name: str
    ros_version: int
    store: Stores

    @property
    def encoding(self) -> str:
        """Serialisation format of its messages: ``"ros1"`` or ``"cdr"``."""
        return "ros1" if self.ros_version == 1 else "cdr"


DISTROS: dict[str, Distro] = {
    "noetic": Distro("noetic", 1, Stores.ROS1_NOETIC),
    "humble": Distro("humble", 2, Stores.ROS2_HUMBLE),
    "jazzy": Distro("jazzy", 2, Stores.ROS2_JAZZY),
}
"""The supported distros by name."""


def get_distro(name: str) -> Distro:
    """The distro called ``name``, or a ``ValueError`` listing the known ones."""
    try:
        return DISTROS[name]
    except KeyError:
        raise ValueError(f"unknown ROS distro {name!r}; known: {sorted(DISTROS)}") from None


@cache
def typestore(name: str) -> Typestore:
    """The type store of distro ``name``, completed with the types it lacks.

    ``rosbags``' Noetic store has no ``tf2_msgs/TFMessage`` and no store has ``vision_msgs``:
    their genuine definitions are registered (vision_msgs 4.1.1's, ROS 2 Jazzy's, in every
    distro: see :data:`~bubblerob_env.ros.messages.definitions.VISION_MSGS`).
    """
    store = get_typestore(get_distro(name).store)
    types = {}
    for msgtype in ("tf2_msgs/TFMessage", *VISION_MSGS):
        full_name = msgtype.replace("/", "/msg/")
        if full_name not in store.fielddefs:
            types.update(get_types_from_msg(msg_text(msgtype), full_name))
    store.register(types)
    return store


@cache
def message_definition(name: str, msgtype: str) -> tuple[str, str]:
    """``(definition text, hash)`` of ``msgtype`` in a bag (or on a live topic) of distro ``name``.

    ROS 1: the genuine full text (:func:`~bubblerob_env.ros.messages.definitions.ros1_definition`)
    and the md5sum ``rosbags`` computes; ROS 2: ``ros2msg`` text and RIHS01 hash.
    """
    store = typestore(name)
    if get_distro(name).ros_version == 1:
        _, text = ros1_definition(msgtype)
        _, md5sum = store.generate_msgdef(msgtype, ros_version=1)
        return text, md5sum
    text, _ = store.generate_msgdef(msgtype, ros_version=2)
    return text, store.hash_rihs01(msgtype)


def serialize(name: str, message: Any, msgtype: str) -> bytes:
    """``message`` serialised as distro ``name`` puts it on the wire (ROS 1, little-endian CDR)."""
    store = typestore(name)
    if get_distro(name).encoding == "ros1":
        return bytes(store.serialize_ros1(message, msgtype))
    return bytes(store.serialize_cdr(message, msgtype, little_endian=True))


def deserialize(name: str, raw: bytes, msgtype: str) -> Any:
    """The message of type ``msgtype`` in ``raw`` bytes of distro ``name``."""
    store = typestore(name)
    if get_distro(name).encoding == "ros1":
        return store.deserialize_ros1(raw, msgtype)
    return store.deserialize_cdr(raw, msgtype)
