"""Genuine ROS 1 Noetic message definitions, kept as ``.msg`` files in ``msg/<package>/``.

`rosbag check` says a bag "does not need any migrations" only when each connection's
``message_definition`` equals the installed message's full text (comments included) and its md5sum
matches; a live ``rospy`` subscriber checks the same. ``rosbags``' Noetic type store has the types
but not the comments, so the ``.msg`` files are vendored verbatim from the Noetic releases that
Debian packages (std_msgs 0.5.13, common_msgs 1.13.1, geometry2 0.7.6, ros_comm_msgs 1.11.3; BSD
licence), and ``vision_msgs`` 4.1.1 (:data:`VISION_MSGS`, ROS 2 Jazzy's release; Apache 2.0),
which Noetic's Debian packages lack. :func:`ros1_definition` assembles the full text as genmsg
does and takes the md5sum from ``rosbags``; ``tests/ros/test_ros1_tools.py`` checks both against
Debian's installed packages (``tests/ros/test_detections.py``: vision_msgs' md5sum with genpy).
"""

from __future__ import annotations

from functools import cache
from importlib import resources

__all__ = ["VISION_MSGS", "full_text", "msg_text", "ros1_definition"]

VISION_MSGS = (
    "vision_msgs/Point2D", "vision_msgs/Pose2D", "vision_msgs/BoundingBox2D",
    "vision_msgs/ObjectHypothesis", "vision_msgs/ObjectHypothesisWithPose",
    "vision_msgs/Detection2D", "vision_msgs/Detection2DArray",
)  # fmt: skip
"""The vendored ``vision_msgs`` types, dependencies first: ``/detections``' message and its parts.

The same text in ROS 1 and ROS 2 bags: vision_msgs 4.x is ROS 2's (Noetic's vision_msgs 1.x has
another ``Detection2D``, and Debian packages no vision_msgs at all), so a ROS 1 bag holds the
Jazzy layout under the name ``vision_msgs/Detection2DArray``, its full text and md5sum in the
connection header: readers that build classes from the bag (``rosbag``, ``rosbags``,
``rostopic echo -b``) decode it; a node built against Noetic's vision_msgs would refuse its md5sum.
"""

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
