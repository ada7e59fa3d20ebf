"""Genuine ROS 1 Noetic message definitions, kept as ``.msg`` files in ``msg/<package>/``.

`rosbag check` says a bag "does not need any migrations" only when each connection's
``message_definition`` equals the installed message's full text (comments included) and its md5sum
matches; a live ``rospy`` subscriber checks the same. ``rosbags``' Noetic type store has the types
but not the comments, so the ``.msg`` files are vendored verbatim from the Noetic releases that
Debian packages (std_msgs 0.5.13, common_msgs 1.13.1, geometry2 0.7.6, ros_comm_msgs 1.11.3; BSD
licence). :func:`ros1_definition` assembles the full text as genmsg does and takes the md5sum from
``rosbags``; ``tests/ros/test_ros1_tools.py`` checks both against Debian's installed packages.
"""

from __future__ import annotations

from functools import cache
from importlib import resources

__all__ = ["full_text", "msg_text", "ros1_definition"]

_SEPARATOR = "=" * 80 + "\n"
_BUILTIN = {
    "bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64",
    "uint64", "float32", "float64", "string", "time", "duration",
}  # fmt: skip


@cache
def msg_text(name: str) -> str:
    """The ``.msg`` file of ``name`` (``pkg/Type``) as shipped; ``KeyError`` if none is."""
    package, _, message = name.partition("/")
    path = resources.files(__package__) / "msg" / package / f"{message}.msg"
    if not path.is_file():
        raise KeyError(f"no vendored ROS 1 definition for {name}")
    return path.read_text(encoding="utf-8")


def _depends(name: str) -> list[str]:
    """Types of ``name``'s fields that are messages, in field order (genmsg's ``load_depends``)."""
    package = name.partition("/")[0]
    found = []
    for line in msg_text(name).splitlines():
        line = line.partition("#")[0].strip()
        if not line or "=" in line:  # blank, comment or constant
            continue
        base = line.split()[0].partition("[")[0]
        if base in _BUILTIN:
            continue
        if base == "Header":
            base = "std_msgs/Header"
        found.append(base if "/" in base else f"{package}/{base}")
    return found


def _all_depends(name: str) -> list[str]:
    """Every embedded type, depth first, each once (genmsg's ``get_all_depends``)."""
    found: list[str] = []
    for dependency in _depends(name):
        for each in (dependency, *_all_depends(dependency)):
            if each not in found:
                found.append(each)
    return found


@cache
def full_text(name: str) -> str:
    """Genmsg's full text of ``name``: its ``.msg``, then each embedded type's after a separator."""
    text = msg_text(name) + "\n"
    for dependency in _all_depends(name):
        text += f"{_SEPARATOR}MSG: {dependency}\n{msg_text(dependency)}\n"
    return text[:-1]  # genmsg drops the last newline


def ros1_definition(msgtype: str) -> tuple[str, str]:
    """``(ROS 1 type name, full text)`` of ``msgtype`` (``pkg/msg/Type`` or ``pkg/Type``)."""
    name = msgtype.replace("/msg/", "/")
    return name, full_text(name)
