"""What the live node needs from a ROS client library, and the errors of starting one.

A backend publishes bytes that are already serialised for its distro (``ros1`` for ROS 1, CDR for
ROS 2: the same bytes a bag of that distro holds) and hands received control messages over as
raw bytes with the type the sender claimed, so that decoding and validation are shared
(:mod:`~bubblerob_env.ros.live.controls`). :mod:`~bubblerob_env.ros.live.ros1` (``rospy``) and
:mod:`~bubblerob_env.ros.live.ros2` (``rclpy``) implement it;
:func:`~bubblerob_env.ros.live.connect.load_backend` starts one.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable

__all__ = [
    "BackendError",
    "LiveBackend",
    "MasterUnreachableError",
    "Publish",
    "RawCallback",
    "RosUnavailableError",
]

Publish = Callable[[bytes], None]
"""Publishes one serialised message on the topic it was made for."""

RawCallback = Callable[[bytes, "str | None", str], None]
"""``callback(raw, msgtype, sender)``: ``msgtype`` as the sender declared it (ROS 1 style
``pkg/Type``), ``None`` where the middleware already checked it."""


class BackendError(RuntimeError):
    """The ROS middleware cannot be used (the message says why and what to do)."""


class RosUnavailableError(BackendError):
    """The ROS client library (``rospy`` or ``rclpy``) cannot be imported."""


class MasterUnreachableError(BackendError):
    """No ROS 1 master answers at ``ROS_MASTER_URI``."""


class LiveBackend(ABC):
    """A ROS node that publishes serialised messages and subscribes to raw control messages."""

    ros_version: int
    distro: str
    """Whose message definitions the bytes follow: ``noetic``, ``humble`` or ``jazzy``."""

    @abstractmethod
    def advertise(self, topic: str, msgtype: str, latched: bool = False) -> Publish:
        """Start publishing ``topic`` of ``msgtype`` (``pkg/msg/Type``); returns its publish."""

    @abstractmethod
    def subscribe(self, topic: str, msgtype: str, callback: RawCallback) -> None:
        """Call ``callback`` with every message received on ``topic`` (from another thread)."""

    @abstractmethod
    def ok(self) -> bool:
        """False once the node has been shut down (Ctrl-C, ``rosnode kill``, :meth:`shutdown`)."""

    @abstractmethod
    def shutdown(self, reason: str = "done") -> None:
        """Stop the node: unregister every publisher and subscriber. Safe to call twice."""

    @abstractmethod
    def log(self, level: str, text: str) -> None:
        """Log ``text`` at ``level`` (``"info"`` or ``"warn"``) the middleware's way (rosout)."""
