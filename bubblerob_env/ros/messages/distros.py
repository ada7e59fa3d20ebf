"""ROS distributions a bag can claim: their ``rosbags`` type stores and message definitions.

A bag carries the definitions of the distro it claims: ROS 1 bags get Noetic's genuine full texts
(comments included, see :mod:`bubblerob_env.ros.ros1_defs`), ROS 2 bags the Humble or Jazzy
definitions with their RIHS01 hashes (Jazzy's ``sensor_msgs/Range`` has a ``variance`` field that
Humble's lacks).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from bubblerob_env.ros import ros1_defs

__all__ = ["DISTROS", "Distro", "get_distro", "message_definition", "typestore"]


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

    ``rosbags``' Noetic store has no ``tf2_msgs/TFMessage``; its genuine definition is registered.
    """
    store = get_typestore(get_distro(name).store)
    if "tf2_msgs/msg/TFMessage" not in store.fielddefs:
        text = ros1_defs.FULL_TEXT["tf2_msgs/TFMessage"].split("\n=")[0]
        store.register(get_types_from_msg(text, "tf2_msgs/msg/TFMessage"))
    return store


@cache
def message_definition(name: str, msgtype: str) -> tuple[str, str]:
    """``(definition text, hash)`` of ``msgtype`` as a bag of distro ``name`` stores it.

    ROS 1: the genuine full text and its md5sum; ROS 2: ``ros2msg`` text and RIHS01 hash.
    """
    distro = get_distro(name)
    store = typestore(name)
    if distro.ros_version == 1:
        ros1_name = msgtype.replace("/msg/", "/")
        if ros1_name not in ros1_defs.FULL_TEXT:
            raise KeyError(f"no vendored ROS 1 definition for {msgtype}")
        _, md5sum = store.generate_msgdef(msgtype, ros_version=1)
        if md5sum != ros1_defs.MD5SUM[ros1_name]:
            raise RuntimeError(
                f"rosbags' Noetic {msgtype} (md5 {md5sum}) differs from the genuine definition "
                f"(md5 {ros1_defs.MD5SUM[ros1_name]})"
            )
        return ros1_defs.FULL_TEXT[ros1_name], md5sum
    text, _ = store.generate_msgdef(msgtype, ros_version=2)
    return text, store.hash_rihs01(msgtype)
